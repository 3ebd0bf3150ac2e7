"""The antenna scan in the model: its config keys, the two-way pattern, the
fixed-point rule of the contract, the echoes it weighs and the PPI drawn from them.

Expected values come from closed forms written here (the Gaussian lobe's
−24·(θ/θ₃)² dB, the beam's turn rate, the canceller's |2 sin(πf/PRF)|^(2(n−1))
power response), not from the code under test.
"""

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from rast.cli import main
from rast.model.contract import scan as sc
from rast.model.physics.antenna import AntennaScan, read_pattern_csv
from rast.model.physics.config import ConfigError
from rast.model.physics.farm import load_config, parse_config
from rast.model.physics.stream import build_farm_streams
from rast.model.radar.ppi import dwell_image
from rast.model.radar.receiver import echo_samples, pulse_times

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

ONE_TURBINE = """
sample_rate = 20
radar_frequency = 2800
prf = 1000
pulse_width = 1
{scan}
[[windmill]]
name = "t1"
range = 10.0
azimuth = {azimuth}
num_blades = 3
rpm = 15
num_rcs = 1
radius = [20.0]
rsc = [1.0]
tower_rcs = 10
"""

FREE = 'scan_mode = "free"\nscan_rpm = 12.5\nbeamwidth_deg = 1.4\nsidelobe_db = -50'


def farm_of(scan: str = FREE, azimuth: float = 90.0, source=None):
    return parse_config(tomllib.loads(ONE_TURBINE.format(scan=scan, azimuth=azimuth)), source)


def problems_of(scan: str) -> str:
    with pytest.raises(ConfigError) as error:
        farm_of(scan)
    return str(error.value)


# ------------------------------------------------------------------ config


def test_a_config_without_scan_keys_stares_as_before():
    farm = farm_of("")
    assert farm.scan.mode == "stare" and not farm.scan.turning
    assert farm.windmills[0].azimuth_deg == 90.0
    t = pulse_times(1000.0, 0.5)
    # staring, the echo carries no pattern: the same samples at any azimuth
    a = echo_samples(farm, t)[1]
    b = echo_samples(farm_of("", azimuth=200.0), t)[1]
    assert np.array_equal(a, b)


def test_scan_keys_are_read_with_their_units():
    farm = farm_of('scan_mode = "acp"\nscan_rpm = -5\nscan_start_deg = 370\nacp_per_rev = 16384\n'
                   'beamwidth_deg = 1.1\nsidelobe_db = -60')
    s = farm.scan
    assert (s.mode, s.rpm, s.start_deg, s.acp_per_rev, s.beamwidth_deg, s.sidelobe_db) == \
        ("acp", -5.0, 10.0, 16384, 1.1, -60.0)
    assert farm_of('scan_mode = "acp"\nscan_rpm = 5\nacp_per_rev = "auto"').scan.acp_per_rev == "auto"


@pytest.mark.parametrize("scan, needles", [
    ('scan_mode = "spin"', ["'scan_mode'", "'stare'"]),
    ('scan_mode = "free"', ["'scan_rpm' is required"]),
    ('scan_mode = "free"\nscan_rpm = 0', ["'scan_rpm' must not be 0"]),
    ('scan_mode = "acp"\nscan_rpm = 5\nacp_per_rev = 1000', ["'acp_per_rev'", "4096"]),
    ('scan_mode = "acp"\nscan_rpm = 5\nacp_per_rev = true', ["'acp_per_rev'"]),
    ('scan_mode = "free"\nscan_rpm = 5\nsidelobe_db = -95', ["'sidelobe_db'", "[-90, 0]"]),
    ('scan_mode = "free"\nscan_rpm = 5\nsidelobe_db = 3', ["'sidelobe_db'"]),
    ('scan_mode = "free"\nscan_rpm = 5\nbeamwidth_deg = 0', ["'beamwidth_deg' must be positive"]),
    ('scan_mode = "free"\nscan_rpm = 5\nbeamwidth_deg = nan', ["'beamwidth_deg' must be a number"]),
    ('scan_mode = "free"\nscan_rpm = 5000', ["'scan_rpm' must be at most 600"]),
    ('scan_mode = "free"\nscan_rpm = 5\npattern_file = "missing.csv"', ["pattern_file", "missing.csv"]),
    ('scan_mode = "free"\nscan_rpm = 5\nscan_rmp = 5', ["'scan_rmp' is not a known key", "scan_rpm"]),
])
def test_bad_scan_keys_are_refused_by_name(scan, needles):
    text = problems_of(scan)
    for needle in needles:
        assert needle in text, text


def test_a_bad_turbine_azimuth_is_refused():
    with pytest.raises(ConfigError, match="'azimuth' must be a number"):
        parse_config(tomllib.loads(ONE_TURBINE.format(scan=FREE, azimuth='"east"')))


# ------------------------------------------------------------------ the pattern


def test_gaussian_lobe_is_minus_6_db_two_way_at_half_the_beamwidth():
    scan = AntennaScan("free", 12.5, 0.0, 4096, 1.4, -50.0)
    assert scan.two_way_gain_db(0.7) == pytest.approx(-6.0)
    assert scan.two_way_gain_db(-0.7) == pytest.approx(-6.0)
    assert scan.two_way_gain_db(1.4) == pytest.approx(-24.0)
    assert scan.two_way_gain_db(10.0) == -50.0                    # floored
    assert scan.two_way_gain_db(359.3) == pytest.approx(-6.0)      # offsets wrap


def test_pattern_file_interpolates_in_db_and_takes_the_floor_beyond(tmp_path):
    csv_file = tmp_path / "pattern.csv"
    csv_file.write_text("offset_deg,gain_db\n# an asymmetric lobe\n-2,-40\n0,0\n1,-20\n3,-30\n")
    farm = farm_of(FREE + '\npattern_file = "pattern.csv"', source=str(tmp_path / "farm.toml"))
    s = farm.scan
    assert s.two_way_gain_db(-1.0) == pytest.approx(-20.0)
    assert s.two_way_gain_db(0.5) == pytest.approx(-10.0)
    assert s.two_way_gain_db(2.0) == pytest.approx(-25.0)
    assert s.two_way_gain_db(5.0) == -50.0 and s.two_way_gain_db(-2.5) == -50.0


@pytest.mark.parametrize("text, needle", [
    ("0,0\n", "at least two rows"),
    ("0,0\n1,x\n", "line 2"),
    ("0,0\n1,3\n", "above 0 dB"),
    ("0,0\n200,-3\n", "outside [-180, 180]"),
    ("0,0\n0,-3\n", "listed twice"),
    ("0,0\n1,nan\n", "finite"),
])
def test_bad_pattern_files_are_refused_with_the_line(tmp_path, text, needle):
    f = tmp_path / "p.csv"
    f.write_text(text)
    with pytest.raises(ValueError, match=needle.replace("[", r"\[").replace("]", r"\]")):
        read_pattern_csv(f)


# ------------------------------------------------------------------ the contract


def test_pattern_table_words_round_the_closed_form():
    scan = AntennaScan("free", 12.5, 0.0, 4096, 1.4, -50.0)
    table = sc.pattern_words(scan)
    # the lobe is above -50 dB out to 1.4·sqrt(50/24) = 2.02°: span ±2.81° (shift 0) holds it
    assert table.shift == 0 and sc.span_deg(0) > 1.4 * math.sqrt(50 / 24)
    k = np.arange(1024)
    theta = (k - 512 + 0.5) * 360 / 65536
    exact = 32768 * 10 ** (np.maximum(-24 * (theta / 1.4) ** 2, -50) / 20)
    assert np.all(np.abs(table.words - exact) <= 0.5)
    assert table.floor == round(32768 * 10 ** (-50 / 20))
    # offsets beyond the span get the floor; inside, the entry whose bin holds them
    assert sc.pattern_lookup(table, 600) == table.floor and sc.pattern_lookup(table, -600) == table.floor
    assert sc.pattern_lookup(table, 0) == table.words[512]
    assert sc.pattern_lookup(table, -1) == table.words[511]
    assert sc.pattern_lookup(table, 65535) == table.words[511]            # wraps


def test_a_wide_pattern_takes_a_coarser_step():
    narrow = sc.pattern_words(AntennaScan("free", 5.0, 0.0, 4096, 1.0, -40.0)).shift
    wide = sc.pattern_words(AntennaScan("free", 5.0, 0.0, 4096, 10.0, -40.0)).shift
    assert wide > narrow
    reach = 10.0 * math.sqrt(40 / 24)
    assert sc.span_deg(wide) > reach >= sc.span_deg(wide - 1)


def test_free_beam_turns_at_the_scan_rate():
    fs, rpm = 20e6, 12.5
    n = np.array([0, 1, 10**6, 96 * 10**6 - 1, 96 * 10**6, 10**9])    # 96 M samples = one revolution
    codes = sc.free_beam_codes(30.0, rpm, fs, n)
    start = round(30 / 360 * 65536) / 65536                           # the start is kept to a code
    expected = np.floor(np.mod(start + rpm / 60 * n / fs, 1.0) * 65536 + 1e-9)
    assert np.array_equal(codes, expected.astype(np.int64))          # P = 96e6 exactly: no drift
    back = sc.free_beam_codes(30.0, -rpm, fs, n)                      # anticlockwise
    np.testing.assert_array_equal(back, np.floor(np.mod(start - rpm / 60 * n / fs, 1.0) * 65536 + 1e-9))
    with pytest.raises(ValueError, match="more than one azimuth code per RTS sample"):
        sc.free_beam_codes(0.0, 20_000.0, fs, n)


def test_scanned_gain_rounds_half_up():
    assert sc.scanned_gain(65536, 32768) == 65536
    assert sc.scanned_gain(3, 16384) == 2          # 1.5 rounds up
    assert sc.scanned_gain(1, 16383) == 0


# ------------------------------------------------------------------ the echoes


def test_the_beam_lights_a_turbine_as_it_passes():
    """Physics: the echo's amplitude envelope over one revolution is the
    pattern at (beam − turbine); its maximum where the beam points at it."""
    farm = farm_of(azimuth=90.0)
    stare = farm_of("", azimuth=90.0)
    t = pulse_times(1000.0, 4.8)
    lit = echo_samples(farm, t)[1][0]
    plain = echo_samples(stare, t)[1][0]
    beam = np.mod(6 * 12.5 * t, 360)
    gain_db = np.maximum(-24 * ((np.mod(beam - 90 + 180, 360) - 180) / 1.4) ** 2, -50)
    np.testing.assert_allclose(lit, plain * 10 ** (gain_db / 20), rtol=1e-12, atol=1e-15)
    assert abs(beam[np.argmax(np.abs(lit) / np.maximum(np.abs(plain), 1e-30))] - 90) < 0.1


def test_the_replay_weighs_the_stream_by_the_table_word():
    """Replay: each pulse's sample is the staring replay's times the table
    word of the beam's code at that RTS sample, over 2**15."""
    farm = farm_of(azimuth=45.0)
    stare = farm_of("", azimuth=45.0)
    t = pulse_times(1000.0, 4.8)
    lit = echo_samples(farm, t, build_farm_streams(farm, check_ram_depth=False))[1][0]
    plain = echo_samples(stare, t, build_farm_streams(stare, check_ram_depth=False))[1][0]
    n = np.round(t * 20e6).astype(np.int64)
    beam = n * 65536 // 96_000_000 % 65536                      # 96e6 samples a revolution
    offset = (beam - round(45 / 360 * 65536) + 32768) % 65536 - 32768
    theta = (np.floor(offset + 512) - 512 + 0.5) * 360 / 65536          # the bin's centre (shift 0)
    word = np.where(np.abs(offset + 0.5) < 512,
                    np.floor(32768 * 10 ** (np.maximum(-24 * (theta / 1.4) ** 2, -50) / 20) + 0.5),
                    round(32768 * 10 ** (-50 / 20)))
    np.testing.assert_allclose(lit, plain * word / 32768, rtol=1e-12, atol=1e-15)


# ------------------------------------------------------------------ the PPI


def test_dwell_image_means_power_per_cell_and_the_canceller_response():
    prf, pulses = 1000.0, 3600
    az = np.arange(pulses) * 0.1                  # 0.1° per pulse: 10 pulses in each 1° cell
    n = np.arange(pulses)
    still = np.full(pulses, 2.0 + 0j)
    half = np.exp(1j * np.pi * n)                # a tone at PRF/2
    quarter = np.exp(1j * np.pi / 2 * n)         # at PRF/4
    samples = np.stack([still, half, quarter])
    plain = dwell_image(samples, az, 1.0)
    assert plain.cells == 360 and np.all(plain.pulses == 10)
    np.testing.assert_allclose(plain.power[:, 0], 4.0)
    for mti in (2, 3):
        img = dwell_image(samples, az, 1.0, mti)
        f = np.array([0.0, 0.5, 0.25])                # Doppler / PRF
        expected = (2 * np.sin(np.pi * f)) ** (2 * (mti - 1))
        np.testing.assert_allclose(np.nanmean(img.power, axis=0), expected * [4, 1, 1], atol=1e-9)
    assert np.isnan(dwell_image(samples[:, :100], az[:100], 1.0).power[50, 0])     # never looked at


def test_preview_ppi_draws_a_revolution(tmp_path, capsys):
    out = tmp_path / "ppi.png"
    assert main(["preview", str(EXAMPLES / "asr_scan.toml"), "--ppi", "--mti", "2", "--seconds", "1.2",
                 "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # 1.2 s at 12.5 rpm is a quarter turn: 90°/1.4° = 64.3 cells looked at
    assert "1200 pulses over 1.2 s, 65 of 258 dwells" in printed, printed


def test_preview_ppi_refuses_a_staring_config(tmp_path, capsys):
    out = tmp_path / "ppi.png"
    assert main(["preview", str(EXAMPLES / "farm_atc_sband.toml"), "--ppi", "--out", str(out)]) == 2
    assert "stares" in capsys.readouterr().err and not out.exists()
    assert main(["preview", str(EXAMPLES / "asr_scan.toml"), "--mti", "2", "--out", str(out)]) == 2
    assert "--mti is a PPI option" in capsys.readouterr().err and not out.exists()
    assert main(["preview", str(EXAMPLES / "asr_scan.toml"), "--ppi", "--zoom", "100", "--out", str(out)]) == 2
    assert "--zoom is a spectrogram option" in capsys.readouterr().err and not out.exists()


def test_example_differs_from_the_atc_example_only_by_its_scan():
    scan = load_config(EXAMPLES / "asr_scan.toml")
    atc = load_config(EXAMPLES / "farm_atc_sband.toml")
    assert scan.scan.turning and scan.scan.rpm == 12.5 and not atc.scan.turning
    assert [w.azimuth_deg for w in scan.windmills] == [w.azimuth_deg for w in atc.windmills]
    assert 15 < min(w.azimuth_deg for w in scan.windmills) < max(w.azimuth_deg for w in scan.windmills) < 25
    assert scan.scan.dwell_pulses(scan.radar.prf_hz) == pytest.approx(1000 * 1.4 / 75)


def test_the_commands_of_a_turning_config(tmp_path, capsys):
    """`rast stream` of a turning config writes the scan into the manifest
    (each channel's azimuth code, the settings and the table the board
    loads); `rast cosim` refuses acp mode (its bulk run drives no radar
    pulses) and an SDRAM or netlist cosimulation of a turning config, before
    creating anything."""
    import json
    config = EXAMPLES / "asr_scan.toml"
    assert main(["stream", str(config), "--out", str(tmp_path / "s")]) == 0
    assert "a bitstream built with --scan applies" in capsys.readouterr().out
    manifest = json.loads((tmp_path / "s" / "manifest.json").read_text())
    farm = load_config(config)
    want = sc.scan_settings(farm.scan, farm.sample_rate_hz)
    assert {k: manifest["scan"][k] for k in want} == want and manifest["scan"]["scan_mode"] == "free"
    azimuths = [ch["azimuth"] for ch in manifest["registers"]["channels"]]
    assert azimuths == [int(sc.azimuth_code(s.windmill.azimuth_deg)) for s in build_farm_streams(farm).streams]
    acp = tmp_path / "acp.toml"
    acp.write_text(config.read_text().replace('scan_mode = "free"', 'scan_mode = "acp"'))
    assert main(["cosim", str(acp), "--seconds", "0.001", "--out", str(tmp_path / "c")]) == 2
    assert "does not drive" in capsys.readouterr().err and not (tmp_path / "c").exists()
    assert main(["cosim", str(config), "--sdram", "--seconds", "0.001", "--out", str(tmp_path / "c")]) == 2
    assert "leave out --sdram and --netlist" in capsys.readouterr().err and not (tmp_path / "c").exists()
