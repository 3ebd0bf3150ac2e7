"""rast farm: turbine layouts to farm configs, checked against hand-worked geometry.

Closed forms (flat x/y layouts, then a geodetic one against the WGS 84
ellipse's own formulas): the slant range, the rotor angle — the angle between
the line of sight and the rotor plane — broadside (wind across the line of
sight), end-on (wind along it), with the shaft tilt and at elevation — and
the blade-angle offset the elevation brings.
"""

import dataclasses
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from rast.cli import main
from rast.model.physics.farm import load_config, parse_config
from rast.model.physics.layout import (TURBINE_CLASSES, FarmSettings, RadarSite, azimuth_spread_deg,
                                       make_farm, parse_layout, place_turbines)

NREL = TURBINE_CLASSES["nrel-5mw"]
FLAT = dataclasses.replace(NREL, shaft_tilt_deg=0.0)     # the seed's untilted rotor


def one_turbine(wind_from, *, radar_xy=(0.0, 5000.0), radar_h=90.0, cls=FLAT, hub=90.0):
    layout = parse_layout(f"x,y,t_hh,t_rd\n0,0,{hub},126\n")
    (p,) = place_turbines(layout, RadarSite(*radar_xy, radar_h), wind_from, turbine_class=cls,
                          max_range_km=100.0)
    return p


# ------------------------------------------------------------------ geometry

def test_broadside_line_of_sight_lies_in_the_rotor_plane():
    # Radar due north at hub height, wind from the east: rotor plane north-south.
    p = one_turbine(90.0)
    assert p.range_km == pytest.approx(5.0, abs=1e-12)
    assert p.rotor_angle_deg == pytest.approx(0.0, abs=1e-6)
    # Seen from upwind (east) the blade at 90° points north, to the radar:
    # ΔR = +r·sin β = −r·sin(β + 180°), an offset of 180°.
    assert p.blade_offset_deg % 360 == pytest.approx(180.0)


def test_broadside_is_kept_whatever_the_tilt():
    # The rotor plane tilts about its horizontal axis, which is the line of sight.
    assert one_turbine(90.0, cls=NREL).rotor_angle_deg == pytest.approx(0.0, abs=1e-6)
    assert one_turbine(270.0, cls=NREL).rotor_angle_deg == pytest.approx(0.0, abs=1e-6)


def test_end_on_sees_no_rotation_unless_tilted():
    # Wind from the radar (north): the radar looks along the rotor axis.
    assert one_turbine(0.0).rotor_angle_deg == pytest.approx(90.0)
    assert one_turbine(180.0).rotor_angle_deg == pytest.approx(90.0)
    # A 5° shaft tilt leans the rotor plane 5° towards the line of sight.
    assert one_turbine(0.0, cls=NREL).rotor_angle_deg == pytest.approx(85.0)


@pytest.mark.parametrize("eps_deg", [1.0, 3.0, 10.0])
def test_end_on_at_elevation(eps_deg):
    # Radar 5 km north, below the hub: depression ε seen from the hub.
    d = 5000.0
    radar_h = 90.0 - d * math.tan(math.radians(eps_deg))
    p = one_turbine(0.0, radar_h=radar_h)
    assert p.range_km * 1e3 == pytest.approx(d / math.cos(math.radians(eps_deg)), abs=1e-9)
    assert p.rotor_angle_deg == pytest.approx(90.0 - eps_deg)
    assert p.elevation_deg == pytest.approx(eps_deg)             # the hub above the radar
    # Tilt t adds to ε: the axis is t above the horizontal, the line of sight ε below.
    assert one_turbine(0.0, radar_h=radar_h, cls=NREL).rotor_angle_deg == pytest.approx(85.0 - eps_deg)


@pytest.mark.parametrize("eps_deg", [2.0, 8.0])
def test_broadside_at_elevation_turns_the_blade_offset(eps_deg):
    # Still in the rotor plane (rotor angle 0), but the blade perpendicular to the
    # line of sight is no longer the vertical one: φ₀ = 180° − ε.
    radar_h = 90.0 - 5000.0 * math.tan(math.radians(eps_deg))
    p = one_turbine(90.0, radar_h=radar_h)
    assert p.rotor_angle_deg == pytest.approx(0.0, abs=1e-6)
    assert p.blade_offset_deg == pytest.approx(180.0 - eps_deg)


def test_oblique_wind_at_elevation():
    # Wind from W = 30°, radar north at depression ε: a = sin W·cos ε, c = −sin ε.
    w, eps = math.radians(30.0), math.radians(3.0)
    radar_h = 90.0 - 5000.0 * math.tan(eps)
    p = one_turbine(30.0, radar_h=radar_h)
    a, c = math.sin(w) * math.cos(eps), -math.sin(eps)
    assert p.rotor_angle_deg == pytest.approx(math.degrees(math.acos(math.hypot(a, c))))
    assert p.blade_offset_deg == pytest.approx(math.degrees(math.atan2(-c, -a)))


def test_blade_projection_matches_the_vector_geometry():
    """The windmill's ΔR(β) = −r·cos(rotor_angle)·sin(β + φ₀) equals r·(b(β)·û) for a
    blade b(β) = sin β·x̂ + cos β·ŷ of the tilted rotor, for any wind and elevation."""
    rng = np.random.default_rng(1)
    for _ in range(20):
        wind = rng.uniform(0, 360)
        radar = (rng.uniform(-4000, 4000), rng.uniform(-4000, 4000), rng.uniform(0, 300))
        p = one_turbine(wind, radar_xy=radar[:2], radar_h=radar[2], cls=NREL)
        u = np.array([radar[0], radar[1], radar[2] - 90.0])
        u /= np.linalg.norm(u)
        w, t = math.radians(wind), math.radians(5.0)
        upwind = np.array([math.sin(w), math.cos(w), 0.0])
        axis = math.cos(t) * upwind + math.sin(t) * np.array([0, 0, 1.0])
        up = np.cross(axis, np.cross(np.array([0, 0, 1.0]), axis))      # plane's up, by construction
        up /= np.linalg.norm(up)
        right = np.cross(up, axis)                 # right seen from upwind (looking along −axis)
        beta = np.linspace(0, 2 * np.pi, 50)
        physical = np.outer(np.sin(beta), right) + np.outer(np.cos(beta), up)
        model = -math.cos(math.radians(p.rotor_angle_deg)) * np.sin(beta + math.radians(p.blade_offset_deg))
        np.testing.assert_allclose(physical @ u, model, atol=1e-12)


def test_geodetic_slant_range_against_the_ellipse():
    # Radar and turbine on one meridian: the chord between two points of the
    # WGS 84 meridian ellipse, from its textbook parametrisation.
    a, f = 6378137.0, 1 / 298.257223563
    e2 = f * (2 - f)

    def xz(lat_deg, h):
        phi = math.radians(lat_deg)
        n = a / math.sqrt(1 - e2 * math.sin(phi) ** 2)
        return (n + h) * math.cos(phi), (n * (1 - e2) + h) * math.sin(phi)

    layout = parse_layout("xlong,ylat,t_hh,t_rd\n5.0,52.05,90,126\n5.0,52.0,150,126\n")
    placed = place_turbines(layout, RadarSite(5.0, 52.0, 30.0), 90.0, turbine_class=NREL,
                            max_range_km=100.0)
    x0, z0 = xz(52.0, 30.0)
    x1, z1 = xz(52.05, 90.0)
    assert placed[0].range_km * 1e3 == pytest.approx(math.hypot(x1 - x0, z1 - z0), abs=1e-6)
    assert placed[1].range_km * 1e3 == pytest.approx(120.0, abs=1e-6)     # straight up
    # Due north, wind from the east: broadside, and the Earth's curvature lowers the hub.
    assert placed[0].bearing_deg == pytest.approx(0.0, abs=1e-9)
    # Seen from the radar the hub, 60 m higher, sinks by d²/(2M) below the radar's
    # horizon (M the meridian's radius of curvature): about 2.4 m at 5.56 km.
    phi = math.radians(52.0)
    m = a * (1 - e2) / (1 - e2 * math.sin(phi) ** 2) ** 1.5
    d = m * math.radians(0.05)
    expected = math.degrees(math.atan2(60.0 - d * d / (2 * m), d))
    assert placed[0].elevation_deg == pytest.approx(expected, abs=2e-4)
    assert expected < math.degrees(math.atan2(60.0, d)) - 0.02


def test_azimuth_spread_wraps_through_north():
    assert azimuth_spread_deg([350.0, 10.0, 5.0]) == pytest.approx((350.0, 10.0, 20.0))
    assert azimuth_spread_deg([90.0, 100.0]) == pytest.approx((90.0, 100.0, 10.0))


# ------------------------------------------------------------------ rotor speed

def test_rotor_speed_curve():
    assert NREL.rpm(None) == 12.1
    assert NREL.rpm(8.0) == pytest.approx(7.55 * 8.0 * 60 / (2 * math.pi * 63.0))   # optimal tip speed
    assert NREL.rpm(4.0) == 6.9 and NREL.rpm(20.0) == 12.1                           # clamped
    assert NREL.rpm(None, 63.0) == pytest.approx(24.2)            # half the rotor, the same tip speed
    iea = TURBINE_CLASSES["iea-15mw"]
    assert iea.rpm(None) == 7.56 and iea.rpm(4.0) == 5.0
    with pytest.raises(ValueError, match="parked"):
        NREL.rpm(2.0)


# ------------------------------------------------------------------ USWTDB

USWTDB_HEADER = ("case_id,faa_ors,faa_asn,usgs_pr_id,eia_id,t_state,t_county,t_fips,p_name,p_year,"
                 "p_tnum,p_cap,t_manu,t_model,t_cap,t_hh,t_rd,t_rsa,t_ttlh,retrofit,retrofit_year,"
                 "t_conf_atr,t_conf_loc,t_img_date,t_img_src,xlong,ylat")


def uswtdb_row(case_id, model, hh, rd, lon, lat):
    return (f"{case_id},,,,,TX,\"Nolan County, TX\",48353,Synthetic Wind,2012,2,4.0,GE Wind,{model},2000,"
            f"{hh},{rd},,,0,,3,3,2019-01-01,Synthetic,{lon},{lat}")


def test_uswtdb_columns_need_no_renaming():
    text = "\n".join([USWTDB_HEADER, uswtdb_row(3001, "GE2.5-116", 90, 116, -100.31, 32.41),
                      uswtdb_row(3002, "unknown", "", -9999, -100.30, 32.42)]) + "\n"
    layout = parse_layout(text)
    assert layout.geodetic and layout.columns == ("xlong", "ylat")
    a, b = layout.turbines
    assert (a.name, a.x, a.y, a.hub_height_m, a.rotor_diameter_m, a.model) == (
        "t3001", -100.31, 32.41, 90.0, 116.0, "GE2.5-116")
    assert (b.name, b.hub_height_m, b.rotor_diameter_m, b.line) == ("t3002", None, None, 3)
    placed = place_turbines(layout, RadarSite(-100.33, 32.40, 20.0), 200.0, turbine_class=NREL,
                            max_range_km=50.0)
    assert placed[1].hub_height_m == 90.0 and placed[1].rotor_diameter_m == 126.0   # the class's


# ------------------------------------------------------------------ the command

def run(argv, capsys):
    try:
        status = main([str(a) for a in argv])
    except SystemExit as exc:
        status = exc.code
    out, err = capsys.readouterr()
    return status, out, err


def test_written_farm_is_ready_for_rast_stream(tmp_path, capsys):
    layout = tmp_path / "layout.csv"
    layout.write_text("x,y,t_hh,t_rd\n0,3000,90,126\n400,3200,,\n-500,4000,100,100\n")
    out = tmp_path / "farm.toml"
    status, printed, err = run(["farm", layout, "--radar", "0,0,20", "--wind-from", "270",
                                "--wind-speed", "9", "--out", out], capsys)
    assert status == 0, err
    farm = parse_config(tomllib.loads(out.read_text()))
    assert [w.name for w in farm.windmills] == ["t001", "t002", "t003"]
    assert farm.windmills[0].range_km == pytest.approx(math.hypot(3000, 70) / 1e3, abs=1e-6)
    assert farm.windmills[0].radius_m.max() == pytest.approx(63.0)      # blade = rotor diameter / 2
    assert farm.windmills[2].radius_m.max() == pytest.approx(50.0)
    # Bearings 0°, 7.1° and 352.9°: a spread of 14.25° through north, each the turbine's azimuth.
    spread = math.degrees(math.atan2(400, 3200)) + math.degrees(math.atan2(500, 4000))
    expected = [0.0, math.degrees(math.atan2(400, 3200)), 360 - math.degrees(math.atan2(500, 4000))]
    assert [w.azimuth_deg for w in farm.windmills] == pytest.approx(expected, abs=1e-4)
    assert f"azimuth spread of {spread:.2f} deg" in printed
    assert run(["stream", out, "--out", tmp_path / "s"], capsys)[0] == 0


def assert_refused(status, err, out, *needles):
    assert status == 2, err
    lines = [line for line in err.splitlines() if line.startswith("rast farm: ")]
    assert len(lines) == 1 and "Traceback" not in err, err
    for needle in needles:
        assert needle in err, f"{needle!r} not in {err!r}"
    assert not out.exists()
    assert not list(out.parent.glob("*.toml"))          # no temporary file left either


@pytest.mark.parametrize("csv, needles", [
    ("t_hh,t_rd\n90,126\n", ["line 1", "no position columns", "'xlong' and 'ylat'"]),
    ("x,y,t_hh\n0,3000,90\n0,oops,90\n", ["line 3, column 'y'", "'oops' is not a number"]),
    ("x,y,t_hh\n0,3000,90\n0,3100,tall\n", ["line 3, column 't_hh'", "'tall' is not a number"]),
    ("x,y,t_hh\n0,3000,-90\n", ["line 2, column 't_hh'", "must be positive"]),
    ("x,y\n0,3000\n0,9000\n", ["line 3 (turbine 't002')", "9.000 km", "maximum range 7.495 km"]),
    ("x,y\n0,3000\n0,3000,5\n", ["line 3", "has 3 cells"]),
    ("x,y\n", ["no turbine rows"]),
    ("name,x,y\na,0,3000\na,0,3100\n", ["lines 2, 3", "'a' is used more than once"]),
])
def test_bad_layouts_name_the_line_or_column(tmp_path, capsys, csv, needles):
    layout = tmp_path / "layout.csv"
    layout.write_text(csv)
    out = tmp_path / "o" / "farm.toml"
    status, _, err = run(["farm", layout, "--radar", "0,0,20", "--wind-from", "0", "--out", out], capsys)
    assert_refused(status, err, out, *needles)


def test_max_range_option_and_parked_rotors(tmp_path, capsys):
    layout = tmp_path / "layout.csv"
    layout.write_text("x,y\n0,3000\n0,5000\n")
    out = tmp_path / "o" / "farm.toml"
    status, _, err = run(["farm", layout, "--radar", "0,0,20", "--wind-from", "0", "--max-range-km", "4",
                          "--out", out], capsys)
    assert_refused(status, err, out, "line 3 (turbine 't002')", "maximum range 4.000 km")
    status, _, err = run(["farm", layout, "--radar", "0,0,20", "--wind-from", "0", "--wind-speed", "30",
                          "--out", out], capsys)
    assert_refused(status, err, out, "--wind-speed", "30 m/s", "3-25 m/s")


def test_missing_layout_and_bad_radar(tmp_path, capsys):
    out = tmp_path / "o" / "farm.toml"
    status, _, err = run(["farm", tmp_path / "nope.csv", "--radar", "0,0,20", "--wind-from", "0",
                          "--out", out], capsys)
    assert_refused(status, err, out, "nope.csv", "cannot read the layout")
    (tmp_path / "g.csv").write_text("xlong,ylat\n-100.3,32.4\n")
    status, _, err = run(["farm", tmp_path / "g.csv", "--radar=-100.4,32.4,20", "--wind-from", "0",
                          "--out", out], capsys)
    assert_refused(status, err, out, "--radar: latitude -100.4", "LAT,LON,HEIGHT_M")
    (tmp_path / "l.csv").write_text("x,y\n0,3000\n")
    status, _, err = run(["farm", tmp_path / "l.csv", "--radar", "0,0", "--wind-from", "0",
                          "--out", out], capsys)
    assert_refused(status, err, out, "--radar", "three numbers")


# ------------------------------------------------------------------ the example

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
EXAMPLE_ARGS = ["--radar", "32.40,-100.40,25", "--wind-from", "200", "--wind-speed", "9", "--prf", "12000"]


def test_example_farm_regenerates_identically(tmp_path, capsys):
    """examples/farm_layout.toml is what `rast farm` makes of the example layout
    (the command in the layout's header), byte for byte."""
    layout = EXAMPLES / "farm_layout_uswtdb.csv"
    comments = " ".join(line.lstrip("#").replace("\\", " ") for line in layout.read_text().splitlines()
                        if line.startswith("#"))
    assert " ".join(EXAMPLE_ARGS) in " ".join(comments.split())
    out = tmp_path / "farm.toml"
    status, _, err = run(["farm", layout, *EXAMPLE_ARGS, "--out", out], capsys)
    assert status == 0, err
    assert out.read_text() == (EXAMPLES / "farm_layout.toml").read_text()
    farm = load_config(EXAMPLES / "farm_layout.toml")
    assert len(farm.windmills) >= 60 and farm.radar.prf_hz == 12000


def test_tower_and_ram_depth_options(tmp_path, capsys):
    """--tower-rcs puts a static return on every turbine, --ram-depth the build's pool at the top."""
    layout = tmp_path / "layout.csv"
    layout.write_text("x,y\n0,3000\n400,3200\n")
    out = tmp_path / "farm.toml"
    status, _, err = run(["farm", layout, "--radar", "0,0,20", "--wind-from", "90", "--tower-rcs", "50",
                          "--ram-depth", "4096", "--out", out], capsys)
    assert status == 0, err
    farm = load_config(out)
    assert farm.ram_depth == 4096
    assert [w.tower.rcs_m2 for w in farm.windmills] == [50.0, 50.0]
    assert all(w.tower.shadow_width_deg == 0 for w in farm.windmills)
    status, _, err = run(["farm", layout, "--radar", "0,0,20", "--wind-from", "90", "--out", out], capsys)
    assert status == 0, err
    assert all(w.tower is None for w in load_config(out).windmills) and load_config(out).ram_depth is None
    bad = tmp_path / "refused" / "bad.toml"
    bad.parent.mkdir()
    status, _, err = run(["farm", layout, "--radar", "0,0,20", "--wind-from", "90", "--ram-depth", "0",
                          "--out", bad], capsys)
    assert_refused(status, err, bad, "--ram-depth", "positive whole number")


# ------------------------------------------------------------------ the 64-channel block-RAM example

ATC_ARGS = ["--radar", "32.1870,-100.4315,20", "--wind-from", "200", "--wind-speed", "9",
            "--radar-frequency", "2800", "--prf", "1000", "--pulse-width", "1", "--tower-rcs", "100",
            "--ram-depth", "65536"]
#: The default build of the time-multiplexed engine: stream pool, common delay and tap
#: window (samples at 20 MS/s), FIR interpolation up to fs/768.
POOL_WORDS, MAX_DELAY, MAX_TAP, FIR_RATIO = 65_536, 8190, 2046, 768


def test_atc_example_regenerates_identically(tmp_path, capsys):
    """examples/farm_atc_sband.toml is what `rast farm` makes of the example layout
    with the S-band radar of docs/farm_layouts.md, byte for byte."""
    docs = (EXAMPLES.parent / "docs" / "farm_layouts.md").read_text()
    assert " ".join(ATC_ARGS) in " ".join(docs.replace("\\", " ").split())
    out = tmp_path / "farm.toml"
    status, _, err = run(["farm", EXAMPLES / "farm_layout_uswtdb.csv", *ATC_ARGS, "--out", out], capsys)
    assert status == 0, err
    assert out.read_text() == (EXAMPLES / "farm_atc_sband.toml").read_text()


def test_atc_example_fits_the_block_ram_build():
    """64 channels whose streams fit the pool with room to reload the longest while
    all play, whose depth fits the tap window, played by the FIR within its rate
    and seen by the radar without Doppler aliasing."""
    from rast.model.physics.stream import build_farm_streams
    farm = load_config(EXAMPLES / "farm_atc_sband.toml")
    assert len(farm.windmills) == 64 and farm.ram_depth == POOL_WORDS
    assert 2700 <= farm.radar.frequency_mhz <= 2900                    # S band, airport surveillance
    assert farm.sample_rate_hz % farm.radar.prf_hz == 0                 # whole samples per PRI
    assert all(w.num_blades == 3 and w.num_rcs == 8 and w.wire is not None and w.tower.rcs_m2 > 0
               for w in farm.windmills)
    fs = build_farm_streams(farm)                                       # refuses what ram_depth cannot hold
    lengths = [s.plan.length for s in fs.streams]
    assert sum(lengths) + max(lengths) <= POOL_WORDS                    # a reload of the longest fits beside
    delays = [s.delay_samples for s in fs.streams]
    assert min(delays) <= MAX_DELAY and max(delays) - min(delays) <= MAX_TAP
    assert all(s.plan.stream_rate_hz <= farm.sample_rate_hz / FIR_RATIO for s in fs.streams)
    assert all(s.plan.stream_rate_hz >= 4 * s.plan.max_doppler_hz for s in fs.streams)
    assert max(s.plan.max_doppler_hz for s in fs.streams) < farm.radar.prf_hz / 2


@pytest.mark.parametrize("headroom", [True, False])
def test_a_full_scale_pulse_through_the_atc_farm_does_not_clip(tmp_path, headroom):
    """Eight turbines of the S-band farm lie within one 1 us pulse; their echoes
    add up in the block's output. `rast farm` lowers output_gain_db so that
    their largest possible sum is full scale: a full-scale chirp through the
    bit-exact model of the block then never sets the saturation flag. Without
    that line (gains as at 0 dB, the loudest single echo at full scale) the
    same pulses saturate it."""
    from rast.model.contract.fixedpoint import OUTPUT
    from rast.model.physics.stream import build_farm_streams
    from rast.sim.e2e import prepare
    from rast.sim.scenario import model_outputs
    text = (EXAMPLES / "farm_atc_sband.toml").read_text()
    gain_line = [line for line in text.splitlines() if line.startswith("output_gain_db")]
    assert len(gain_line) == 1
    if not headroom:
        text = text.replace(gain_line[0] + "\n", "")
    config = tmp_path / "farm.toml"
    config.write_text(text)
    level = build_farm_streams(load_config(config)).echo_sum()
    assert len(level.windmills) == 8 and level.pulse_samples == 20
    e = prepare(config, 0.01, amplitude=1.0)                  # 10 pulses, full scale on I and Q
    yi, yq, overflow = model_outputs(e.scenario)
    peak = max(np.abs(yi).max(), np.abs(yq).max())
    if headroom:
        assert -0.1 <= level.level_dbfs <= 0.0 and not level.clips
        assert overflow == 0 and peak < OUTPUT.max
        assert peak > OUTPUT.max / 10                         # the echoes are there, within 20 dB
    else:
        assert level.clips and level.level_dbfs > 15
        assert overflow == 1 and peak == -OUTPUT.min


def test_preview_draws_a_grid_of_range_bins_or_a_map(tmp_path, capsys):
    """More range bins than fit stacked: a grid of small panels, not one tall
    column; --range-doppler draws the map instead."""
    from rast.model.radar.plot import STACKED_PANELS
    rows = "\n".join(f"{k * 40},{3000 + 400 * k}" for k in range(10))
    (tmp_path / "l.csv").write_text("x,y\n" + rows + "\n")
    config = tmp_path / "farm.toml"
    assert run(["farm", tmp_path / "l.csv", "--radar", "0,0,20", "--wind-from", "90", "--out", config],
               capsys)[0] == 0
    png = tmp_path / "grid.png"
    status, printed, err = run(["preview", config, "--seconds", "0.2", "--out", png], capsys)
    assert status == 0, err
    assert "10 range bin(s)" in printed and "range-Doppler map" not in printed and 10 > STACKED_PANELS
    width, height = png_size(png)
    assert height < 1.5 * width            # a grid (4 x 3 panels), not ten stacked rows
    png = tmp_path / "map.png"
    status, printed, err = run(["preview", config, "--seconds", "0.2", "--range-doppler", "--out", png], capsys)
    assert status == 0, err
    assert "range-Doppler map" in printed
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def png_size(path) -> tuple[int, int]:
    """Width and height of a PNG, from its IHDR chunk."""
    data = Path(path).read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
