"""Range-extended turbines (rast.model.physics.extended) against closed forms and the single-tap model."""

import dataclasses
import math

import numpy as np
import pytest

from rast.model.physics.config import SPEED_OF_LIGHT_M_S as C, ConfigError
from rast.model.physics.farm import parse_config
from rast.model.physics.turbine import range_cell_weight
from rast.model.radar.receiver import receive
from rast.model.contract.regmap import register_map
from rast.model.contract.loadplan import manifest_to_register_writes
from rast.model.physics.stream import build_farm_streams
from rast.model.physics.turbine import modulation, modulation_reference

FULL = dict(name="a", range=2.0, num_blades=3, rpm=15, rotor_angle=20, radius=[60.0, 30.0],
            rsc=[1.0, 0.5], phase_start=[0.0, 40.0], wire_enable=True, wire_radius_min=5.0,
            wire_radius_max=50.0, wire_reflectivity=0.1, tower_rcs=2.0, tower_shadow_width=20,
            rsc_weighting={"angle": [0, 180], "width": 6, "gain_db": 12})


def farm_of(windmill, sample_rate=20, **top):
    return parse_config({"sample_rate": sample_rate, "radar_frequency": 5350, **top,
                         "windmill": [windmill]})


def turbine_of(farm):
    """The unsplit turbine the taps came from."""
    tap = farm.windmills[0]
    return dataclasses.replace(tap, name=tap.range_cell.turbine, range_km=tap.range_cell.hub_range_km,
                               range_cell=None)


def test_weight_is_a_partition_of_unity_that_keeps_the_range():
    d = np.random.default_rng(1).uniform(100, 110, 1000)
    taps = np.arange(98, 113)
    w = np.stack([range_cell_weight(d, k) for k in taps])
    assert np.all(w >= 0) and np.all((w > 0).sum(axis=0) <= 2)
    np.testing.assert_allclose(w.sum(axis=0), 1.0, atol=1e-12)
    np.testing.assert_allclose(taps @ w, d, atol=1e-9)


def test_taps_of_a_hand_worked_turbine():
    # 2 km, 20 MS/s: hub delay 2·2000/c·20e6 = 266.855 samples; a 26 m blade in the line
    # of sight sweeps ±2·26/c·20e6 = ±3.469 samples: taps floor(263.386) … ceil(270.325).
    farm = farm_of(dict(name="a", range=2.0, num_blades=3, rpm=15, radius=[26.0], rsc=[1.0],
                        range_extended=True))
    assert [w.range_cell.delay_samples for w in farm.windmills] == list(range(263, 272))
    assert [w.name for w in farm.windmills] == [f"a.t{j}" for j in range(9)]
    streams = build_farm_streams(farm)
    assert [s.delay_samples for s in streams.streams] == list(range(263, 272))
    # At 60° the projection halves the sweep: ±1.735 samples, taps 265 … 269.
    farm = farm_of(dict(name="a", range=2.0, num_blades=3, rpm=15, radius=[26.0], rsc=[1.0],
                        rotor_angle=60, range_extended=True))
    assert [w.range_cell.delay_samples for w in farm.windmills] == list(range(265, 270))


@pytest.mark.parametrize("sample_rate", [20, 100])
def test_taps_sum_to_the_single_range_echo(sample_rate):
    farm = farm_of(dict(FULL, range_extended=True), sample_rate)
    assert len(farm.windmills) > 3
    t = np.linspace(0, 4, 2001)          # (a whole turn; the identity holds at every instant)
    total = sum(modulation(w, t, farm.radar.wavelength_m) for w in farm.windmills)
    ref = modulation_reference(turbine_of(farm), t, farm.radar.wavelength_m)
    assert np.max(np.abs(total - ref)) < 1e-9 * np.max(np.abs(ref))


def test_echo_centroid_is_the_scatterers_true_range():
    # One scatterer: |m_k| = sqrt(rcs)·w_k(D), so Σ k|m_k| / Σ|m_k| = D(t) =
    # 2(R − r·cos(ra)·sin β)/c·f_s, the closed form of its moving range.
    farm = farm_of(dict(name="a", range=1.5, num_blades=1, rpm=12, radius=[40.0], rsc=[2.0],
                        rotor_angle=30, start_angle=10, range_extended=True), 100)
    t = np.linspace(0, 5, 3001)
    mags = np.stack([np.abs(modulation(w, t, farm.radar.wavelength_m)) for w in farm.windmills])
    taps = np.array([w.range_cell.delay_samples for w in farm.windmills])
    beta = 2 * np.pi * 12 / 60 * t + np.deg2rad(10)
    expected = 2 * (1500 - 40 * np.cos(np.deg2rad(30)) * np.sin(beta)) / C * 100e6
    np.testing.assert_allclose(taps @ mags / mags.sum(axis=0), expected, atol=1e-9)
    np.testing.assert_allclose(mags.sum(axis=0), math.sqrt(2.0), rtol=1e-12)


def test_time_in_each_tap_follows_the_arcsine_law():
    # D = D0 − Dr·sin β with β uniform in time: tap k is lit while |D − k| < 1, a fraction
    # (arcsin(s₊) − arcsin(s₋))/π of a turn, s± = clip((D0 − k ± 1)/Dr).
    farm = farm_of(dict(name="a", range=2.0, num_blades=1, rpm=15, radius=[26.0], rsc=[1.0],
                        range_extended=True), 100)
    d0, dr = 2 * 2000 / C * 100e6, 2 * 26 / C * 100e6
    t = (np.arange(400_000) + 0.5) * (4.0 / 400_000)
    for w in farm.windmills:
        k = w.range_cell.delay_samples
        lit = np.mean(np.abs(modulation(w, t, farm.radar.wavelength_m)) > 0)
        s_hi, s_lo = (np.clip((d0 - k + s) / dr, -1, 1) for s in (1, -1))
        assert lit == pytest.approx((np.arcsin(s_hi) - np.arcsin(s_lo)) / np.pi, abs=2e-4), k


def test_fine_range_cells_hold_the_doppler_the_geometry_allows():
    """The model radar with one range cell per tap (pulse of half an RTS sample at 100 MS/s):
    a blade tip at ΔR has Doppler ±f_max·sqrt(1 − (ΔR/r)²), so tap k (|D − k| < 1) holds
    only Doppler between f_max·sqrt(1 − s_max²) and f_max·sqrt(1 − s_min²)."""
    farm = farm_of(dict(name="a", range=2.0, num_blades=1, rpm=15, radius=[26.0], rsc=[1.0],
                        range_extended=True), 100, pulse_width=0.005, prf=20000)
    t, bins, x = receive(farm, 4.0)          # one revolution: a line spectrum, no leakage
    assert [len(b.members) for b in bins] == [1] * len(farm.windmills)
    f_max = 2 * (2 * np.pi * 15 / 60) * 26 / farm.radar.wavelength_m
    d0, dr = 2 * 2000 / C * 100e6, 2 * 26 / C * 100e6
    f = np.fft.fftfreq(t.size, 1 / 20000)
    for b, row in zip(bins, x):
        k = farm.windmills[b.members[0]].range_cell.delay_samples
        lo, hi = (d0 - k - 1) / dr, (d0 - k + 1) / dr
        s_min = 0.0 if lo < 0 < hi else min(abs(lo), abs(hi))
        s_max = min(1.0, max(abs(lo), abs(hi)))
        f_hi, f_lo = f_max * math.sqrt(1 - s_min ** 2), f_max * math.sqrt(1 - s_max ** 2)
        p = np.abs(np.fft.fft(row)) ** 2
        # 30 Hz: the spectral width of the moving weight (a tap is crossed in ≳ 70 ms)
        band = (np.abs(f) <= f_hi + 30) & (np.abs(f) >= f_lo - 30)
        assert p[band].sum() / p.sum() > 0.99, (k, f_lo, f_hi)


def test_coarse_range_cell_sees_the_single_tap_replay():
    """At 20 MS/s with a 2 µs pulse one range cell holds every tap: the replayed taps
    (quantised words, FIR interpolation, gains) add up to the single-tap replay
    within the 16-bit quantisation floor (each stream ≈ −90 dB)."""
    turbine = dict(name="a", range=2.0, num_blades=3, rpm=15, radius=[26.0, 13.0], rsc=[1.0, 0.5],
                   tower_rcs=1.0)
    results = []
    for extended in (True, False):
        farm = farm_of(dict(turbine, range_extended=extended), pulse_width=2.0)
        streams = build_farm_streams(farm)
        t, bins, x = receive(farm, 1.0, streams)
        k = max(range(len(bins)), key=lambda i: len(bins[i].members))
        assert len(bins[k].members) == len(farm.windmills)
        # undo the common scale: a word of stream l is worth gain_l / 2**15 on the output,
        # gain_l = (K_l / scale_l) / max_l(K_l / scale_l)
        results.append(x[k] * max(s.relative_amplitude / s.scale for s in streams.streams) * 2 ** 15)
    extended, single = results
    error_db = 10 * np.log10(np.sum(np.abs(extended - single) ** 2) / np.sum(np.abs(single) ** 2))
    assert error_db < -75


def test_taps_are_channels_of_the_manifest_and_registers():
    farm = farm_of(dict(name="a", range=2.0, num_blades=3, rpm=15, radius=[26.0], rsc=[1.0],
                        range_extended=True))
    streams = build_farm_streams(farm)
    manifest = streams.manifest()
    chans = manifest["registers"]["channels"]
    assert [c["delay_samples"] for c in chans] == list(range(263, 272))
    assert [w["range_cell"]["tap"] for w in manifest["windmills"]] == list(range(9))
    contract = streams.smallest_contract()
    writes = dict(manifest_to_register_writes(manifest, contract))
    rmap = register_map(contract)
    assert writes[rmap.addr("COMMON_DELAY")] == 263 - contract.latency
    assert [writes[rmap.addr("DELAY", ch)] for ch in range(9)] == list(range(9))


def test_automatic_threshold_and_opt_out():
    big = dict(name="big", range=1.0, num_blades=3, rpm=12, radius=[60.0], rsc=[1.0])
    small = dict(name="small", range=3.0, num_blades=3, rpm=12, radius=[3.0], rsc=[1.0])
    # big sweeps 4·60/c·20e6 = 16.01 samples around 2·1000/c·20e6 = 133.43:
    # taps floor(125.42) … ceil(141.43), 18 of them; small sweeps 0.8 samples.
    farm = parse_config({"sample_rate": 20, "radar_frequency": 5350, "range_extend_above": 2,
                         "windmill": [big, small]})
    names = [w.name for w in farm.windmills]
    assert names == [f"big.t{j}" for j in range(18)] + ["small"]
    assert [w.range_cell.delay_samples for w in farm.windmills[:18]] == list(range(125, 143))
    assert farm.windmills[-1].range_cell is None
    farm = parse_config({"sample_rate": 20, "radar_frequency": 5350, "range_extend_above": 2,
                         "windmill": [dict(big, range_extended=False), small]})
    assert [w.name for w in farm.windmills] == ["big", "small"]


def test_bad_keys_and_name_clash():
    with pytest.raises(ConfigError, match="'range_extended' must be true or false"):
        farm_of(dict(name="a", range=2.0, num_blades=3, rpm=15, radius=[26.0], rsc=[1.0],
                     range_extended="yes"))
    with pytest.raises(ConfigError, match="'range_extend_above' must not be negative"):
        farm_of(dict(name="a", range=2.0, num_blades=3, rpm=15, radius=[26.0], rsc=[1.0]),
                range_extend_above=-1)
    with pytest.raises(ConfigError, match="windmill 'a.t0'.*delay tap"):
        parse_config({"sample_rate": 20, "radar_frequency": 5350, "windmill": [
            dict(name="a", range=2.0, num_blades=3, rpm=15, radius=[26.0], rsc=[1.0], range_extended=True),
            dict(name="a.t0", range=3.0, num_blades=3, rpm=15, radius=[26.0], rsc=[1.0])]})


def test_the_example_near_turbine():
    # 1.2 km at 20 MS/s: hub at 160.11 samples; 26 m at 30°: ±2·22.52/c·20e6 = ±3.004 samples
    from pathlib import Path
    from rast.model.physics.farm import load_config
    farm = load_config(Path(__file__).resolve().parents[1] / "examples" / "range_extended_near.toml")
    assert [w.range_cell.delay_samples for w in farm.windmills] == list(range(157, 165))
