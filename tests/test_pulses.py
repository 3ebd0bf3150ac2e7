"""The radar pulse generator (rast.model.radar.pulses): timing, chirp slope, noise, quantisation."""

import numpy as np
import pytest

from rast.model.contract import fixedpoint as fx
from rast.model.radar.pulses import TABLE_4_1, PulseConfig, generate, pulse_waveform, quantise_iq


def test_rect_pulse_timing_and_idle():
    cfg = PulseConfig(sample_rate_mhz=20, prf_hz=20_000, pulse_width_us=2.5, amplitude=0.5, n_pulses=3)
    tr = generate(cfg)
    assert cfg.samples_per_pri == 1000 and cfg.pulse_samples == 50
    assert tr.i.shape == (3, 1000)
    mag = np.hypot(tr.i, tr.q)
    on = mag > 0
    # every pulse is on for exactly the first 50 samples, then idle (exact zeros)
    assert on[:, :50].all() and not on[:, 50:].any()
    assert np.array_equal(tr.pulse_starts, [0, 1000, 2000])
    # amplitude 0.5 of full scale on a zero-offset rect pulse: I = 0.5·2^15, Q = 0
    assert np.all(tr.i[:, :50] == 1 << 14) and np.all(tr.q == 0)


def test_chirp_instantaneous_frequency_slope():
    cfg = PulseConfig(sample_rate_mhz=80, **{**TABLE_4_1, "bandwidth_mhz": 20}, amplitude=0.9)
    x = pulse_waveform(cfg)
    fs = cfg.sample_rate_mhz * 1e6
    f_inst = np.diff(np.unwrap(np.angle(x))) * fs / (2 * np.pi)
    t = (np.arange(f_inst.size) + 0.5) / fs
    slope, f0 = np.polyfit(t, f_inst, 1)
    assert slope == pytest.approx(20e6 / 10e-6, rel=1e-3)   # B/τ = 2 MHz/µs
    assert f0 == pytest.approx(-10e6, abs=20e3)            # starts at −B/2 ...
    assert f_inst[-1] == pytest.approx(10e6, abs=0.5e6)     # ... and ends at +B/2
    assert np.allclose(np.abs(x), 0.9)


def test_carrier_offset_rotates_phase():
    cfg = PulseConfig(sample_rate_mhz=10, prf_hz=10_000, pulse_width_us=100, carrier_offset_hz=125e3)
    x = pulse_waveform(cfg)
    step = np.angle(x[1:] / x[:-1])
    assert np.allclose(step, 2 * np.pi * 125e3 / 10e6)


def test_noise_seed_reproducible_and_distinct():
    kw = dict(sample_rate_mhz=20, prf_hz=20_000, pulse_width_us=10, noise_rms=0.01, n_pulses=4)
    a = generate(PulseConfig(seed=1, **kw))
    b = generate(PulseConfig(seed=1, **kw))
    c = generate(PulseConfig(seed=2, **kw))
    assert np.array_equal(a.i, b.i) and np.array_equal(a.q, b.q)
    assert not np.array_equal(a.i, c.i)
    # idle samples carry noise of the requested σ (in LSBs)
    idle = a.i[:, 300:].astype(float)
    assert idle.std() == pytest.approx(0.01 * 2 ** 15, rel=0.05)
    # noise differs from pulse to pulse
    assert not np.array_equal(a.i[0], a.i[1])


def test_quantisation_bounds_and_saturation():
    cfg = PulseConfig(sample_rate_mhz=20, prf_hz=20_000, pulse_width_us=10, amplitude=1.0,
                      noise_rms=0.5, seed=3, n_pulses=8, carrier_offset_hz=1e6)
    tr = generate(cfg)
    for v in (tr.i, tr.q):
        assert v.dtype == np.int64
        assert v.min() >= fx.INPUT.min and v.max() <= fx.INPUT.max
    assert (tr.i == fx.INPUT.max).any() and (tr.i == fx.INPUT.min).any()   # saturates, no wrap
    i, q = quantise_iq(np.array([1.0 + 0j, -1.0, 0.5 / 2 ** 15, -1.5 / 2 ** 15]))
    assert list(i) == [fx.INPUT.max, fx.INPUT.min, 1, -2]   # half away from zero


def test_words_pack_i_low():
    cfg = PulseConfig(sample_rate_mhz=1, prf_hz=1000, pulse_width_us=1, amplitude=0.25,
                      start_phase_deg=90)
    w = generate(cfg).words()
    i, q = fx.unpack_iq(w, fx.INPUT.width)
    assert i[0] == 0 and q[0] == 1 << 13


def test_active_window_is_prefix_of_full_train():
    kw = dict(sample_rate_mhz=20, prf_hz=20_000, pulse_width_us=10, noise_rms=0.02, seed=5,
              n_pulses=3, noise_in_pulse_only=True, shape="chirp", bandwidth_mhz=20)
    full = generate(PulseConfig(**kw))
    win = generate(PulseConfig(**kw), active_samples=300)
    assert np.array_equal(full.i[:, :300], win.i) and not full.i[:, 300:].any()
    with pytest.raises(ValueError, match=r"^active_samples drops idle samples"):
        generate(PulseConfig(**{**kw, "noise_in_pulse_only": False}), active_samples=300)


def test_for_seconds_counts_pulses():
    cfg = PulseConfig.for_seconds(1.0, sample_rate_mhz=20, **TABLE_4_1)
    assert cfg.n_pulses == 20_000 and cfg.total_samples == 20_000_000


@pytest.mark.parametrize("kw, msg", [
    (dict(prf_hz=-1), r"^prf_hz must be a positive number, not -1$"),
    (dict(prf_hz=30_000), r"^the PRI must be a whole number of RTS samples: 20 MHz / prf 30000 Hz = 666.667 "
                          r"samples \(prf 29985 Hz gives 667, 30030 Hz gives 666\)$"),
    (dict(shape="square"), r"^shape must be one of \('rect', 'chirp'\), not 'square'$"),
    (dict(amplitude=1.5), r"^amplitude must be a fraction of full scale in \[0, 1\], not 1.5$"),
    (dict(shape="chirp"), r"^a chirp needs bandwidth_mhz > 0$"),
    (dict(pulse_width_us=60), r"^pulse_width_us \(60\) must not exceed the PRI"),
    (dict(n_pulses=0), r"^n_pulses must be a positive integer, not 0$"),
    (dict(carrier_offset_hz=10e6), r"^carrier_offset_hz must be below half the sample rate"),
])
def test_config_validation(kw, msg):
    base = dict(sample_rate_mhz=20, prf_hz=20_000, pulse_width_us=10)
    with pytest.raises(ValueError, match=msg):
        PulseConfig(**{**base, **kw})
