"""``rast assess``: the reference processor checked against closed forms.

Every count of random events is compared with an exact binomial interval
(99.9 %) over decisions that are independent by construction (disjoint CFAR
windows, clutter-map decisions far apart in scans); the seeds are fixed, so
each test passes or fails the same way on every run.
"""

import csv
import dataclasses
import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from rast.cli import main
from rast.model.physics.config import ConfigError, SPEED_OF_LIGHT_M_S
from rast.model.physics.farm import load_config, parse_config
from rast.model.physics.stream import build_farm_streams
from rast.model.physics.turbine import max_doppler_hz
from rast.model.radar import cfar as cf
from rast.model.radar import moments as mo
from rast.model.radar import mtd as mt
from rast.model.radar.assess import AssessConfig, GateGrid, Scene, assess, process, write_outputs
from rast.model.radar.receiver import receive

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
ATC = EXAMPLES / "farm_atc_sband.toml"
WINDOW = 2 * (1 + 8) + 1         # the default CA-CFAR's span: 8 reference + 1 guard cells each side


def complex_noise(rng, shape, power=1.0):
    return np.sqrt(power / 2) * (rng.standard_normal(shape) + 1j * rng.standard_normal(shape))


def within(count, n, p, confidence=0.999):
    lo, hi = cf.binomial_interval(n, p, confidence)
    return lo <= count <= hi, (lo, hi)


# ---------------------------------------------------------------------------
# CFAR and clutter map against their design Pfa, Marcum Q and Albersheim

def test_ca_cfar_false_alarm_rate_is_pfa():
    """Noise alone: the fraction of cells a CA-CFAR declares is Pfa. Cells are
    tested one per disjoint window (every 19th gate), so the decisions are
    independent and their count is Binomial(n, Pfa)."""
    rng = np.random.default_rng(11)
    cfg = cf.CfarConfig(reference_cells=16, guard_cells=1, pfa=1e-3)
    power = np.abs(complex_noise(rng, (4000, WINDOW * 40))) ** 2
    detected, noise, alpha = cf.ca_cfar(power, cfg)
    tested = detected[:, WINDOW // 2::WINDOW]
    assert np.allclose(alpha[WINDOW // 2::WINDOW], 16 * (1e-3 ** (-1 / 16) - 1))
    ok, bounds = within(int(tested.sum()), tested.size, 1e-3)
    assert ok, (int(tested.sum()), bounds, tested.size)


def test_ca_cfar_detects_a_steady_target_at_marcum_q_rate():
    """A Swerling 0 target of 12 dB SNR in every tested cell: detected at the
    CA-CFAR's closed-form probability E[Q1(√(2S), √(2αY/N))] (Marcum Q over the
    Gamma-distributed reference sum), within binomial bounds."""
    rng = np.random.default_rng(12)
    cfg = cf.CfarConfig(reference_cells=16, guard_cells=1, pfa=1e-4)
    snr = 10 ** (12 / 10)
    x = complex_noise(rng, (3000, WINDOW * 40))
    cut = np.arange(WINDOW // 2, x.shape[1], WINDOW)
    x[:, cut] += math.sqrt(snr) * np.exp(2j * np.pi * rng.random((x.shape[0], cut.size)))
    detected, _, _ = cf.ca_cfar(np.abs(x) ** 2, cfg)
    pd = float(cf.ca_cfar_pd(snr, 16, 1e-4))
    assert 0.3 < pd < 0.8                                    # the test is sensitive where Pd is
    hits = detected[:, cut]
    ok, bounds = within(int(hits.sum()), hits.size, pd)
    assert ok, (int(hits.sum()), bounds, pd)


def test_closed_forms_agree():
    """Marcum Q at a = 0 is exp(−b²/2); the CA-CFAR Pd at S = 0 is Pfa; with many
    reference cells it tends to the known-noise Pd; Albersheim's SNR for Pd 0.9
    gives Pd 0.9 ± 0.02 by Marcum Q (his equation is good to about 0.2 dB)."""
    b = np.array([0.5, 1.0, 3.0, 5.0])
    assert np.allclose(cf.marcum_q1(0.0, b), np.exp(-b ** 2 / 2), rtol=1e-12)
    for n in (4, 16, 32):
        assert cf.ca_cfar_pd(0.0, n, 1e-6) == pytest.approx(1e-6, rel=1e-6)
    s = 10 ** (13 / 10)
    known = float(cf.marcum_q1(math.sqrt(2 * s), math.sqrt(-2 * math.log(1e-6))))
    assert float(cf.ca_cfar_pd(s, 512, 1e-6)) == pytest.approx(known, abs=0.01)
    for pfa in (1e-3, 1e-6):
        snr = 10 ** (cf.albersheim_snr_db(0.9, pfa) / 10)
        assert float(cf.marcum_q1(math.sqrt(2 * snr), math.sqrt(-2 * math.log(pfa)))) == pytest.approx(0.9, abs=0.02)


def stare_config(**kw):
    return AssessConfig(seconds=1.0, **kw)


def test_mtd_chain_false_plots_and_clutter_map_rate():
    """Noise alone through canceller, Doppler filters, CFAR and clutter map:
    the MTD plots number Pfa times the cells tested, and the clutter map's
    steady-state false alarms its Pfa, each within binomial bounds. The map
    decisions counted are 40 scans apart (a map of weight 1/8 then shares
    (7/8)^40 = 0.5 % of its memory) after 120 scans of warm-up."""
    rng = np.random.default_rng(13)
    gates, scans = 120, 2400
    cfg = stare_config(mtd=mt.MtdConfig(cpi_pulses=10, canceller_pulses=3), scan_cpis=1,
                       cfar=cf.CfarConfig(16, 1, 1e-4), clutter_map=cf.ClutterMapConfig(0.125, 1e-2))
    samples = complex_noise(rng, (gates, scans * 10))
    result = process(samples, np.arange(scans * 10) / 1000.0, cfg, wavelength_m=0.1)
    mtd_plots = result.plot_channel == "mtd"
    # CFAR cells: every gate has some reference cells; 7 of the 8 filters (not zero Doppler)
    n = gates * scans * 7
    ok, bounds = within(int(mtd_plots.sum()), n, 1e-4)
    assert ok, (int(mtd_plots.sum()), bounds)
    zero = ~mtd_plots
    picked = (result.plot_cpi >= 120) & ((result.plot_cpi - 120) % 40 == 0)
    looks = len(range(120, scans, 40)) * gates
    count = int((zero & picked).sum())
    ok, bounds = within(count, looks, 1e-2)
    assert ok, (count, bounds, looks)


def test_mtd_detects_a_tone_at_the_coherent_closed_form():
    """A steady tone at a Doppler filter's centre, no canceller, rectangular
    window: the N-pulse FFT integrates its SNR N times, and the MTD plots it at
    the CA-CFAR's closed-form probability for N·SNR, at the right Doppler."""
    rng = np.random.default_rng(14)
    n_pulses, cpis, prf = 8, 1500, 1000.0
    gates = WINDOW * 12
    cfg = stare_config(mtd=mt.MtdConfig(cpi_pulses=n_pulses, canceller_pulses=0, window="rect"),
                       cfar=cf.CfarConfig(16, 1, 1e-6), clutter_map=cf.ClutterMapConfig(0.125, 1e-12))
    t = np.arange(n_pulses * cpis) / prf
    f0 = 3 * prf / n_pulses                                  # filter 3's centre
    snr = 10 ** (3.5 / 10)                                   # per pulse: 12.5 dB after 8 pulses
    x = complex_noise(rng, (gates, t.size))
    targets = np.arange(WINDOW // 2, gates, WINDOW)
    x[targets] += math.sqrt(snr) * np.exp(2j * np.pi * (f0 * t[None, :] + rng.random((targets.size, 1))))
    result = process(x, t, cfg, wavelength_m=0.1)
    at_target = np.isin(result.plot_gate, targets)
    assert np.allclose(result.plot_doppler_hz[at_target], f0, rtol=1e-9)
    pd = float(cf.ca_cfar_pd(n_pulses * snr, 16, 1e-6))
    assert 0.3 < pd < 0.9
    ok, bounds = within(int(at_target.sum()), targets.size * cpis, pd)
    assert ok, (int(at_target.sum()), bounds, pd)


@pytest.mark.parametrize("pulses", [2, 3])
def test_mti_canceller_response_is_the_closed_form(pulses):
    """Tones through the canceller and a rectangular-window filter bank: the
    filter a tone sits on carries its amplitude times |2 sin(π f T)|^(n−1)
    for an n-pulse canceller (n−1 delays), across the whole band."""
    prf, n = 1000.0, 17
    cfg = mt.MtdConfig(cpi_pulses=n, canceller_pulses=pulses, window="rect")
    m = cfg.kept_pulses
    t = np.arange(n) / prf
    k = np.arange(m)
    f = k * prf / m
    samples = np.exp(2j * np.pi * f[:, None] * t[None, :])            # one gate per tone
    plan = mt.plan_cpis(n, n)
    spectrum = mt.doppler_filter_bank(samples, plan, cfg)[0]          # (gates, filters)
    measured = np.abs(spectrum[k, k])
    expected = np.abs(2 * np.sin(np.pi * f / prf)) ** (pulses - 1)
    assert np.allclose(measured, expected, rtol=1e-9, atol=1e-12)
    assert np.allclose(mt.canceller_response(f, prf, pulses), expected, rtol=1e-9, atol=1e-12)


# ---------------------------------------------------------------------------
# Weather moments

def test_pulse_pair_velocity_of_a_tone_is_exact():
    """A pure tone of Doppler f: the pulse-pair velocity is −λf/2 to float precision."""
    prf, lam = 1000.0, 0.107
    f = np.array([-480.0, -123.4, 0.5, 77.7, 333.0, 499.0])
    t = np.arange(64) / prf
    blocks = np.exp(2j * np.pi * f[:, None] * t[None, :])[None]        # (1 radial, gates, pulses)
    out = mo.radial_moments(blocks, 1 / prf, lam, cfg=mo.MomentsConfig(64, "none", "numpy"))
    assert np.allclose(out["velocity_m_s"][0], -lam * f / 2, rtol=1e-12, atol=1e-12)
    assert np.allclose(out["width_m_s"][0], 0.0, atol=1e-5)
    assert np.allclose(out["power"][0], 1.0, rtol=1e-12)


def test_pyart_moments_agree_with_numpy_or_say_how_to_install():
    """Py-ART's I/Q retrievals give the numpy estimators' moments (to its
    single-precision autocorrelations); without Py-ART (pyart_mch does not
    resolve beside the pinned packages, docs/assess.md) asking for it is
    refused with the install line, and ``auto`` falls back to numpy."""
    rng = np.random.default_rng(15)
    prf, lam = 1000.0, 0.107
    f = np.array([-300.0, 40.0, 250.0])
    t = np.arange(64) / prf
    blocks = (np.exp(2j * np.pi * (f[:, None] * t[None, :])) * (1 + 0.3 * rng.standard_normal((3, 64))))[None]
    blocks = np.repeat(blocks, 4, axis=0) + complex_noise(rng, (4, 3, 64), 0.05)
    a = mo.radial_moments(blocks, 1 / prf, lam, noise_power=0.05, cfg=mo.MomentsConfig(64, "mean", "numpy"))
    if not mo.pyart_available():
        with pytest.raises(ValueError, match=r"pip install 'rast\[weather\]'"):
            mo.radial_moments(blocks, 1 / prf, lam, noise_power=0.05, cfg=mo.MomentsConfig(64, "mean", "pyart"))
        auto = mo.radial_moments(blocks, 1 / prf, lam, noise_power=0.05, cfg=mo.MomentsConfig(64, "mean", "auto"))
        assert auto["engine"] == "numpy"
        for key in ("power", "velocity_m_s", "width_m_s"):
            assert np.array_equal(a[key], auto[key]), key
        return
    b = mo.radial_moments(blocks, 1 / prf, lam, noise_power=0.05, cfg=mo.MomentsConfig(64, "mean", "pyart"))
    assert b["engine"] == "pyart"
    for key in ("power", "velocity_m_s", "width_m_s"):
        assert np.allclose(a[key], b[key], rtol=1e-4, atol=1e-4), key


ONE_TURBINE = """
sample_rate = 20
radar_frequency = 5350
prf = 20000
pulse_width = 2
noise_dbfs = -100

[[windmill]]
name = "w"
range = 3.0
num_blades = 3
rpm = 15
radius = [12.0, 6.0]
rsc = [1.0, 0.5]
phase_start = [0.0, 90.0]
"""


def test_turbine_width_matches_the_blades_doppler_spread():
    """The run's spectrum width at a turbine's gate is its blades' RMS Doppler.

    Scatterer k has the Doppler f_k·cos β (f_k = max_doppler_hz at r_k), β
    uniform over whole revolutions: mean 0, mean square f_k²/2, weighted by
    RCS: σ_f² = Σ σ_k f_k²/2 / Σ σ_k, σ_v = λσ_f/2. Tolerance 3 %: the
    Gaussian pulse-pair estimator reads −2 ln J0(2π f_k T) instead of
    (2π f_k T)²/2, +0.3 % at f_k T = 0.034 here; the cross terms between
    scatterers average to J0 of ≥ 1300 rad over a revolution (≤ 2 % of a
    pair's power, entering R0 and R1 alike)."""
    farm = parse_config(tomllib.loads(ONE_TURBINE))
    w = farm.windmills[0]
    lam = farm.radar.wavelength_m
    f = max_doppler_hz(w, lam) * w.radius_m / w.radius_m.max()
    sigma_f = math.sqrt(np.sum(w.rcs_m2 * f ** 2 / 2) / np.sum(w.rcs_m2))
    cfg = AssessConfig(seconds=4.0, physics=True,                 # one revolution, 3 blade periods
                       moments=mo.MomentsConfig(400, "none", "numpy"))
    scene, result, summary = assess(farm, cfg)
    gate = summary["gates"][0]
    assert gate["width_m_s"] == pytest.approx(lam * sigma_f / 2, rel=0.03)
    assert gate["expected_width_m_s"] == pytest.approx(lam * sigma_f / 2, rel=1e-4)
    assert abs(gate["velocity_bias_m_s"]) < 0.02 * lam * sigma_f / 2


# ---------------------------------------------------------------------------
# The receiver noise

def test_noise_dbfs_config_key():
    base = "sample_rate = 20\nradar_frequency = 5350\n[[windmill]]\nname = \"a\"\nrange = 2.0\nnum_blades = 3\n" \
           "rpm = 15\nradius = [26.0]\nrsc = [1.0]\n"
    assert parse_config(tomllib.loads(base)).noise_dbfs is None           # existing configs unchanged
    assert parse_config(tomllib.loads("noise_dbfs = -60\n" + base)).noise_dbfs == -60.0
    for bad, needle in (("3", "at most 0"), ('"loud"', "must be a number"), ("-1000", "at most 300")):
        with pytest.raises(ConfigError, match=needle):
            parse_config(tomllib.loads(f"noise_dbfs = {bad}\n" + base))


def test_receive_adds_seeded_noise_of_the_configured_power():
    """receive(): complex white Gaussian noise of noise_dbfs per sample,
    reproducible; the mean power of 2·10⁵ samples lies within ±2 % (10 σ of
    the exponential's 1/√n)."""
    farm = load_config(EXAMPLES / "two_windmills.toml")
    streams = build_farm_streams(farm)
    noisy = dataclasses.replace(farm, noise_dbfs=-50.0)
    _, _, clean = receive(farm, 10.0, streams)
    _, _, a = receive(noisy, 10.0, streams)
    _, _, b = receive(noisy, 10.0, streams)
    _, _, c = receive(noisy, 10.0, streams, noise_seed=2)
    noise = a - clean
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert np.mean(np.abs(noise) ** 2) == pytest.approx(1e-5, rel=0.02)
    assert abs(np.mean(noise.real ** 2) / np.mean(noise.imag ** 2) - 1) < 0.02


# ---------------------------------------------------------------------------
# A rast config, the azimuth path, the RTL's gates

def test_cfar_on_a_farm_plots_at_the_turbines():
    """examples/farm_atc_sband.toml, one second: the turbines' blades give MTD
    plots, every one at a turbine's range gate (or the next: a pulse covers
    c·τ/2 beyond), none elsewhere beyond the noise's own binomial bound."""
    farm = load_config(ATC)
    scene, result, summary = assess(farm, AssessConfig(seconds=1.0))
    spacing = scene.grid.spacing_km
    assert spacing == pytest.approx(SPEED_OF_LIGHT_M_S * 1e-6 / 2 / 1e3)
    ranges = np.array([w.range_km for w in farm.windmills])
    plot_km = scene.grid.centres_km[result.plot_gate]
    near = np.min(np.abs(plot_km[:, None] - ranges[None, :]), axis=1) <= 1.5 * spacing
    lo, hi = summary["noise_plots_per_scan_interval_99_9"]
    assert (~near).sum() <= hi
    assert near.sum() > 100
    plotted = set(result.plot_gate.tolist())
    assert all(g in plotted or g + 1 in plotted for g in scene.grid.index(ranges).tolist())
    assert all(t["detection_fraction"] > 0 for t in summary["turbines"])
    assert summary["false_plots_per_scan_mean"] == result.plots       # one scan: the whole run


def test_azimuth_path_dwells_revolutions_and_ppi(tmp_path):
    """A synthetic scan: 2 revolutions at 60 rpm (1 s each) and a PRF of 2 kHz,
    a 2° beam: dwells of about 11 pulses, one CPI of 10 in each. A target at
    30° and gate 40 answers only while the beam is on it: the plots are at
    its azimuth and range, two scans, and the picture is a PPI."""
    rng = np.random.default_rng(16)
    prf, rpm, bw = 2000.0, 60.0, 2.0
    t = np.arange(int(2 * 60 / rpm * prf)) / prf
    az = (6 * rpm * t + 0.1) % 360
    gates = 80
    x = complex_noise(rng, (gates, t.size))
    on = np.abs((az - 30.0 + 180) % 360 - 180) <= bw / 2
    x[40, on] += 30 * np.exp(2j * np.pi * 300.0 * t[on])
    cfg = AssessConfig(seconds=2.0, beamwidth_deg=bw, mtd=mt.MtdConfig(10, 3),
                       cfar=cf.CfarConfig(16, 1, 1e-6), clutter_map=cf.ClutterMapConfig(0.125, 1e-9))
    result = process(x, t, cfg, wavelength_m=0.1, azimuth_deg=az, noise_power=1.0)
    plan = result.plan
    assert plan.scans == 2 and plan.cells == 180
    cell_of_pulse = (np.mod(az, 360) // bw).astype(int)
    idx = plan.start[:, None] + np.arange(10)[None, :]
    assert np.all(cell_of_pulse[idx] == cell_of_pulse[plan.start][:, None])      # CPIs inside dwells
    assert np.bincount(plan.scan).tolist() == [180, 180]
    target = result.plot_gate == 40
    assert target.sum() >= 2
    assert np.all(np.abs(plan.azimuth_deg[result.plot_cpi[target]] - 30.0) <= bw)
    assert set(plan.scan[result.plot_cpi[target]].tolist()) == {0, 1}
    assert (~target).sum() <= cf.binomial_interval(plan.count * gates * 8, 1e-6)[1]
    farm = load_config(EXAMPLES / "two_windmills.toml")
    scene = Scene(x, t, GateGrid(0, 0.15, gates), farm, 0.0, "replay", az)
    from rast.model.radar.assess import summarize
    summary = summarize(scene, result, cfg)
    written = write_outputs(tmp_path, scene, result, summary)
    assert [p.name for p in written] == ["plots.csv", "summary.json", "ppi.png"]
    rows = list(csv.DictReader(open(tmp_path / "plots.csv")))
    assert len(rows) == result.plots and all(r["azimuth_deg"] for r in rows)


def test_cli_assess_writes_plots_summary_and_picture(tmp_path, capsys):
    out = tmp_path / "a"
    assert main(["assess", str(ATC), "--seconds", "0.5", "--out", str(out)]) == 0
    stdout = capsys.readouterr().out
    assert "false plots / scan" in stdout and "detection fraction" in stdout and "velocity bias" in stdout
    rows = list(csv.DictReader(open(out / "plots.csv")))
    assert rows and list(rows[0]) == ["time_s", "range_km", "azimuth_deg", "doppler_hz", "snr_db", "scan",
                                      "channel"]
    assert all(r["azimuth_deg"] == "" for r in rows)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["plots"] == len(rows) and summary["parameters"]["noise_dbfs"] == -70.0
    assert (out / "range_doppler.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_cli_assess_refuses_before_writing(tmp_path, capsys):
    out = tmp_path / "never"
    for argv, needle in ((["--gates", str(tmp_path / "none.npy")], "--gates"),
                         (["--stagger-prf", "1100", "--gates", str(tmp_path)], "--gates"),
                         (["--sweep", "wind=0:10:5"], "--sweep"),
                         (["--sweep", "rpm=0.5x,1x", "--sweep", "rpm=2x,3x"], "twice"),
                         (["--cpi-pulses", "2", "--canceller", "3"], "--cpi-pulses")):
        status = main(["assess", str(ATC), "--seconds", "0.2", "--out", str(out), *argv])
        err = capsys.readouterr().err
        assert status == 2 and err.startswith("rast assess: ") and needle in err, (argv, err)
        assert not out.exists()


def test_rtl_gates_are_assessed_like_the_model(tmp_path):
    """A cosimulation's gates.npy (output words, one row per pulse) with the
    report beside it: the same plots as the model's replay samples, as the
    RTL's output is the model's bit for bit (here: the model's samples rounded
    to output words)."""
    farm = load_config(ATC)
    _, bins, samples = receive(farm, 0.5, build_farm_streams(farm))
    words = np.round(samples.T * (1 << 15))
    np.save(tmp_path / "gates.npy", words.astype(np.complex128))
    (tmp_path / "report.json").write_text(json.dumps(dict(prf_hz=farm.radar.prf_hz,
                                                          gates_km=[b.range_km for b in bins])))
    from rast.model.radar.assess import read_gates
    gates, report, _ = read_gates(tmp_path)
    cfg = AssessConfig(seconds=0.5)
    rtl = assess(farm, cfg, gates=gates, report=report)
    model = assess(farm, cfg)
    assert rtl[0].source == "rtl" and rtl[1].plots == model[1].plots
    assert np.array_equal(rtl[1].plot_gate, model[1].plot_gate)


# ---------------------------------------------------------------------------
# Sweeps on Dask

def test_sweep_parsing():
    from rast.model.radar.sweep import SweepError, grid, parse_axis
    assert parse_axis("wind_from=0:360:15").values == tuple(range(0, 360, 15))
    assert parse_axis("rpm=0.8x,1x").factor and parse_axis("rpm=10,12").values == (10.0, 12.0)
    assert len(grid([parse_axis("wind_from=0:90:30"), parse_axis("rpm=1x,2x")])) == 6
    for bad in ("speed=1,2", "wind_from=0:360:0", "wind_from=10,400", "rpm=0x", "scan_start_deg=1x"):
        with pytest.raises(SweepError):
            parse_axis(bad)


def test_sweep_on_a_local_dask_cluster(tmp_path, capsys):
    """Two wind directions of the ATC farm, made again from its layout (the
    config's header), on a LocalCluster of one worker process: one row per
    case in sweep.csv, the summary plot, and each case's summary."""
    out = tmp_path / "s"
    assert main(["assess", str(ATC), "--seconds", "0.3", "--sweep", "wind_from=200,290",
                 "--workers", "1", "--out", str(out)]) == 0
    stdout = capsys.readouterr().out
    assert "2 case(s) assessed" in stdout
    rows = list(csv.DictReader(open(out / "sweep.csv")))
    assert [float(r["wind_from"]) for r in rows] == [200.0, 290.0]
    assert all(r["error"] == "" and float(r["false_plots_per_scan_mean"]) >= 0 for r in rows)
    assert (out / "sweep.png").exists() and len(list((out / "cases").glob("case_*.json"))) == 2
    # the farm made again for the config's own wind (200°) is the config's farm (header's rounding aside)
    first = json.loads((out / "cases" / "case_0000.json").read_text())
    config = {t["name"]: t["range_km"] for t in assess(load_config(ATC), AssessConfig(seconds=0.3))[2]["turbines"]}
    again = {t["name"]: t["range_km"] for t in first["turbines"]}
    assert again.keys() == config.keys()
    assert max(abs(again[k] - config[k]) for k in config) < 0.2


def test_sweep_rpm_factor_and_scan_start(tmp_path):
    """rpm factors scale every windmill's rotor speed; scan_start_deg turns
    a turning antenna's start and is noted as without effect on a staring
    one. Threads this time."""
    from rast.model.radar.sweep import case_data, parse_axis
    base = tomllib.loads(ATC.read_text())
    axes = {"rpm": parse_axis("rpm=2x"), "scan_start_deg": parse_axis("scan_start_deg=0,90")}
    data, notes = case_data(base, {"rpm": 2.0, "scan_start_deg": 90.0}, axes, None)
    assert [t["rpm"] for t in data["windmill"]] == [2 * t["rpm"] for t in base["windmill"]]
    assert data["scan_start_deg"] == 90.0 and notes and "stares" in notes[0]
    turning, notes = case_data(tomllib.loads((EXAMPLES / "asr_scan.toml").read_text()),
                               {"scan_start_deg": 90.0}, axes, None)
    assert turning["scan_start_deg"] == 90.0 and notes == []
    out = tmp_path / "r"
    assert main(["assess", str(EXAMPLES / "two_windmills.toml"), "--seconds", "0.05", "--sweep", "rpm=0.5x,1x",
                 "--threads", "--workers", "1", "--out", str(out)]) == 0
    rows = list(csv.DictReader(open(out / "sweep.csv")))
    assert [float(r["rpm"]) for r in rows] == [0.5, 1.0] and all(r["error"] == "" for r in rows)
