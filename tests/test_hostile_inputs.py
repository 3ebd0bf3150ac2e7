"""RAST tried as a hostile new user would: every bad input to every
subcommand ends in one line ``rast <command>: ...`` on stderr, exit status 2,
and nothing created or replaced; a load over a line that damages one frame
(any frame, any bit, either way) either takes effect whole or says it did
not, on a simulated board on a pseudo-terminal (``rast.sim.pty_board``).

The cases are tables, so that a reader sees what was tried; the counts are
in the closing note of the work that made them."""

import contextlib
import csv
import io
import json
import os
import resource
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rast.cli import main
from rast.model.contract.datapath import ReplayModel
from rast.model.contract.fixedpoint import ReplayContract, pack_iq
from rast.model.contract.regmap import stream_crc32
from rast.sim.pty_board import Damage, PtyBoard

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "two_windmills.toml"
LAYOUT = ROOT / "examples" / "farm_layout_uswtdb.csv"
RECORDING = ROOT / "examples" / "recording_15rpm.npy"

WINDMILL = ('[[windmill]]\nname = "{name}"\nrange = {range}\nnum_blades = 3\nrpm = {rpm}\n'
            'radius = [26.0]\nrsc = [{rsc}]\n')


def farm_toml(head="", **windmill):
    keys = dict(name="a", range=2.0, rpm=15, rsc=1.0) | windmill
    return f"sample_rate = 20\nradar_frequency = 5350\n{head}\n" + WINDMILL.format(**keys)


def run_rast(argv):
    """(status, stdout, stderr) of ``rast argv`` in this process."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status = main([str(a) for a in argv])
        except SystemExit as exc:               # argparse's own errors
            status = exc.code
    return status, out.getvalue(), err.getvalue()


def refused(argv, command, *needles, untouched=()):
    """``rast argv`` is refused in one line naming the problem; ``untouched``
    (paths) are as they were before."""
    before = {Path(p): _snapshot(Path(p)) for p in untouched}
    status, _, err = run_rast(argv)
    assert status == 2, err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"rast {command}: "), err
    for needle in needles:
        assert needle in err, f"{needle!r} not in {err!r}"
    for path, snap in before.items():
        assert _snapshot(path) == snap, f"{path} changed"


def _snapshot(path):
    if path.is_symlink() or not path.exists():
        return None
    if path.is_dir():
        return {p.name: _snapshot(p) for p in sorted(path.iterdir())}
    if path.is_file():
        return path.read_bytes()
    return path.stat().st_mode


# ---- config files -------------------------------------------------------------

CONFIG_CASES = {
    "binary": (b"\x00\x01\x02\x03 not text", ["binary file"]),
    "invalid UTF-8": (b"sample_rate = 20 # \xff\xfe\n", ["not UTF-8 text"]),
    "deep nesting": (b"a = " + b"[" * 5000 + b"]" * 5000 + b"\n", ["nests arrays or tables too deeply"]),
    "NaN range": (farm_toml(range="nan").encode(), ["'range' must be a number, not nan"]),
    "inf rpm": (farm_toml(rpm="inf").encode(), ["'rpm' must be a number, not inf"]),
    "huge range": (farm_toml(range="1e300").encode(), ["'range' must be at most 100000 km"]),
    "huge rcs": (farm_toml(rsc="1e300").encode(), ["'rsc' must hold values of at most"]),
    "huge integer rpm": (farm_toml(rpm=10 ** 400).encode(), ["'rpm' must be a number"]),
    "NaN flash angle": ((farm_toml() + 'rsc_weighting = { angle = [nan], width = 5, gain_db = 6 }\n').encode(),
                        ["'angle' must be a number or a list of numbers"]),
    "huge flash gain": ((farm_toml() + 'rsc_weighting = { angle = [0], width = 5, gain_db = 1e300 }\n').encode(),
                        ["'gain_db' must be at most 300 dB"]),
    "inf weight table": ((farm_toml() + 'rsc_weighting = [[1, inf]]\n').encode(), ["'rsc_weighting' must be a table"]),
    "gain below every word": (farm_toml("output_gain_db = -200").encode(), ["makes every gain word 0"]),
    "zero echo": ((farm_toml() + WINDMILL.format(name="ghost", range=1.0, rpm=15, rsc=0.0)).encode(),
                  ["windmill 'ghost': its echo is identically zero"]),
    "seed mode at 0.001 rpm": (farm_toml('interpolation = "hold"\nstream_rate = "rts"', rpm=0.001).encode(),
                               ["needs 400,000,000,000 words"]),
    "hold rate above the sample rate": (
        b'sample_rate = 0.005\nradar_frequency = 5350\ninterpolation = "hold"\n'
        + WINDMILL.format(name="fast", range=2.0, rpm=15, rsc=1.0).encode().replace(b"[26.0]", b"[40.0]"),
        ["its automatic stream rate", "exceeds the RTS sample rate"]),
    "stream rate that rounds to 0": ((farm_toml(rpm=0.01) + "stream_rate = 0.000001\n").encode(),
                                     ["phase increment rounds to 0"]),
}


@pytest.mark.parametrize("case", sorted(CONFIG_CASES))
def test_a_bad_config_is_refused_and_nothing_written(tmp_path, case):
    text, needles = CONFIG_CASES[case]
    cfg = tmp_path / "bad.toml"
    cfg.write_bytes(text)
    out = tmp_path / "out"
    refused(["stream", cfg, "--out", out], "stream", *needles)
    assert not out.exists()


def test_a_config_with_a_byte_order_mark_is_read(tmp_path):
    cfg = tmp_path / "bom.toml"
    cfg.write_bytes(b"\xef\xbb\xbf" + farm_toml().encode())
    status, out, err = run_rast(["stream", cfg, "--out", tmp_path / "out"])
    assert status == 0, err
    assert (tmp_path / "out" / "a.hex").exists()


def test_a_gain_that_rounds_to_zero_is_said_by_name(tmp_path):
    """A turbine 110 dB below the loudest plays silent: rast stream says so."""
    cfg = tmp_path / "far.toml"
    cfg.write_text(farm_toml() + WINDMILL.format(name="far", range=2000.0, rpm=15, rsc=1e-4))
    status, out, err = run_rast(["stream", cfg, "--out", tmp_path / "out"])
    assert status == 0, err
    assert "rast stream: warning: windmill 'far': its gain" in err and "rounds to 0" in err
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    far = next(w for w in manifest["windmills"] if w["name"] == "far")
    assert far["gain_word"] == 0
    # what the block plays is stated: the increment's rate and period
    for w in manifest["windmills"]:
        assert w["played_stream_rate_hz"] == w["phase_increment"] / 2 ** 32 * 20e6
        assert w["played_period_s"] == pytest.approx(w["length"] / w["played_stream_rate_hz"], rel=1e-12)


# ---- outputs --------------------------------------------------------------------

def test_outputs_replace_regular_files_only(tmp_path):
    refused(["stream", EXAMPLE, "--out", ""], "stream", "--out is empty")
    refused(["preview", EXAMPLE, "--seconds", "1", "--out", "/dev/null"], "preview",
            "/dev/null is a character device")
    fifo = tmp_path / "fifo.png"
    os.mkfifo(fifo)
    refused(["preview", EXAMPLE, "--seconds", "1", "--out", fifo], "preview", "is a FIFO")
    refused(["farm", LAYOUT, "--radar", "32.1870,-100.4315,20", "--wind-from", "200", "--prf", "1000",
             "--out", "/dev/null"], "farm", "/dev/null is a character device")
    assert Path("/dev/null").is_char_device()


def test_a_later_run_whose_output_name_is_a_folder_keeps_the_earlier_output_whole(tmp_path):
    out = tmp_path / "out"
    assert run_rast(["stream", EXAMPLE, "--out", out])[0] == 0
    (out / "wm15.bin").unlink()
    (out / "wm15.bin").mkdir()
    refused(["stream", EXAMPLE, "--out", out], "stream", "wm15.bin is a folder", untouched=[out])


#: Writers and their arguments (``OUT`` the output), each run with a file-size
#: limit as a full disk would stop it: the old output stays whole.
WRITERS = {
    "stream": (["stream", EXAMPLE, "--out", "OUT"], "dir"),
    "preview": (["preview", EXAMPLE, "--seconds", "1", "--out", "OUT"], "file"),
    "farm": (["farm", LAYOUT, "--radar", "32.1870,-100.4315,20", "--wind-from", "200", "--prf", "1000",
              "--out", "OUT"], "file"),
    "import": (["import", RECORDING, "--prf", "1000", "--out", "OUT"], "dir"),
}


@pytest.mark.parametrize("writer", sorted(WRITERS))
def test_a_full_disk_leaves_the_old_output_whole(tmp_path, writer):
    """The command run again with a file-size limit of 4 KB (RLIMIT_FSIZE: a
    write beyond it fails as on a full disk): it says it cannot write, exits
    2, and the output of the first run is as it was, no stray file beside."""
    argv, kind = WRITERS[writer]
    out = tmp_path / ("out" if kind == "dir" else "out.x")
    if writer == "preview":
        out = tmp_path / "out.png"
    elif writer == "farm":
        out = tmp_path / "farm.toml"
    elif writer == "verilog":
        out = tmp_path / "replay.v"
    argv = [out if a == "OUT" else a for a in argv]
    assert run_rast(argv)[0] == 0
    before = _snapshot(tmp_path)

    def limit():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (4096, 4096))
    proc = subprocess.run([sys.executable, "-m", "rast.cli", *map(str, argv)], capture_output=True, text=True,
                          preexec_fn=limit, timeout=600)
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert proc.stderr.startswith(f"rast {writer}: ") and "too large" in proc.stderr.lower(), proc.stderr
    assert _snapshot(tmp_path) == before


def test_a_full_disk_leaves_the_old_verilog_whole(tmp_path, monkeypatch):
    """rast verilog's output with the disk full as the file is flushed (its
    Yosys cannot run under a file-size limit: the write fails in process)."""
    out = tmp_path / "replay.v"
    argv = ["verilog", "--channels", "1", "--pool-words", "64", "--max-delay", "14", "--max-tap", "6",
            "--output", out]
    assert run_rast(argv)[0] == 0
    before = _snapshot(tmp_path)

    def full(fd):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(os, "fsync", full)
    refused(argv, "verilog", "No space left on device")
    assert _snapshot(tmp_path) == before


# ---- layouts (rast farm) ---------------------------------------------------------

def _layout(tmp_path, cell):
    """The example layout's first three turbines, the first's t_model ``cell``
    (quoted by the csv module where it must be)."""
    lines = LAYOUT.read_text().splitlines()
    head = [l for l in lines if l.startswith("#")]
    rows = list(csv.reader([l for l in lines if not l.startswith("#")]))
    rows[1][rows[0].index("t_model")] = cell
    text = io.StringIO()
    csv.writer(text, lineterminator="\n").writerows(rows[:4])
    path = tmp_path / "layout.csv"
    path.write_text("\n".join(head) + "\n" + text.getvalue())
    return path


FARM = ["--radar", "32.1870,-100.4315,20", "--wind-from", "200", "--prf", "1000"]


@pytest.mark.parametrize("cell, needles", [
    ("x\ntower_rcs = 5000 #", ["a quoted cell runs over several lines"]),
    ('x"]\n[[windmill]]\nname="evil', ["a quoted cell runs over several lines"]),
    ("A" * 200_000, ["field larger than field limit"]),
])
def test_a_hostile_layout_cell_is_refused(tmp_path, cell, needles):
    out = tmp_path / "farm.toml"
    refused(["farm", _layout(tmp_path, cell), *FARM, "--out", out], "farm", *needles)
    assert not out.exists()


def test_layout_text_in_the_config_is_escaped(tmp_path):
    """A control character in a cell reaches the config's comment escaped: the
    config holds exactly the keys rast farm writes."""
    out = tmp_path / "farm.toml"
    status, _, err = run_rast(["farm", _layout(tmp_path, "m\x0btower_rcs = 5000"), *FARM, "--out", out])
    assert status == 0, err
    text = out.read_text()
    assert "t_model m\\x0btower_rcs = 5000" in text
    assert not any(line.startswith("tower_rcs") for line in text.splitlines())


def test_a_turbine_below_the_radar_horizon_is_refused(tmp_path):
    layout = tmp_path / "far.csv"
    layout.write_text("x,y\n0,90000\n0,100\n")
    refused(["farm", layout, "--radar", "0,0,10", "--wind-from", "0", "--prf", "500", "--out",
             tmp_path / "f.toml"], "farm", "line 2 (turbine 't001'): it lies below the radar's horizon",
            "up to 64.0 km")


# ---- recordings (rast import) ------------------------------------------------------

def _sigmf(tmp_path, rate):
    np.zeros(1000, dtype=np.complex64).tofile(tmp_path / "r.sigmf-data")
    (tmp_path / "r.sigmf-meta").write_text(json.dumps({
        "global": {"core:datatype": "cf32_le", "core:sample_rate": rate, "core:version": "1.0.0"},
        "captures": [{"core:sample_start": 0}], "annotations": []}))
    return tmp_path / "r.sigmf-meta"


@pytest.mark.parametrize("make, args, needles", [
    (lambda d: d / "empty.npy", [], ["not a NumPy .npy file"]),
    (lambda d: d / "trunc.npy", [], ["not a NumPy .npy file"]),
    (lambda d: _sigmf(d, "fast"), [], ["'core:sample_rate' must be a positive number of Hz, not 'fast'"]),
    (lambda d: _sigmf(d, -5), [], ["'core:sample_rate' must be a positive number of Hz, not -5"]),
    (lambda d: RECORDING, ["--prf", "1"], ["holds 0 pulse(s)", "need at least 2"]),
    (lambda d: RECORDING, ["--period", "1e-9"], ["shorter than two pulse intervals"]),
    (lambda d: RECORDING, ["--period", "0.003"], ["fir interpolation plays streams of at least 8"]),
])
def test_a_bad_recording_is_refused(tmp_path, make, args, needles):
    (tmp_path / "empty.npy").write_bytes(b"")
    (tmp_path / "trunc.npy").write_bytes(RECORDING.read_bytes()[:100])
    out = tmp_path / "out"
    prf = [] if "--prf" in args or make(tmp_path).suffix == ".sigmf-meta" else ["--prf", "1000"]
    refused(["import", make(tmp_path), *prf, *args, "--out", out], "import", *needles)
    assert not out.exists()


# ---- builds, reports, previews, cosimulations ---------------------------------------

@pytest.mark.parametrize("report, needles", [
    ("", ["is not valid JSON"]),
    ("[]", ["has no 'build' section"]),
    ('{"build": {}}', ["lacks channels, slots"]),
    ('{"build": {"channels": 2, "slots": 8, "pool_words": 65536, "max_delay": 8190, "max_tap": 2046, '
     '"interpolation": "fir", "cmult_form": "4mult", "sample_rate_hz": 40000000, "pool": "bram"}}',
     ["build replays at 40 MHz", "every Doppler would play 2x too high"]),
    ('{"build": {"channels": 2, "slots": 8, "pool_words": 65536, "max_delay": 8190, "max_tap": 2046, '
     '"interpolation": "fir", "cmult_form": "4mult", "sample_rate_hz": 10000000, "pool": "bram"}}',
     ["build replays at 10 MHz", "every Doppler would play 2x too low and every range 2x too long"]),
])
def test_a_build_report_that_is_not_the_bitstream_s_is_refused(tmp_path, report, needles):
    rep = tmp_path / "report.json"
    rep.write_text(report)
    refused(["stream", EXAMPLE, "--build", rep, "--out", tmp_path / "out"], "stream", *needles)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("args, needles", [
    (["--clock-mhz", "inf"], ["Clock must be a positive number of MHz, not inf"]),
    (["--clock-mhz", "nan"], ["Clock must be a positive number of MHz, not nan"]),
    (["--baud", "7"], ["Baud rate 7 is outside what the board's USB UART (FT231X) makes"]),
    (["--baud", "99999999"], ["Baud rate 99999999 is outside"]),
])
def test_an_impossible_build_is_refused_before_any_tool_runs(tmp_path, args, needles):
    refused(["build", *args, "--out", tmp_path / "b"], "build", *needles)
    assert not (tmp_path / "b").exists()


def test_preview_and_cosim_bound_the_work_before_allocating(tmp_path):
    refused(["preview", EXAMPLE, "--seconds", "1e9", "--out", tmp_path / "p.png"], "preview",
            "20,000,000,000,000 pulses", "give at most")
    refused(["cosim", EXAMPLE, "--seconds", "1e9", "--out", tmp_path / "c"], "cosim", "give at most")


@pytest.mark.parametrize("args, needles", [
    (["--overlap", "2"], ["--overlap must be a fraction in [0, 1), not 2"]),
    (["--dynamic-range", "-3"], ["--dynamic-range must be a positive number of dB"]),
    (["--channels", "0"], ["--channels must be in [1, 512], not 0"]),
    (["--noise-rms", "nan"], ["--noise-rms must be a non-negative"]),
    (["--reload-at", "5"], ["--reload-at must be a time in [0, --seconds)"]),
    (["--out-is-a-file"], ["exists and is not a folder"]),
])
def test_cosim_options_are_checked_before_simulating(tmp_path, args, needles):
    out = tmp_path / "c"
    if args == ["--out-is-a-file"]:
        out.write_text("keep")
        args = []
    refused(["cosim", EXAMPLE, *args, "--out", out], "cosim", *needles, untouched=[out])


# ---- the load, over a line that damages one frame --------------------------------

CONTRACT = ReplayContract(channels=3, pool_words=256, max_delay=120, max_tap=14, sample_rate_hz=1_000_000)


def _streams(folder, lengths, seed):
    """A `rast stream`-shaped manifest of random streams; their words."""
    folder.mkdir(parents=True)
    rng = np.random.default_rng(seed)
    wms, chans, words = [], [], []
    for k, n in enumerate(lengths):
        w = pack_iq(rng.integers(-20000, 20000, n), rng.integers(-20000, 20000, n))
        (folder / f"w{k}.hex").write_text("".join(f"{int(x):08x}\n" for x in w))
        wms.append({"name": f"w{k}", "hex_file": f"w{k}.hex", "length": n, "crc32": stream_crc32(w)})
        chans.append({"windmill": f"w{k}", "enable": 1, "length": n, "phase_increment": 5_000_000,
                      "gain": (3 + k) << 14, "delay_samples": 100 + 2 * k})
        words.append([int(x) for x in w])
    (folder / "manifest.json").write_text(json.dumps(
        {"format": "rast-manifest/2", "windmills": wms, "registers": {"channels": chans}}))
    return words


@pytest.fixture(scope="module")
def manifests(tmp_path_factory):
    d = tmp_path_factory.mktemp("load")
    _streams(d / "a", (40, 50, 30), seed=1)
    return d, _streams(d / "b", (45, 35, 50), seed=2)


def _load_with(manifests, damage, live):
    """Load A cleanly, then B with ``damage`` on the line: (status, stderr,
    whether the board plays B whole, whether the damage happened)."""
    d, b_words = manifests
    with PtyBoard(ReplayModel(CONTRACT)) as board:
        assert run_rast(["load", d / "a", "--port", board.port])[0] == 0
        board.damage, board._host_frames, board._replies = damage, 0, 0
        status, _, err = run_rast(["load", d / "b", "--port", board.port] + ([] if live else ["--muted"]))
        m = board.model
        plays_b = (all(list(m.stream_of(l)) == b_words[l] for l in range(3)) and not any(m.pending)
                   and all(m.enable) and m.gain == [(3 + l) << 14 for l in range(3)]
                   and m.delay_act == [0, 2, 4] and m.crc_played == [stream_crc32(w) for w in b_words])
        assert board.error is None
        return status, err, plays_b, board.damaged, board._host_frames, board._replies


#: Damage cases drawn once (seeded): each of the first FRAMES frames either
#: way is a candidate (a clean load of B is 105-107 frames each way, the
#: polls of the switches and the final status varying with timing), and any
#: bit of it.
FRAMES = 95
DAMAGE_CASES = [Damage(("host", "board")[k % 2], int(i), int(b))
                for k, (i, b) in enumerate(np.random.default_rng(66).integers(0, [FRAMES, 512], size=(48, 2)))]


@pytest.mark.parametrize("damage", DAMAGE_CASES, ids=lambda d: f"{d.direction}{d.index}b{d.bit}")
def test_a_load_over_a_line_that_damages_one_frame_takes_effect_or_says_so(manifests, damage):
    live = damage.bit % 3 != 0
    status, err, plays_b, hit, _, _ = _load_with(manifests, damage, live)
    assert hit, "the damage did not happen: the conversation was shorter than the case assumes"
    assert "Traceback" not in err
    if status == 0:
        assert plays_b, "rast load said done, but the board does not play what was loaded"
    else:
        assert status == 1 and len(err.strip().splitlines()) == 1 and err.startswith("rast load: "), err


def test_a_clean_load_is_more_frames_each_way_than_the_cases_pick_from(manifests):
    status, err, plays_b, _, host_frames, replies = _load_with(manifests, None, True)
    assert status == 0 and plays_b, err
    assert min(host_frames, replies) > FRAMES


def test_a_board_that_stops_reading_ends_the_load_in_one_line(manifests, monkeypatch):
    """The board takes 300 bytes, then reads nothing: the host's writes of a
    16,000-word stream fill the line's buffers and block until the write
    timeout, and rast load says so."""
    import rast.load
    monkeypatch.setattr(rast.load, "WRITE_TIMEOUT_S", 0.5)
    d, _ = manifests
    big = d / "big"
    if not big.exists():
        _streams(big, (16000,), seed=3)
    with PtyBoard(ReplayModel(ReplayContract(channels=1, pool_words=16384, max_delay=120, max_tap=14,
                                             sample_rate_hz=1_000_000)), stop_reading_after=300) as board:
        status, _, err = run_rast(["load", big, "--port", board.port, "--muted"])
    assert status == 1 and len(err.strip().splitlines()) == 1, err
    assert err.startswith("rast load: the board stopped reading"), err
