"""Every user error of every `rast` subcommand: one message `rast <cmd>: ...` on
stderr, exit status 2, no traceback, and nothing created.

Run in-process through ``rast.cli.main`` (an exception escaping it would fail
the test with its traceback), plus one run of the real executable. No test
starts a bitstream build: ``rast.gateware.build.build`` is replaced by a trap.
"""

import json
import subprocess
import sys

import numpy as np
import pytest

from rast.cli import main
from rast.model.contract.fixedpoint import ReplayContract, pack_iq
from rast.model.contract.regmap import stream_crc32

CONFIG = ('sample_rate = 20\nradar_frequency = 5350\n'
          '[[windmill]]\nname = "a"\nrange = 2.0\nnum_blades = 3\nrpm = 15\nradius = [26.0]\nrsc = [1.0]\n')


def rast(argv, capsys):
    """Exit status and stderr of ``rast argv`` (argparse's own errors exit through SystemExit)."""
    try:
        status = main([str(a) for a in argv])
    except SystemExit as exc:
        status = exc.code
    out, err = capsys.readouterr()
    return status, err


def assert_user_error(status, err, command, *needles):
    assert status == 2, err
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.startswith(f"rast {command}: ")]
    assert len(lines) == 1, err
    for needle in needles:
        assert needle in err, f"{needle!r} not in {err!r}"


@pytest.fixture
def config(tmp_path):
    path = tmp_path / "farm.toml"
    path.write_text(CONFIG)
    return path


def write_manifest(folder, lengths=(3,), delays=(100,), increment=1 << 31):
    """A `rast stream`-shaped manifest with short streams, as in test_hdl_verilog."""
    folder.mkdir(parents=True, exist_ok=True)
    wms, chans = [], []
    for k, (n, d) in enumerate(zip(lengths, delays)):
        words = pack_iq(list(range(100, 100 + n)), [0] * n)
        (folder / f"w{k}.hex").write_text("".join(f"{int(w):08x}\n" for w in words))
        wms.append({"name": f"w{k}", "hex_file": f"w{k}.hex", "length": n, "crc32": stream_crc32(words)})
        chans.append({"windmill": f"w{k}", "enable": 1, "length": n, "phase_increment": increment,
                      "gain": 1 << 16, "delay_samples": d})
    manifest = {"format": "rast-manifest/2", "windmills": wms, "registers": {"channels": chans}}
    (folder / "manifest.json").write_text(json.dumps(manifest))
    return folder / "manifest.json"


# --------------------------------------------------------------------- stream

def test_stream_missing_config(tmp_path, capsys):
    out = tmp_path / "out"
    assert_user_error(*rast(["stream", tmp_path / "nope.toml", "--out", out], capsys), "stream",
                      "nope.toml", "cannot read the config", "No such file")
    assert not out.exists()


def test_stream_config_is_a_folder(tmp_path, capsys):
    out = tmp_path / "out"
    assert_user_error(*rast(["stream", tmp_path, "--out", out], capsys), "stream", "cannot read the config")
    assert not out.exists()


def test_stream_malformed_toml(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("sample_rate = = 20\n")
    out = tmp_path / "out"
    assert_user_error(*rast(["stream", bad, "--out", out], capsys), "stream", "bad.toml", "is not valid TOML")
    assert not out.exists()


def test_stream_bad_value_names_windmill_and_key(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text(CONFIG.replace("rpm = 15", "rpm = -15"))
    out = tmp_path / "out"
    assert_user_error(*rast(["stream", bad, "--out", out], capsys), "stream",
                      "windmill 'a'", "'rpm' must be positive, not -15")
    assert not out.exists()


def test_stream_out_is_a_file(config, tmp_path, capsys):
    out = tmp_path / "out"
    out.write_text("keep me")
    assert_user_error(*rast(["stream", config, "--out", out], capsys), "stream",
                      "--out", "exists and is not a folder")
    assert out.read_text() == "keep me"


def test_stream_out_below_a_file(config, tmp_path, capsys):
    (tmp_path / "file").write_text("")
    out = tmp_path / "file" / "sub" / "out"
    assert_user_error(*rast(["stream", config, "--out", out], capsys), "stream", "is a file, not a folder")
    assert (tmp_path / "file").is_file()


def test_stream_without_out(config, capsys):
    assert_user_error(*rast(["stream", config], capsys), "stream", "--out")


# -------------------------------------------------------------------- preview

def test_preview_shorter_than_one_cpi(config, tmp_path, capsys):
    png = tmp_path / "pics" / "p.png"
    assert_user_error(*rast(["preview", config, "--out", png, "--seconds", "0.05"], capsys), "preview",
                      "--seconds 0.05 gives 1000 pulses", "one CPI of 100 ms (2000 pulses)")
    assert not png.parent.exists()


@pytest.mark.parametrize("option, value, needle", [
    ("--seconds", "-1", "positive number of seconds"),
    ("--seconds", "nan", "positive number of seconds"),
    ("--overlap", "1", "fraction in [0, 1)"),
    ("--dynamic-range", "0", "positive number of dB"),
])
def test_preview_bad_number(config, tmp_path, capsys, option, value, needle):
    png = tmp_path / "pics" / "p.png"
    assert_user_error(*rast(["preview", config, "--out", png, option, value], capsys), "preview",
                      option, needle, value)
    assert not png.parent.exists()


def test_preview_out_is_a_folder(config, tmp_path, capsys):
    assert_user_error(*rast(["preview", config, "--out", tmp_path, "--seconds", "1"], capsys), "preview",
                      "is a folder, not a file")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["farm.toml"]


def test_preview_missing_config(tmp_path, capsys):
    png = tmp_path / "pics" / "p.png"
    assert_user_error(*rast(["preview", tmp_path / "nope.toml", "--out", png], capsys), "preview",
                      "nope.toml", "cannot read the config")
    assert not png.parent.exists()


def test_cosim_pri_of_no_whole_samples(tmp_path, capsys):
    """A PRF that gives no whole number of RTS samples per PRI (20 MHz / 12 kHz)
    is named, with the nearest PRFs that do, before the output folder exists."""
    config = tmp_path / "farm.toml"
    config.write_text(CONFIG.replace("radar_frequency = 5350\n", "radar_frequency = 5350\nprf = 12000\n"))
    out = tmp_path / "cosim"
    assert_user_error(*rast(["cosim", config, "--seconds", "0.01", "--out", out], capsys), "cosim",
                      "the PRI must be a whole number of RTS samples", "prf 12000 Hz = 1666.67 samples",
                      "prf 11997.6 Hz gives 1667", "12004.8 Hz gives 1666")
    assert not out.exists()


# -------------------------------------------------------------------- verilog

VERILOG = ["verilog", "--channels", "1", "--pool-words", "16", "--max-delay", "126",
           "--max-tap", "2"]


def verilog_error(capsys, tmp_path, extra, *needles):
    out = tmp_path / "v" / "top.v"
    assert_user_error(*rast(VERILOG + extra + ["-o", out], capsys), "verilog", *needles)
    assert not out.parent.exists()


def test_verilog_missing_manifest(tmp_path, capsys):
    verilog_error(capsys, tmp_path, ["--manifest", tmp_path / "m" / "manifest.json"],
                  "cannot read the manifest", "manifest.json", "No such file")


def test_verilog_manifest_folder_without_manifest(tmp_path, capsys):
    (tmp_path / "m").mkdir()
    verilog_error(capsys, tmp_path, ["--manifest", tmp_path / "m"], "cannot read the manifest",
                  "m/manifest.json")


def test_verilog_manifest_not_json(tmp_path, capsys):
    (tmp_path / "manifest.json").write_text("{windmills: [}")
    verilog_error(capsys, tmp_path, ["--manifest", tmp_path / "manifest.json"],
                  "manifest.json is not valid JSON", "line 1")


def test_verilog_manifest_lacks_registers(tmp_path, capsys):
    path = write_manifest(tmp_path / "m")
    manifest = json.loads(path.read_text())
    del manifest["registers"]
    path.write_text(json.dumps(manifest))
    verilog_error(capsys, tmp_path, ["--manifest", path], "has no 'registers.channels' list")


def test_verilog_manifest_channel_lacks_gain(tmp_path, capsys):
    path = write_manifest(tmp_path / "m")
    manifest = json.loads(path.read_text())
    manifest["registers"]["channels"][0]["gain"] = "loud"
    path.write_text(json.dumps(manifest))
    verilog_error(capsys, tmp_path, ["--manifest", path], "registers.channels[0]", "the integer 'gain'")


def test_verilog_stream_file_missing(tmp_path, capsys):
    path = write_manifest(tmp_path / "m")
    (tmp_path / "m" / "w0.hex").unlink()
    verilog_error(capsys, tmp_path, ["--manifest", path], "cannot read the stream file", "w0.hex")


def test_verilog_stream_file_bad_word(tmp_path, capsys):
    path = write_manifest(tmp_path / "m")
    hexfile = tmp_path / "m" / "w0.hex"
    lines = hexfile.read_text().splitlines()
    lines[1] = "12345G78"
    hexfile.write_text("\n".join(lines) + "\n")
    verilog_error(capsys, tmp_path, ["--manifest", path], "w0.hex: line 2", "'12345G78'", "32-bit hex word")


def test_verilog_stream_file_wrong_length(tmp_path, capsys):
    path = write_manifest(tmp_path / "m", lengths=(3,))
    hexfile = tmp_path / "m" / "w0.hex"
    hexfile.write_text("".join(hexfile.read_text().splitlines(keepends=True)[:2]))
    verilog_error(capsys, tmp_path, ["--manifest", path], "w0.hex has 2 words, the manifest says 3")


def test_verilog_stream_file_changed_after_its_crc(tmp_path, capsys):
    """A stream file edited after `rast stream` wrote it (same length, one word
    changed) no longer has the manifest's CRC-32: refused, naming both."""
    path = write_manifest(tmp_path / "m", lengths=(3,))
    m = json.loads(path.read_text())
    hexfile = tmp_path / "m" / "w0.hex"
    words = [int(x, 16) for x in hexfile.read_text().split()]
    m["windmills"][0]["crc32"] = stream_crc32(words)
    path.write_text(json.dumps(m))
    hexfile.write_text("".join(f"{w ^ (k == 1):08x}\n" for k, w in enumerate(words)))
    verilog_error(capsys, tmp_path, ["--manifest", path], "w0.hex has CRC-32",
                  f"the manifest says {stream_crc32(words):#010x}", "the file changed after `rast stream`")


def test_manifest_with_a_crc_that_is_no_32_bit_word(tmp_path, capsys):
    path = write_manifest(tmp_path / "m")
    m = json.loads(path.read_text())
    m["windmills"][0]["crc32"] = -1
    path.write_text(json.dumps(m))
    verilog_error(capsys, tmp_path, ["--manifest", path], "windmills[0]",
                  "'crc32' that is not a 32-bit unsigned integer: -1")


def test_verilog_manifest_does_not_fit(tmp_path, capsys):
    path = write_manifest(tmp_path / "m", lengths=(3, 4), delays=(100, 102))
    verilog_error(capsys, tmp_path, ["--manifest", path], "does not fit a block of 1 channel(s)",
                  "2 windmills")


def test_verilog_manifest_deeper_than_the_window(tmp_path, capsys):
    verilog = [v if v != "1" else "2" for v in VERILOG] + ["--interpolation", "hold"]   # 2 channels, taps up to 2
    path = write_manifest(tmp_path / "m", lengths=(8, 8), delays=(100, 103))
    m = json.loads(path.read_text())
    for ch in m["registers"]["channels"]:
        ch["phase_increment"] = 1 << 20
    path.write_text(json.dumps(m))
    out = tmp_path / "v" / "top.v"
    assert_user_error(*rast(verilog + ["--manifest", path, "-o", out], capsys), "verilog",
                      "Windmill 'w1' (channel 1) lies 3 samples beyond the common delay",
                      "the delay window reaches 2: the farm is 3 samples deep")
    assert not out.parent.exists()


def test_manifest_of_chained_delays_is_refused(tmp_path, capsys):
    path = write_manifest(tmp_path / "m")
    m = json.loads(path.read_text())
    ch = m["registers"]["channels"][0]
    ch["delay_increment"] = ch.pop("delay_samples")
    path.write_text(json.dumps(m))
    verilog_error(capsys, tmp_path, ["--manifest", path], "registers.channels[0]",
                  "'delay_increment' (a manifest of chained delays, from an older rast)",
                  "run 'rast stream' again")


def test_verilog_manifest_stream_longer_than_the_ram(tmp_path, capsys):
    path = write_manifest(tmp_path / "m", lengths=(20,))
    verilog_error(capsys, tmp_path, ["--manifest", path], "pool words 16",
                  "Stream length of channel 0 ('w0') must be in [8, 16] words, not 20")


def test_verilog_bad_pool_words(tmp_path, capsys):
    out = tmp_path / "v" / "top.v"
    status, err = rast(["verilog", "--pool-words", "1000", "-o", out], capsys)
    assert_user_error(status, err, "verilog", "bad replay block parameters",
                      "Pool words must be a power of two from 16 to 16384 or a multiple of 16384, not 1000")
    assert not out.parent.exists()


def test_verilog_bad_module_name(tmp_path, capsys):
    verilog_error(capsys, tmp_path, ["--name", "3top"], "--name '3top' is not a Verilog identifier")


def test_verilog_output_is_a_folder(tmp_path, capsys):
    status, err = rast(VERILOG + ["-o", tmp_path], capsys)
    assert_user_error(status, err, "verilog", "--output", "is a folder, not a file")
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------- build

@pytest.fixture
def no_build(monkeypatch):
    """Fail the test if a bitstream build would start."""
    import rast.gateware.build as gb

    def trap(*args, **kwargs):
        raise AssertionError("a build started: the error was not caught before it")
    monkeypatch.setattr(gb, "build", trap)


@pytest.mark.parametrize("args, needles", [
    (["--channels", "160", "--pool-words", "16384", "--max-tap", "510"],
     ["160 channels (20 pipelines of 8 slots)", "need 200 MULT18X18D", "the LFE5U-85F has 156"]),
    (["--pool-words", "98304"], ["98304-word stream pool", "DP16KD block RAMs", "the LFE5U-85F has 208"]),
    (["--board", "ulx3s-25f", "--channels", "4"], ["4 channels", "need 148 DP16KD", "the LFE5U-25F has 56"]),
    (["--clock-mhz", "1000"], ["PLL output frequency must be in", "not 1000.0"]),
    (["--clock-mhz", "0"], ["Clock must be a positive number of MHz"]),
    (["--clock-mhz", "210"], ["Clock 210 MHz must be a whole multiple of the sample rate 20 MHz"]),
    # at 100 MS/s the default fabric clock is 100 MHz, one slot a pipeline
    (["--sample-rate-mhz", "100"], ["64 channels (64 pipelines of 1 slots)", "need 400 DP16KD"]),
    (["--sample-rate-mhz", "-20"], ["Sample rate must be a positive number of MHz"]),
    (["--baud", "60000000"], ["Baud rate 60000000 is outside what the board's USB UART (FT231X) makes"]),
    (["--baud", "7"], ["Baud rate 7 is outside", "300 to 3000000 baud"]),
    (["--clock-mhz", "inf"], ["Clock must be a positive number of MHz, not inf"]),
    (["--pool-words", "1000"], ["Pool words must be a power of two from 16 to 16384", "not 1000"]),
    (["--channels", "0"], ["Channel count must be a positive integer, not 0"]),
    (["--board", "none"], ["--board none needs --device"]),
    (["--board", "ulx3s-25f", "--device", "LFE5U-85F"], ["leave out --board ulx3s-25f"]),
    (["--device", "LFE5U-85F", "--package", "XX"], ["ECP5 package must be one of", "'XX'"]),
    (["--device", "LFE5U-85F", "--speed", "9"], ["speed grade must be 6, 7 or 8"]),
    (["--device", "LFE5U-85F", "--package", "BG756"], ["needs a pin map"]),
    (["--pinmap", "pins.json"], ["--pinmap is for a plain device"]),
])
def test_build_bad_arguments(tmp_path, capsys, no_build, args, needles):
    out = tmp_path / "bit"
    assert_user_error(*rast(["build", *args, "--out", out], capsys), "build", *needles)
    assert not out.exists()


@pytest.mark.parametrize("content, needles", [
    (None, ["Cannot read the pin map", "pins.json", "No such file"]),
    ("{\"clk\": ", ["pin map", "pins.json is not valid JSON"]),
    ("[1, 2]", ["pins.json must be a JSON object"]),
    ('{"clk": "G2", "clk_mhz": 25}', ["pins.json lacks uart_rx, uart_tx, adc_data"]),
])
def test_build_bad_pinmap(tmp_path, capsys, no_build, content, needles):
    pins = tmp_path / "pins.json"
    if content is not None:
        pins.write_text(content)
    out = tmp_path / "bit"
    assert_user_error(*rast(["build", "--device", "LFE5U-85F", "--pinmap", pins, "--out", out], capsys),
                      "build", *needles)
    assert not out.exists()


def test_build_short_data_bus_in_pinmap(tmp_path, capsys, no_build):
    from rast.gateware.platforms import _default_ball_pinmap
    pm = _default_ball_pinmap()
    pm["dac_data"] = pm["dac_data"][:15]
    (tmp_path / "pins.json").write_text(json.dumps(pm))
    out = tmp_path / "bit"
    status, err = rast(["build", "--device", "LFE5U-85F", "--pinmap", tmp_path / "pins.json",
                        "--out", out], capsys)
    assert_user_error(status, err, "build", "entry dac_data must list 16 balls")
    assert not out.exists()


def test_build_out_is_a_file(tmp_path, capsys, no_build):
    out = tmp_path / "bit"
    out.write_text("keep me")
    assert_user_error(*rast(["build", "--out", out], capsys), "build", "--out", "exists and is not a folder")
    assert out.read_text() == "keep me"


# ----------------------------------------------------------------------- load

def test_load_without_manifest_or_status(capsys):
    assert_user_error(*rast(["load", "--port", "/dev/null"], capsys), "load", "give MANIFEST_DIR")


def test_load_missing_manifest_is_reported_before_the_port(tmp_path, capsys):
    # The manifest is checked first: the message is about it, not about the port.
    assert_user_error(*rast(["load", tmp_path / "nope", "--port", tmp_path / "tty"], capsys), "load",
                      "cannot read the manifest", "nope")


def test_load_missing_stream_file(tmp_path, capsys):
    write_manifest(tmp_path / "m")
    (tmp_path / "m" / "w0.hex").unlink()
    assert_user_error(*rast(["load", tmp_path / "m", "--port", tmp_path / "tty"], capsys), "load",
                      "cannot read the stream file", "w0.hex")


def test_load_port_cannot_be_opened(tmp_path, capsys):
    write_manifest(tmp_path / "m")
    port = tmp_path / "ttyUSB9"
    assert_user_error(*rast(["load", tmp_path / "m", "--port", port], capsys), "load",
                      f"cannot open the serial port {port}: No such file or directory")
    assert not port.exists()


def test_load_bad_baud(tmp_path, capsys):
    write_manifest(tmp_path / "m")
    assert_user_error(*rast(["load", tmp_path / "m", "--port", "/dev/null", "--baud", "0"], capsys),
                      "load", "--baud must be a positive number")


def test_load_manifest_that_does_not_fit_writes_nothing(tmp_path, capsys, monkeypatch):
    import serial
    import rast.load as rl
    sent = []

    class Port:
        """A serial port that records what is sent and never answers."""
        def __init__(self, *args, **kwargs): pass
        def __enter__(self): return self
        def __exit__(self, *exc): return False
        def write(self, data): sent.append(bytes(data))
        def read(self, n): return b""
        def reset_input_buffer(self): pass

    bitstream = ReplayContract(channels=1, pool_words=64, max_delay=60, max_tap=14)
    monkeypatch.setattr(serial, "Serial", Port)
    monkeypatch.setattr(rl, "read_contract", lambda bridge: bitstream)
    write_manifest(tmp_path / "m", lengths=(3, 4), delays=(100, 102))
    assert_user_error(*rast(["load", tmp_path / "m", "--port", "fake"], capsys), "load",
                      "does not fit the bitstream's replay block (1 channel(s), pool words 64",
                      "2 windmills")
    assert sent == []


def _model_port(monkeypatch, contract):
    """serial.Serial replaced by a board that answers from the bit-exact model,
    on which time passes: 5000 samples for every reply read."""
    import serial
    from rast.model.contract.datapath import ReplayModel
    from rast.sim.uart_chain import ModelBoard
    board = ModelBoard(ReplayModel(contract))
    quiet = np.zeros(5000, dtype=np.int64)

    class Port:
        def __init__(self, *args, **kwargs): pass
        def __enter__(self): return self
        def __exit__(self, *exc): return False
        def write(self, data): board.write(data)

        def read(self, n):
            board.model.run(quiet, quiet)
            return board.read(n)

        def reset_input_buffer(self): pass
    monkeypatch.setattr(serial, "Serial", Port)
    return board


def test_load_verify_reads_the_streams_back_out_of_the_sdram(tmp_path, capsys, monkeypatch):
    from rast.model.contract.regmap import stream_crc32
    board = _model_port(monkeypatch, ReplayContract(channels=2, pool="sdram", pool_words=1 << 12,
                                                    max_delay=120, max_tap=14))
    write_manifest(tmp_path / "m", lengths=(8, 9), delays=(100, 102), increment=1 << 20)
    assert main(["load", str(tmp_path / "m"), "--port", "fake", "--verify"]) == 0
    assert "read 17 stream words back out of the SDRAM" in capsys.readouterr().out
    # the last read-back on the board was the second stream's
    assert board.model.check_crc == stream_crc32(pack_iq(list(range(100, 109)), [0] * 9))


def test_load_verify_on_a_block_ram_bitstream_writes_nothing(tmp_path, capsys, monkeypatch):
    board = _model_port(monkeypatch, ReplayContract(channels=2, pool_words=64, max_delay=120, max_tap=14))
    write_manifest(tmp_path / "m", lengths=(3, 4), delays=(100, 102))
    assert_user_error(*rast(["load", tmp_path / "m", "--port", "fake", "--verify"], capsys), "load",
                      "block RAM, which has no read-back")
    assert board.applied == []


def test_load_says_whether_it_was_live_or_muted(tmp_path, capsys, monkeypatch):
    board = _model_port(monkeypatch, ReplayContract(channels=2, pool_words=64, max_delay=120, max_tap=14,
                                                    sample_rate_hz=1_000_000))
    write_manifest(tmp_path / "a", lengths=(8, 9), delays=(100, 102), increment=1 << 20)
    write_manifest(tmp_path / "b", lengths=(10, 8), delays=(100, 102), increment=1 << 20)
    assert main(["load", str(tmp_path / "a"), "--port", "fake"]) == 0
    assert main(["load", str(tmp_path / "b"), "--port", "fake"]) == 0
    out = capsys.readouterr().out
    # the second load went beside the first, whose longest period is 9 words at 2**-12 word a sample
    assert "live: no channel turned off; each playing channel switches at its old stream's next " \
           "period boundary, within 0.04 s, then refills its word cache for" in out
    # done once both switched: a bank each, and the second load's streams
    assert board.model.pending == [0, 0] and board.model.bank == [0, 0] and board.model.base_act == [17, 27]
    assert main(["load", str(tmp_path / "a"), "--port", "fake", "--muted"]) == 0
    assert "muted: every channel was off during the load (as --muted asks)" in capsys.readouterr().out
    assert board.model.pending == [0, 0] and board.model.base_act == [0, 8]


# ------------------------------------------------------------ the executable

def test_executable_reports_without_traceback(tmp_path):
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-m", "rast.cli", "stream", str(tmp_path / "nope.toml"),
                           "--out", str(out)], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert proc.stderr.startswith("rast stream: ") and "cannot read the config" in proc.stderr
    assert "Traceback" not in proc.stderr and proc.stdout == ""
    assert not out.exists()
