"""SFDR over the whole Doppler band (rast.model.radar.sfdr) and its place in ``rast preview``.

Every tone sits on a DFT bin centre (PRF 20 kHz, CPI 0.1 s: 2000 pulses, 10 Hz
bins), where the periodic Blackman-Harris window has no scalloping loss and
leaks nowhere beyond ±3 bins, so a line's power ratio is exactly its
amplitude ratio squared: the expected SFDR is the construction's own.
"""

import numpy as np
import pytest

from rast.cli import main
from rast.model.physics.farm import parse_config
from rast.model.radar.receiver import range_bins, receive
from rast.model.radar.sfdr import SfdrResult, blackman_harris, farm_sfdr, sfdr, worst

PRF = 20_000.0
CPI = 0.1
N = 2000                       # pulses per CPI
BIN = PRF / N                  # 10 Hz


def tone(f_hz, level_db=0.0, n=N, phase=0.0):
    t = np.arange(n) / PRF
    return 10 ** (level_db / 20) * np.exp(1j * (2 * np.pi * f_hz * t + phase))


def test_window_is_the_four_term_blackman_harris():
    w = blackman_harris(8)
    # periodic: w[0] = a0 - a1 + a2 - a3, w[n/2] = a0 + a1 + a2 + a3 = 1
    assert w[0] == pytest.approx(0.35875 - 0.48829 + 0.14128 - 0.01168)
    assert w[4] == pytest.approx(1.0)
    np.testing.assert_allclose(w[1:], w[1:][::-1])


@pytest.mark.parametrize("spur_hz", [6000.0, -4320.0, 9990.0])
def test_spur_outside_the_band_sets_the_sfdr(spur_hz):
    x = tone(500.0, n=3 * N) + tone(spur_hz, -50.0, n=3 * N, phase=0.3)
    r = sfdr(x, PRF, CPI, [1000.0])
    assert isinstance(r, SfdrResult)
    assert r.sfdr_db == pytest.approx(50.0, abs=0.5)
    assert abs(r.spur_hz - spur_hz) <= BIN
    assert r.per_cpi_db.shape == (3,)
    np.testing.assert_allclose(r.per_cpi_db, 50.0, atol=0.5)


def test_strongest_line_anywhere_is_the_reference():
    # the carrier itself at -6 dB: the reference is the strongest line, not 0 dB
    x = tone(-700.0, -6.0) + tone(3000.0, -66.0)
    assert sfdr(x, PRF, CPI, [800.0]).sfdr_db == pytest.approx(60.0, abs=0.5)


def test_spur_inside_the_exclusion_is_not_counted():
    # -30 dB inside the turbines' band (900 Hz < 1000 Hz), -80 dB outside at 7000 Hz
    x = tone(200.0) + tone(900.0, -30.0) + tone(7000.0, -80.0)
    r = sfdr(x, PRF, CPI, [400.0, 1000.0])          # the largest maximum Doppler counts
    assert r.sfdr_db == pytest.approx(80.0, abs=0.5)
    assert abs(r.spur_hz - 7000.0) <= BIN


def test_guard_band_edges():
    # 1000 Hz + 6 guard bins = 1060 Hz is excluded; 1080 Hz (8 bins out) is not.
    # A bin-centred line leaks into ±3 bins: one at 1030 Hz stays within 1060 Hz.
    inside = tone(0.0) + tone(-1030.0, -20.0) + tone(5000.0, -70.0)
    assert sfdr(inside, PRF, CPI, [1000.0]).sfdr_db == pytest.approx(70.0, abs=0.5)
    outside = tone(0.0) + tone(-1080.0, -20.0) + tone(5000.0, -70.0)
    r = sfdr(outside, PRF, CPI, [1000.0])
    assert r.sfdr_db == pytest.approx(20.0, abs=0.5)
    assert abs(r.spur_hz + 1080.0) <= BIN
    # with no guard the 1030 Hz line is outside
    r = sfdr(inside, PRF, CPI, [1000.0], guard_bins=0)
    assert r.sfdr_db == pytest.approx(20.0, abs=0.5) and abs(r.spur_hz + 1030.0) <= BIN


def test_the_worst_cpi_is_found():
    # five CPIs and a half: a -60 dB spur throughout, a -40 dB one only in the 3rd
    # CPI, a -10 dB one only in the unfinished tail (not a CPI, so not counted)
    total = 5 * N + N // 2
    x = tone(300.0, n=total) + tone(-8000.0, -60.0, n=total)
    x[2 * N:3 * N] += tone(4000.0, -40.0)
    x[5 * N:] += tone(2000.0, -10.0, n=N // 2)
    r = sfdr(x, PRF, CPI, [500.0])
    assert r.cpi_index == 2
    assert r.sfdr_db == pytest.approx(40.0, abs=0.5)
    assert abs(r.spur_hz - 4000.0) <= BIN
    assert r.per_cpi_db.shape == (5,)
    np.testing.assert_allclose(r.per_cpi_db[[0, 1, 3, 4]], 60.0, atol=0.5)


def test_nothing_outside_the_band_is_infinite():
    r = sfdr(tone(100.0), PRF, CPI, [500.0])
    assert r.sfdr_db > 200          # only rounding leaks beyond ±3 bins of a bin-centred tone
    assert sfdr(np.zeros(N, complex), PRF, CPI, [500.0]).sfdr_db == np.inf


@pytest.mark.parametrize("kwargs, match", [
    (dict(samples=np.ones(N - 1, complex)), "samples: 1999 are fewer than one CPI"),
    (dict(samples=np.ones((2, N), complex)), "samples must be 1-D"),
    (dict(max_doppler_hz=[]), "max_doppler_hz is empty"),
    (dict(max_doppler_hz=[9950.0]), "covers the whole band"),
    (dict(max_doppler_hz=[9900.0], guard_bins=10), "guard_bins"),
    (dict(guard_bins=-1), "guard_bins must be >= 0"),
    (dict(prf_hz=0.0), "prf_hz must be a positive number"),
    (dict(cpi_s=-0.1), "cpi_s must be a positive number"),
    (dict(cpi_s=1e-5), "a CPI needs at least 2"),
])
def test_bad_inputs_name_the_parameter(kwargs, match):
    args = dict(samples=tone(0.0), prf_hz=PRF, cpi_s=CPI, max_doppler_hz=[1000.0])
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        sfdr(args.pop("samples"), args.pop("prf_hz"), args.pop("cpi_s"), args.pop("max_doppler_hz"), **args)


FARM = {"sample_rate": 20, "radar_frequency": 5350, "windmill": [
    {"name": "near", "range": 2.0, "num_blades": 1, "rpm": 15, "radius": [26.0], "rsc": [1.0]},
    {"name": "far", "range": 3.0, "num_blades": 1, "rpm": 25, "radius": [20.0], "rsc": [1.0]}]}


def test_farm_sfdr_excludes_each_bins_own_band_and_worst_picks_the_smallest():
    farm = parse_config(FARM)
    bins = range_bins(farm)
    assert [b.members for b in bins] == [(0,), (1,)]
    # max Doppler 2·ω·r/λ: near 2·(π/2)·26/λ ≈ 1458 Hz, far 2·(5π/6)·20/λ ≈ 1869 Hz
    lam = farm.radar.wavelength_m
    f_near, f_far = 2 * (np.pi / 2) * 26 / lam, 2 * (5 * np.pi / 6) * 20 / lam
    # a -40 dB line at 1700 Hz: outside near's band (+60 Hz guard), inside far's
    row = tone(100.0, n=2 * N) + tone(1700.0, -40.0, n=2 * N) + tone(-9000.0, -75.0, n=2 * N)
    assert f_near + 6 * BIN < 1700 < f_far
    res = farm_sfdr(farm, np.stack([row, row]), bins)
    assert res[0].sfdr_db == pytest.approx(40.0, abs=0.5) and abs(res[0].spur_hz - 1700) <= BIN
    assert res[1].sfdr_db == pytest.approx(75.0, abs=0.5) and abs(res[1].spur_hz + 9000) <= BIN
    assert worst(res) is res[0]
    with pytest.raises(ValueError, match="results is empty"):
        worst([])
    with pytest.raises(ValueError, match=r"shape \(bins, pulses\)"):
        farm_sfdr(farm, row, bins)


def test_draw_spectrogram_shows_the_whole_band_unless_zoomed():
    import matplotlib.pyplot as plt
    from rast.model.radar.plot import draw_spectrogram
    from rast.model.radar.receiver import spectrogram
    spec = spectrogram(tone(500.0, n=2 * N), PRF, CPI)
    fig, (a, b) = plt.subplots(2)
    draw_spectrogram(a, spec, lines=[("x", 1000.0)])
    draw_spectrogram(b, spec, lines=[("x", 1000.0)], zoom_hz=1500.0)
    lo, hi = a.get_ylim()
    assert lo <= -PRF / 2 and hi >= PRF / 2 - BIN
    assert b.get_ylim() == pytest.approx((-1500.0, 1500.0))
    plt.close(fig)


def test_preview_reports_the_sfdr_of_each_bin_and_the_worst(tmp_path, capsys):
    config = tmp_path / "farm.toml"
    config.write_text('sample_rate = 20\nradar_frequency = 5350\n'
                      '[[windmill]]\nname = "a"\nrange = 2.0\nnum_blades = 1\nrpm = 15\nradius = [26.0]\nrsc = [1.0]\n'
                      '[[windmill]]\nname = "b"\nrange = 2.6\nnum_blades = 1\nrpm = 20\nradius = [20.0]\nrsc = [1.0]\n')
    png = tmp_path / "pic.png"
    assert main(["preview", str(config), "--out", str(png), "--seconds", "0.5", "--replay", "--zoom", "3000"]) == 0
    out = capsys.readouterr().out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the same samples, measured here
    from rast.model.physics.stream import build_farm_streams
    farm = parse_config({"sample_rate": 20, "radar_frequency": 5350, "windmill": [
        {"name": "a", "range": 2.0, "num_blades": 1, "rpm": 15, "radius": [26.0], "rsc": [1.0]},
        {"name": "b", "range": 2.6, "num_blades": 1, "rpm": 20, "radius": [20.0], "rsc": [1.0]}]})
    _, bins, samples = receive(farm, 0.5, build_farm_streams(farm))
    res = farm_sfdr(farm, samples, bins)
    for b, r in zip(bins, res):
        assert f"SFDR range bin {b.range_km:g} km: {r.sfdr_db:.1f} dB" in out
    w = worst(res)
    assert f"worst SFDR {w.sfdr_db:.1f} dB" in out


def test_preview_rejects_a_bad_zoom(tmp_path, capsys):
    config = tmp_path / "farm.toml"
    config.write_text('sample_rate = 20\nradar_frequency = 5350\n'
                      '[[windmill]]\nname = "a"\nrange = 2.0\nnum_blades = 1\nrpm = 15\nradius = [26.0]\nrsc = [1.0]\n')
    with pytest.raises(SystemExit) as exc:
        main(["preview", str(config), "--out", str(tmp_path / "p.png"), "--zoom", "0"])
    assert exc.value.code == 2
    assert "--zoom" in capsys.readouterr().err
    assert not (tmp_path / "p.png").exists()
