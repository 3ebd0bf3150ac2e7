"""Physics against closed forms (seed eq. 2.10, 2.13–2.25)."""

import numpy as np
import pytest

from rast.model.physics.config import SPEED_OF_LIGHT_M_S
from rast.model.physics.farm import parse_config
from rast.model.radar.receiver import receive, spectrogram
from rast.model.physics.stream import build_farm_streams, delay_samples
from rast.model.physics.turbine import blade_angles, max_doppler_hz, modulation, wire_return

C_BAND_MHZ = 5350.0
WAVELENGTH = SPEED_OF_LIGHT_M_S / (C_BAND_MHZ * 1e6)


def farm_of(*windmills, **top):
    data = {"sample_rate": 20, "radar_frequency": C_BAND_MHZ, **top,
            "windmill": [{"name": f"w{i}", "range": 2.0, "num_blades": 1, **w}
                         for i, w in enumerate(windmills)]}
    return parse_config(data)


def peak_doppler_hz(farm, seconds=4.0):
    _, _, samples = receive(farm, seconds)
    spec = spectrogram(samples[0], farm.radar.prf_hz, farm.radar.cpi_ms * 1e-3)
    frequencies = spec.doppler_hz[np.argmax(spec.power_db, axis=1)]
    return frequencies, spec


@pytest.mark.parametrize("rpm, radius, rotor_angle", [(15, 26.0, 0.0), (25, 20.0, 0.0), (12, 40.0, 35.0)])
def test_single_scatterer_peak_doppler_matches_closed_form(rpm, radius, rotor_angle):
    # The first CPI (centre 50 ms) is centred on the blade pointing up (β = 0),
    # where the Doppler peaks: start_angle puts it there.
    start = -360 * rpm / 60 * 0.05
    farm = farm_of({"rpm": rpm, "radius": [radius], "rsc": [1.0], "rotor_angle": rotor_angle,
                    "start_angle": start})
    expected = 2 * (2 * np.pi * rpm / 60) * radius * np.cos(np.deg2rad(rotor_angle)) / WAVELENGTH
    frequencies, spec = peak_doppler_hz(farm, seconds=60 / rpm)
    assert abs(frequencies.max() - expected) <= spec.resolution_hz
    assert abs(frequencies.min() + expected) <= spec.resolution_hz
    assert max_doppler_hz(farm.windmills[0], WAVELENGTH) == pytest.approx(expected)


def test_seed_figure_15_rpm_26_m_peaks_near_1460_hz():
    # Seed section 4.3.3: 15 rpm at 5.35 GHz gives 1460 Hz maximum Doppler.
    farm = farm_of({"rpm": 15, "radius": [26.0], "rsc": [1.0]})
    assert abs(max_doppler_hz(farm.windmills[0], WAVELENGTH) - 1460) < 5


def test_approaching_blade_has_positive_doppler():
    # At β = 0 the blade points up and moves towards the radar (ΔR decreasing):
    # eq. 2.10 says its Doppler is positive.
    farm = farm_of({"rpm": 15, "radius": [26.0], "rsc": [1.0]})
    w = farm.windmills[0]
    dt = 1e-5
    t = np.array([-dt, dt])
    delta_r = -26.0 * np.sin(blade_angles(w, t)[0])
    assert delta_r[1] < delta_r[0], "the blade at β≈0 must be approaching"
    m = modulation(w, t, WAVELENGTH)
    doppler = np.angle(m[1] * np.conj(m[0])) / (2 * np.pi * 2 * dt)
    assert doppler > 1400
    frequencies, _ = peak_doppler_hz(farm, seconds=0.3)
    assert frequencies[0] > 1000, "first CPI (β near 0) must show positive Doppler"


def test_rotation_period_follows_rpm_not_its_inverse():
    # eq. 2.16 as printed would turn a 15 rpm rotor at 4 rev/s; the corrected one turns it at 0.25 rev/s.
    farm = farm_of({"rpm": 15, "radius": [26.0], "rsc": [1.0]})
    beta = blade_angles(farm.windmills[0], np.array([0.0, 4.0]))
    assert beta[0, 1] - beta[0, 0] == pytest.approx(2 * np.pi)


def test_wire_closed_form_matches_numerical_integration_of_eq_2_20():
    farm = farm_of({"rpm": 12, "num_rcs": 0, "wire_enable": True, "wire_radius_min": 5.0,
                    "wire_radius_max": 40.0, "wire_reflectivity": 0.3, "wire_phase_offset": 30.0,
                    "rotor_angle": 20.0, "wire_view_angle": 10.0})
    w = farm.windmills[0]
    beta = np.linspace(-0.2, 0.2, 41)[None, :]
    closed = wire_return(w, beta, WAVELENGTH)[0]
    r = np.linspace(5.0, 40.0, 400_001)
    k0_dot_eb = -(2 * np.pi / WAVELENGTH) * np.cos(np.deg2rad(30.0)) * np.sin(beta[0])
    integrand = 0.3 * np.exp(-2j * k0_dot_eb[:, None] * r[None, :])
    numeric = np.exp(1j * np.deg2rad(30.0)) * np.trapezoid(integrand, r, axis=1)
    np.testing.assert_allclose(closed, numeric, rtol=0, atol=1e-6 * np.abs(numeric).max())


def test_wire_flash_when_blade_perpendicular_to_line_of_sight():
    farm = farm_of({"rpm": 12, "num_rcs": 0, "wire_enable": True, "wire_radius_max": 40.0,
                    "wire_reflectivity": 0.05})
    w = farm.windmills[0]
    beta = np.linspace(0, 2 * np.pi, 3600, endpoint=False)[None, :]
    amplitude = np.abs(wire_return(w, beta, WAVELENGTH)[0])
    # The flash (α·L) is at β = 0 (up) and β = π (down), and far above the rest.
    assert amplitude[0] == pytest.approx(0.05 * 40.0)
    assert amplitude[1800] == pytest.approx(0.05 * 40.0)
    assert np.median(amplitude) < 0.01 * amplitude.max()


def test_tower_adds_a_zero_doppler_line():
    farm = farm_of({"rpm": 15, "radius": [26.0], "rsc": [1.0], "tower_rcs": 100.0})
    frequencies, spec = peak_doppler_hz(farm, seconds=1.0)
    assert np.all(np.abs(frequencies) <= spec.resolution_hz / 2)


def test_tower_shadow_dims_the_blade_pointing_down():
    base = {"rpm": 15, "radius": [26.0], "rsc": [1.0]}
    plain = farm_of(base).windmills[0]
    shadowed = farm_of({**base, "tower_shadow_width": 30, "tower_shadow_depth": 20}).windmills[0]
    t_down, t_up = 2.0, 0.0   # β = π and β = 0 at 15 rpm
    t = np.array([t_up, t_down])
    ratio = np.abs(modulation(shadowed, t, WAVELENGTH)) / np.abs(modulation(plain, t, WAVELENGTH))
    assert ratio[0] == pytest.approx(1.0)
    assert 20 * np.log10(ratio[1]) == pytest.approx(-20.0)


def test_parametric_flash_gain_at_its_angle():
    farm = farm_of({"rpm": 12, "radius": [40.0], "rsc": [4.0],
                    "rsc_weighting": {"angle": 90, "width": 10, "gain_db": 20}})
    w = farm.windmills[0]
    t_at_90 = 90 / 360 * 5.0
    m = modulation(w, np.array([t_at_90, 0.0]), WAVELENGTH)
    assert np.abs(m) == pytest.approx([2.0 * 10.0, 2.0], rel=1e-6)


def test_weight_table_interpolates_periodically():
    farm = farm_of({"rpm": 12, "num_rcs": 2, "radius": [40.0, 10.0], "rsc": [1.0, 1.0],
                    "rsc_weighting": [[1, 3, 5, 7], [2, 2, 2, 2]]})
    w = farm.windmills[0]
    from rast.model.physics.turbine import point_weights
    beta = np.deg2rad(np.array([[0.0, 45.0, 315.0, 360.0]]))
    weights = point_weights(w.weighting, beta)
    np.testing.assert_allclose(weights[0, 0], [1, 2, 4, 1])   # 315° lies between 7 (270°) and 1 (360°)
    np.testing.assert_allclose(weights[1, 0], [2, 2, 2, 2])


def test_blades_are_spread_evenly():
    farm = farm_of({"rpm": 10, "num_blades": 3, "radius": [30.0], "rsc": [1.0]})
    beta = blade_angles(farm.windmills[0], np.array([0.0]))
    np.testing.assert_allclose(np.diff(beta[:, 0]), 2 * np.pi / 3)


def test_three_blade_modulation_repeats_every_t_sim():
    farm = farm_of({"rpm": 12, "num_blades": 3, "num_rcs": 2, "radius": [40.0, 20.0],
                    "rsc": [1.0, 0.5], "phase_start": [10, 70]})
    w = farm.windmills[0]
    t = np.linspace(0, 1, 101)
    np.testing.assert_allclose(modulation(w, t + w.period_s, WAVELENGTH), modulation(w, t, WAVELENGTH),
                               atol=1e-9)


def test_farm_delays_and_amplitudes_follow_eq_2_24():
    farm = farm_of({"rpm": 15, "radius": [26.0], "rsc": [1.0], "range": 4.0},
                   {"rpm": 20, "radius": [20.0], "rsc": [1.0], "range": 2.0},
                   {"rpm": 25, "radius": [20.0], "rsc": [1.0], "range": 2.0},
                   {"rpm": 30, "radius": [20.0], "rsc": [1.0], "range": 3.0})
    fs = build_farm_streams(farm)
    assert [s.windmill.range_km for s in fs.streams] == [2.0, 2.0, 3.0, 4.0]
    f_s = 20e6
    for s in fs.streams:
        assert s.delay_samples == round(2 * s.windmill.range_km * 1e3 / SPEED_OF_LIGHT_M_S * f_s)
        assert s.relative_amplitude == pytest.approx((2.0 / s.windmill.range_km) ** 2)
    assert delay_samples(2.0, f_s) == 267
    # equal ranges share a tap
    taps = fs.taps
    assert [t["delay_samples"] for t in taps] == [267, 400, 534]
    assert taps[0]["windmills"] == ["w1", "w2"]
    assert [s.tap for s in fs.streams] == [0, 0, 1, 2]
    channels = fs.manifest()["registers"]["channels"]
    assert [c["delay_samples"] for c in channels] == [267, 267, 400, 534]


def test_fast_modulation_agrees_with_the_plain_reference():
    # The fast path does its trigonometry in float32 after exact range reduction;
    # it must stay within 1e-6 of the summed amplitudes of the float64 reference.
    rng = np.random.default_rng(7)
    farm = farm_of({"rpm": 13, "num_blades": 3, "num_rcs": 15, "rotor_angle": 25,
                    "radius": list(np.linspace(3, 55, 15)), "rsc": list(rng.uniform(0.1, 2, 15)),
                    "phase_start": list(rng.uniform(0, 360, 15)),
                    "rsc_weighting": {"angle": [0, 180], "width": 7, "gain_db": 9},
                    "wire_enable": True, "wire_radius_min": 2.0, "wire_radius_max": 55.0,
                    "wire_reflectivity": 0.03, "tower_rcs": 10.0, "tower_shadow_width": 30})
    w = farm.windmills[0]
    from rast.model.physics.turbine import modulation_reference
    t = rng.uniform(0, 10, 20_000)
    fast, plain = modulation(w, t, WAVELENGTH), modulation_reference(w, t, WAVELENGTH)
    budget = 1e-6 * (3 * np.sqrt(w.rcs_m2).sum() * 10 ** (9 / 20))
    assert np.max(np.abs(fast - plain)) < budget
    # ... and the comparison is sharp: time reversed (the rotor turning the other way) fails it.
    mirrored = modulation_reference(w, -t, WAVELENGTH)
    assert np.max(np.abs(fast - mirrored)) > 1000 * budget
