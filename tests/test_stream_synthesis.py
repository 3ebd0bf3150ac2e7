"""Fast stream synthesis (rast.model.physics.synthesis): its error against the float64
per-scatterer reference, its fallback, and the writers it made faster.

The error measure is the streams' promise: RMS of (period − reference) over
RMS of the reference, ≤ −100 dBc (a 16-bit word's quantisation floor is
about −98 dBc), with the reference ``modulation_reference`` (eq. 2.15–2.19
as read, float64) at the same instants t_n = n·T_sim/N.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from rast.model.contract import fixedpoint as fx
from rast.model.physics.farm import load_config, parse_config
from rast.model.files.ramfiles import read_hex, write_hex
from rast.model.physics.stream import _fir_peak, build_farm_streams, plan_stream, quantise, quantise_words
from rast.model.physics.synthesis import (CHECK_LIMIT_DBC, TAPS, ComputePool, lagrange_weights,
                                          synthesise_period)
from rast.model.physics.turbine import max_doppler_hz, modulation, modulation_reference

EXAMPLES = sorted((Path(__file__).parent.parent / "examples").glob("*.toml"))
LIMIT_DBC = -100.0


def error_dbc(period, windmill, length, wavelength_m, samples=None, seed=0):
    """RMS error of ``period`` against the reference, dBc; at ``samples`` random
    instants (all of them when None)."""
    n = (np.arange(length) if samples is None or samples >= length else
         np.random.default_rng(seed).integers(0, length, samples))
    t = n * (windmill.period_s / length)
    if windmill.range_cell is None:
        reference = modulation_reference(windmill, t, wavelength_m)
    else:       # one delay tap of a range-extended turbine: its share, evaluated directly
        from rast.model.physics.turbine import tap_modulation
        reference = tap_modulation(windmill, t, wavelength_m)
    with np.errstate(divide="ignore"):           # a wire alone is exact: −inf dBc
        return 10 * np.log10(np.mean(np.abs(period[n] - reference) ** 2) / np.mean(np.abs(reference) ** 2))


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_every_example_is_within_minus_100_dbc_of_the_reference(path):
    """Every stream made for its own windmill; a windmill that plays another's
    stream (share_streams: another start angle or aspect) is judged by the
    sharing's own checks (tests/test_stream_sharing.py), not by this one."""
    farm = load_config(path)
    streams = build_farm_streams(farm, check_ram_depth=False)
    own = [s for s in streams.streams if s.share is None or s.share.stream == s.windmill.name]
    assert own
    for s in own:
        assert error_dbc(s.period, s.windmill, s.plan.length, farm.radar.wavelength_m) <= LIMIT_DBC


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_every_example_oversampled_takes_the_grid_and_stays_within_minus_100_dbc(path):
    # The examples at a forced rate of 2000 × their max Doppler (a few M words
    # each): the grid path, checked at 20 000 random instants.
    farm = load_config(path)
    lam = farm.radar.wavelength_m
    # (the scenes of hundreds and thousands, the air-traffic and the
    # beam-following examples: every k-th windmill, at most 128, across all
    # their farms and turbine models; each is synthesised as any other)
    step = -(-len(farm.windmills) // 128)
    windmills = [dataclasses.replace(w, stream_rate=2000 * max_doppler_hz(w, lam)) for w in farm.windmills[::step]]
    farm = dataclasses.replace(farm, windmills=windmills, interpolation="hold", ram_depth=None)
    for w in farm.windmills:
        length = plan_stream(w, farm).length
        period, synthesis = synthesise_period(w, length, lam)
        assert synthesis.method == "grid", synthesis.reason
        assert synthesis.check_error_dbc <= CHECK_LIMIT_DBC
        assert error_dbc(period, w, length, lam, samples=20000) <= LIMIT_DBC


def stress_windmill(sample_rate_mhz, weighting):
    rng = np.random.default_rng(7)
    return parse_config({
        "sample_rate": sample_rate_mhz, "radar_frequency": 5350, "interpolation": "hold",
        "windmill": [{
            "name": "stress", "range": 2.0, "num_blades": 3, "rpm": 15, "num_rcs": 15,
            "radius": list(np.linspace(4.0, 50.0, 15)), "rsc": list(rng.uniform(0.2, 1.5, 15)),
            "phase_start": list(rng.uniform(0, 360, 15)), "rsc_weighting": weighting,
            "wire_enable": True, "wire_radius_min": 3.0, "wire_radius_max": 50.0,
            "wire_reflectivity": 0.05, "tower_rcs": 20.0, "tower_shadow_width": 12,
            "tower_shadow_depth": 30, "stream_rate": "rts"}]})


def test_flash_heavy_stress_case_in_seed_mode_is_within_minus_100_dbc():
    # Four 1°-wide 20 dB flashes per revolution on every scatterer, the wire's
    # flashes and a deep, narrow tower shadow, one word per RTS sample.
    farm = stress_windmill(5, {"angle": [0, 90, 180, 270], "width": 1, "gain_db": 20})
    w = farm.windmills[0]
    length = plan_stream(w, farm).length
    assert length == round(w.period_s * 5e6)
    period, synthesis = synthesise_period(w, length, farm.radar.wavelength_m)
    assert synthesis.method == "grid", synthesis.reason
    # the flashes themselves, not only random instants: every sample within ±1° of blade 0 at 0°
    flash = np.arange(-length // 360, length // 360) % length
    reference = modulation_reference(w, flash * (w.period_s / length), farm.radar.wavelength_m)
    in_flash = 10 * np.log10(np.mean(np.abs(period[flash] - reference) ** 2) / np.mean(np.abs(reference) ** 2))
    assert in_flash <= LIMIT_DBC
    assert error_dbc(period, w, length, farm.radar.wavelength_m, samples=20000) <= LIMIT_DBC


def test_a_sharp_flash_table_falls_back_to_direct_evaluation():
    # 720 columns (every 0.5°) alternating 1 and 30: slope jumps of ±58 per
    # degree at every column, far outside the band; the midpoint check sees it.
    row = [1.0, 30.0] * 360
    farm = stress_windmill(5, [row])
    w = farm.windmills[0]
    length = plan_stream(w, farm).length
    period, synthesis = synthesise_period(w, length, farm.radar.wavelength_m)
    assert synthesis.method == "direct"
    assert synthesis.check_error_dbc is not None and synthesis.check_error_dbc > CHECK_LIMIT_DBC
    assert "band assumption fails" in synthesis.reason
    n = np.arange(0, length, 997)
    # the same float64 sums, evaluated in other chunks (their length follows the core count):
    # equal to the last bits of float64, not bit for bit
    reference = modulation(w, n * (w.period_s / length), farm.radar.wavelength_m)
    np.testing.assert_allclose(period[n], reference, rtol=0, atol=1e-12 * np.abs(reference).max())
    assert error_dbc(period, w, length, farm.radar.wavelength_m, samples=20000) <= LIMIT_DBC


def test_a_feature_narrower_than_the_grid_falls_back_without_trying():
    farm = stress_windmill(5, {"angle": [0], "width": 0.0005, "gain_db": 20})
    w = farm.windmills[0]
    period, synthesis = synthesise_period(w, plan_stream(w, farm).length, farm.radar.wavelength_m)
    assert synthesis.method == "direct" and synthesis.check_error_dbc is None
    assert "too narrow" in synthesis.reason


def test_automatic_rate_streams_are_evaluated_directly():
    farm = load_config(EXAMPLES[0])
    for s in build_farm_streams(farm, check_ram_depth=False).streams:
        assert s.synthesis.method == "direct" and "nothing to interpolate" in s.synthesis.reason
        np.testing.assert_array_equal(
            s.period, modulation(s.windmill, np.arange(s.plan.length) * (s.windmill.period_s / s.plan.length),
                                 farm.radar.wavelength_m))


def test_lagrange_weights_reproduce_polynomials_up_to_degree_seven():
    x = np.linspace(0, 1, 17)
    nodes = np.arange(TAPS) - (TAPS // 2 - 1)
    weights = lagrange_weights(x)
    for degree in range(TAPS):
        assert np.max(np.abs(nodes ** degree @ weights - x ** degree)) < 1e-9
    assert np.max(np.abs(nodes ** TAPS @ weights - x ** TAPS)) > 1.0   # and not beyond


def test_words_are_a_deterministic_function_of_the_config():
    farm = dataclasses.replace(load_config(EXAMPLES[-1]), interpolation="hold")
    farm = dataclasses.replace(farm, windmills=[dataclasses.replace(w, stream_rate=4e6) for w in farm.windmills])
    a = build_farm_streams(farm, check_ram_depth=False)
    b = build_farm_streams(farm, check_ram_depth=False)
    assert all(s.synthesis.method == "grid" for s in a.streams)
    for x, y in zip(a.streams, b.streams):
        np.testing.assert_array_equal(x.words, y.words)


def test_write_hex_writes_what_readmemh_reads(tmp_path):
    rng = np.random.default_rng(1)
    words = np.concatenate([[0, 1, 0xFFFFFFFF, 0x80000000, 0xDEADBEEF],
                            rng.integers(0, 1 << 32, (1 << 20) + 3)]).astype(np.int64)
    write_hex(words, tmp_path / "a.hex")
    text = (tmp_path / "a.hex").read_text(encoding="ascii")
    assert text[:45] == "00000000\n00000001\nffffffff\n80000000\ndeadbeef\n"
    assert len(text) == 9 * words.size
    np.testing.assert_array_equal(read_hex(tmp_path / "a.hex"), words)
    write_hex(words.astype(np.uint32), tmp_path / "b.hex")
    assert (tmp_path / "b.hex").read_text(encoding="ascii") == text
    with pytest.raises(ValueError):
        write_hex([1 << 32], tmp_path / "c.hex")


def test_the_pruned_fir_peak_matches_the_full_fir_where_it_matters():
    c = np.array(fx.fir_coefficients(), dtype=np.int64)
    rng = np.random.default_rng(5)
    for trial in range(20):
        L = int(rng.integers(16, 3000))
        i = rng.integers(-32768, 32768, L)
        q = np.round(rng.uniform(-1, 1, L) * rng.uniform(0.1, 1) * 32767).astype(np.int64)
        taps = (np.arange(L)[:, None] + fx.FIR_LEAD - np.arange(fx.FIR_TAPS)[None, :]) % L
        full = float(np.abs(fx.round_half_up(np.stack([i, q])[:, taps] @ c.T, fx.FIR_COEF_FRAC)).max())
        for limit in (fx.STREAM.max, 20000, 1000):
            pruned = _fir_peak(i, q, limit)
            assert pruned == full if full > limit else pruned <= limit


def plain_quantise(period, interpolation):
    """The quantiser as first written: whole arrays, scale to the peak, round half to
    even, and for the FIR rescale until its overshoot fits (rast.model.physics.stream._fir_peak)."""
    peak = max(np.abs(period.real).max(), np.abs(period.imag).max())
    scale = fx.STREAM.max / peak
    while True:
        i = np.clip(np.round(period.real * scale), fx.STREAM.min, fx.STREAM.max).astype(np.int64)
        q = np.clip(np.round(period.imag * scale), fx.STREAM.min, fx.STREAM.max).astype(np.int64)
        if interpolation != "fir":
            break
        over = _fir_peak(i, q, fx.STREAM.max)
        if over <= fx.STREAM.max:
            break
        scale *= (fx.STREAM.max - 1) / over
    x = np.concatenate([period.real, period.imag]) * scale
    snr = 10 * np.log10(np.sum(x ** 2) / np.sum((x - np.concatenate([i, q])) ** 2))
    return i, q, scale, snr


@pytest.mark.parametrize("interpolation", ["hold", "fir"])
def test_quantised_words_in_blocks_on_every_core_are_the_plain_quantisers(interpolation, monkeypatch):
    from rast.model.physics import stream
    monkeypatch.setattr(stream, "_QUANTISE_BLOCK", 3001)
    farm = load_config(EXAMPLES[-1])
    for w in farm.windmills:
        length = plan_stream(w, farm).length
        period = modulation(w, np.arange(length) * (w.period_s / length), farm.radar.wavelength_m)
        i, q, scale, snr = plain_quantise(period, interpolation)
        for workers in (1, 2, 3):
            with ComputePool(workers) as pool:
                words, got_scale, got_snr = quantise_words(period, interpolation=interpolation, pool=pool)
            np.testing.assert_array_equal(words.astype(np.int64), fx.pack_iq(i, q))
            assert got_scale == scale
            assert got_snr == pytest.approx(snr, rel=1e-9)
        got = quantise(period, interpolation=interpolation)
        np.testing.assert_array_equal(got[0], i)
        np.testing.assert_array_equal(got[1], q)
        assert got[0].dtype == np.int64 and got[2] == scale


def test_the_period_is_the_same_on_any_number_of_cores_and_in_any_block_size(monkeypatch):
    # Grid and direct paths: pieces on 1, 2 or 3 threads, and small blocks, give the
    # same values bit for bit (BLAS is held to one thread, blocks are whole 64 rows).
    from rast.model.physics import synthesis
    farm = stress_windmill(5, {"angle": [0, 180], "width": 4, "gain_db": 10})
    w = farm.windmills[0]
    lam = farm.radar.wavelength_m
    for length in (plan_stream(w, farm).length // 2, 50_000):          # grid, then direct
        with ComputePool(1) as pool:
            first, how = synthesise_period(w, length, lam, pool=pool)
        assert how.method == ("grid" if length > 50_000 else "direct")
        for workers in (2, 3):
            with ComputePool(workers) as pool:
                np.testing.assert_array_equal(synthesise_period(w, length, lam, pool=pool)[0], first)
        monkeypatch.setattr(synthesis, "SAMPLES_PER_BLOCK", 7777)
        np.testing.assert_array_equal(synthesise_period(w, length, lam)[0], first)
        monkeypatch.undo()


def test_emitted_pieces_cover_the_period_in_order():
    farm = stress_windmill(5, {"angle": [0, 180], "width": 4, "gain_db": 10})
    w = farm.windmills[0]
    length = plan_stream(w, farm).length // 2
    pieces = []
    period, how = synthesise_period(w, length, farm.radar.wavelength_m,
                                    emit=lambda start, values: pieces.append((start, values.copy())))
    assert how.method == "grid" and len(pieces) > 1
    assert [start for start, _ in pieces] == list(np.cumsum([0] + [len(v) for _, v in pieces[:-1]]))
    np.testing.assert_array_equal(np.concatenate([v for _, v in pieces]), period)
