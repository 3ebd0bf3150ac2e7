"""The beam-following example (examples/farm_follow.toml): a 360° scene of
more than 2048 turbines, regenerated from its script, and the channels it
needs at its worst azimuth counted beam code by beam code."""

import re
from pathlib import Path

import numpy as np
import pytest

from rast.cli import main

from test_atc_scale import _command_in_header

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
SCENE = EXAMPLES / "farm_follow.toml"
LAYOUT = EXAMPLES / "farm_layout_follow.csv"


def test_the_scene_regenerates_identically(tmp_path, capsys):
    import runpy
    script = runpy.run_path(str(EXAMPLES / "make_follow_layout.py"))
    rows = script["rows"]()
    assert LAYOUT.read_text() == script["HEADER"] + script["COLUMNS"] + "\n" + "\n".join(rows) + "\n"
    out = tmp_path / "farm.toml"
    assert main(["farm", str(LAYOUT), *_command_in_header(LAYOUT), "--out", str(out)]) == 0
    capsys.readouterr()
    assert out.read_text() == SCENE.read_text()


def test_the_scene_turns_and_surrounds_the_radar():
    from rast.model.physics.farm import load_config
    farm = load_config(SCENE)
    az = np.array([w.azimuth_deg for w in farm.windmills])
    ranges = np.array([w.range_km for w in farm.windmills])
    assert az.size >= 2048
    assert 5 <= ranges.min() and ranges.max() <= 60
    gaps = np.diff(np.sort(np.concatenate([az % 360, [az.min() % 360 + 360]])))
    assert gaps.max() < 10                               # no empty sector of 10 degrees
    assert farm.scan.mode == "free" and farm.scan.sidelobe_db <= farm.scan.assign_below_db


def test_the_channels_the_scene_needs_are_counted_code_by_code():
    """The plan's count is the most turbines whose offset from the beam lies
    in the guarded window at one beam code, counted here for every code."""
    from rast.model.contract.follow import follow_guard_codes, follow_pattern
    from rast.model.contract.scan import AZIMUTH_CODES, azimuth_code, pattern_words
    from rast.cli import default_contract
    from rast.model.physics.beam_window import farm_follow_plan
    from rast.model.physics.farm import load_config

    farm = load_config(SCENE)
    contract = default_contract(farm)
    assert (contract.slots, contract.pipelines, contract.sample_rate_hz) == (32, 2, 2_500_000)   # the following build
    text = farm_follow_plan(farm, contract)
    need = int(re.search(r"at most (\d+) of the (\d+) turbines", text).group(1))
    guard = int(re.search(r"takes its channel (\d+) codes", text).group(1))
    window = follow_pattern(farm.scan, pattern_words(farm.scan))
    assert guard == follow_guard_codes(farm.scan, contract, need)
    az = azimuth_code([w.azimuth_deg for w in farm.windmills])
    held = np.zeros(AZIMUTH_CODES + 1, dtype=np.int64)          # a difference array round the circle
    width = window.hi + 1 - window.lo + guard
    for a in az:
        first = (a + window.lo - guard) % AZIMUTH_CODES
        last = first + width
        held[first] += 1
        if last <= AZIMUTH_CODES:
            held[last] -= 1
        else:
            held[AZIMUTH_CODES] -= 1
            held[0] += 1
            held[last - AZIMUTH_CODES] -= 1
    assert need == np.cumsum(held)[:AZIMUTH_CODES].max()
    assert need <= contract.channels == 64            # the scene fits the 64-channel following build
    with pytest.raises(ValueError, match=f"{need} turbines are within the beam's window at once"):
        farm_follow_plan(farm, contract, channels=need - 1)
    assert f"at most {need} of the" in farm_follow_plan(farm, contract, channels=need)


@pytest.mark.parametrize("option, value, needle", [("--scan-rpm", "0", "non-zero number of rpm"),
                                                   ("--beamwidth-deg", "-1", "positive beamwidth"),
                                                   ("--sidelobe-db", "3", "at most 0")])
def test_rast_farm_refuses_a_bad_scan_option(tmp_path, capsys, option, value, needle):
    layout = tmp_path / "layout.csv"
    layout.write_text("x,y\n0,3000\n")
    out = tmp_path / "farm.toml"
    with pytest.raises(SystemExit):
        main(["farm", str(layout), "--radar", "0,0,20", "--wind-from", "90", option, value, "--out", str(out)])
    assert needle in capsys.readouterr().err and not out.exists()


RING = """
sample_rate = 2.5
radar_frequency = 2800
prf = 1000
pulse_width = 1
scan_mode = "free"
scan_rpm = 12.5
beamwidth_deg = 1.4
sidelobe_db = {sidelobe}
""" + "".join(f"""
[[windmill]]
name = "t{k}"
range = {5 + k}
azimuth = {az}
num_blades = 3
rpm = 15
num_rcs = 1
radius = [20.0]
rsc = [1.0]
""" for k, az in enumerate([0.0, 1.0, 2.0, 120.0, 240.0]))


def test_the_ppi_of_a_scene_round_the_radar_shows_the_channels_held(tmp_path, capsys):
    """Beside the PPI, the channels a following board holds at each beam
    azimuth: three turbines within 2 degrees need three at once; a pattern
    whose floor lies above assign_below_db has no such panel."""
    from rast.cli import _follow_panel
    from rast.model.physics.farm import load_config
    path = tmp_path / "ring.toml"
    path.write_text(RING.format(sidelobe=-70))
    panel = _follow_panel(load_config(path))
    assert int(panel["held"].max()) == 3 and panel["held"].size == 65536 and "at most 3" in panel["held_caption"]
    assert int(panel["held"].min()) == 0
    out = tmp_path / "ppi.png"
    assert main(["preview", str(path), "--ppi", "--seconds", "0.3", "--out", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    path.write_text(RING.format(sidelobe=-50))
    assert _follow_panel(load_config(path)) == {}
