"""The turbines a turning beam needs at once (rast.model.physics.beam_window):
the pattern's window above ``assign_below_db`` and the channels a scene needs
at its worst azimuth. Expected values come from the Gaussian lobe's closed
form, linear interpolation done here, and a brute-force count over beam
azimuths."""

import math

import numpy as np
import pytest

from rast.cli import main
from rast.model.physics.antenna import AntennaScan, read_pattern_csv
from rast.model.physics.beam_window import assignment_window, channels_needed
from rast.model.physics.config import ConfigError
from rast.model.physics.farm import parse_config


def test_the_gaussian_window_is_where_the_lobe_crosses_the_floor():
    scan = AntennaScan("free", 12.5, 0.0, 4096, 1.4, -70.0)
    w = assignment_window(scan, -60.0)
    half = 1.4 * math.sqrt(60.0 / 24.0)            # -24 (theta/1.4)^2 = -60: about 2.2 deg
    assert w.low_deg == pytest.approx(-half) and w.high_deg == pytest.approx(half)
    assert 2.2 < half < 2.25


def test_a_floor_above_the_threshold_leaves_no_turbine_out():
    w = assignment_window(AntennaScan("free", 12.5, 0.0, 4096, 1.4, -50.0), -60.0)
    assert w.whole_circle and w.width_deg == 360.0
    assert channels_needed([0.0, 90.0, 180.0], w).channels == 3


def test_an_asymmetric_measured_pattern(tmp_path):
    path = tmp_path / "pattern.csv"
    path.write_text("offset_deg,gain_db\n-3,-80\n-1,-20\n0,0\n2,-30\n5,-80\n")
    scan = AntennaScan("free", 12.5, 0.0, 4096, 1.4, -90.0, read_pattern_csv(path))
    w = assignment_window(scan, -60.0)
    low = -3 + (80 - 60) / (80 - 20) * 2           # -80 dB at -3 to -20 dB at -1 crosses -60
    high = 2 + (60 - 30) / (80 - 30) * 3           # -30 dB at 2 to -80 dB at 5 crosses -60
    assert w.low_deg == pytest.approx(low, abs=2e-3) and w.high_deg == pytest.approx(high, abs=2e-3)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_channels_needed_are_the_most_turbines_in_the_window(seed):
    rng = np.random.default_rng(seed)
    # farms: clusters of turbines at a few bearings, one across north
    az = np.concatenate([rng.normal(c, s, n) for c, s, n in ((10, 1.5, 40), (200, 0.8, 25), (359, 1.0, 30))])
    scan = AntennaScan("free", 12.5, 0.0, 4096, 1.4, -70.0)
    w = assignment_window(scan, -60.0)
    need = channels_needed(az, w)

    def inside(beam):
        offset = np.mod(beam - az + 180.0, 360.0) - 180.0
        return int(np.count_nonzero((offset >= w.low_deg) & (offset <= w.high_deg)))

    brute = max(inside(b) for b in np.arange(0.0, 360.0, 0.005))
    assert need.channels == brute
    assert inside(need.beam_azimuth_deg) == need.channels
    assert need.turbines == az.size


SCENE = """
sample_rate = 20
radar_frequency = 2800
prf = 1000
pulse_width = 1
scan_mode = "free"
scan_rpm = 12.5
beamwidth_deg = 1.4
sidelobe_db = -70
{extra}
"""

TURBINE = """
[[windmill]]
name = "t{k}"
range = {range}
azimuth = {azimuth}
num_blades = 3
rpm = 15
num_rcs = 1
radius = [20.0]
rsc = [1.0]
"""


def test_rast_stream_prints_the_channels_at_the_worst_azimuth(tmp_path, capsys):
    text = SCENE.format(extra="") + "".join(
        TURBINE.format(k=k, range=5.0 + 0.3 * k, azimuth=a) for k, a in enumerate([10, 11, 12, 13.5, 90, 270]))
    (tmp_path / "scene.toml").write_text(text)
    assert main(["stream", str(tmp_path / "scene.toml"), "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    # +-2.21 deg and a guard: 10, 11, 12 and 13.5 lie within 4.43 deg of one another
    assert "at most 4 of the 6 turbines hold one at once" in out
    assert "above -60 dB from -2.21 to +2.21 deg of offset" in out


def test_assign_below_db_is_checked():
    with pytest.raises(ConfigError, match="'assign_below_db' must be in \\[-90, 0\\] dB"):
        parse_config(__import__("tomllib").loads(
            SCENE.format(extra="assign_below_db = 3") + TURBINE.format(k=0, range=5.0, azimuth=0)))
