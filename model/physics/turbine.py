"""Physics of one windmill: the complex modulation m(t) of seed section 2.5.

Geometry (seed eq. 2.21, 2.22): the blade direction is e_b = (−sin β, cos β),
β = 0 with the blade pointing up. The line of sight lies in the rotor plane
when ``rotor_angle`` = 0; a scatterer at radius r is ``ΔR = −r·cos(rotor_angle)·
sin β`` nearer than the hub (eq. 2.17) and its phase is ``φ = phase_start −
4π·ΔR/λ``. The sign differs from eq. 2.18 as printed: with it, eq. 2.10, the
wire integral eq. 2.20 and the measurements of section 4.2 agree (a blade
moving towards the radar has positive Doppler).

The rotation angle is ``β_b(t) = 2π·rpm·t/60 + start_angle + b·2π/num_blades``
(eq. 2.16 corrected: as printed it turns faster for lower rpm).
"""

from __future__ import annotations

import math

import numpy as np

from rast.model.physics.config import SPEED_OF_LIGHT_M_S, BladeFlash, WeightTable, Windmill

__all__ = ["blade_angles", "modulation", "modulation_reference", "max_doppler_hz", "point_weights",
           "shadow_factor", "wire_return", "CHUNK_SAMPLES", "evaluate_in_chunks", "range_cell_weight",
           "hub_delay_samples", "tap_modulation", "WIRE_SEGMENT_CELLS"]

#: Samples evaluated at a time: bounds the (scatterers × blades × samples) work array.
CHUNK_SAMPLES = 1 << 12


def blade_angles(windmill: Windmill, t_s: np.ndarray) -> np.ndarray:
    """β_b(t) in radians, shape (num_blades, len(t)) (eq. 2.16, corrected)."""
    omega = 2 * np.pi * windmill.rpm / 60.0
    offsets = np.deg2rad(windmill.start_angle_deg) + 2 * np.pi * np.arange(windmill.num_blades) / windmill.num_blades
    return omega * np.asarray(t_s, dtype=float)[None, :] + offsets[:, None]


def _wrap_pi(angle):
    return (angle + np.pi) % (2 * np.pi) - np.pi


def point_weights(weighting, beta: np.ndarray) -> np.ndarray | None:
    """w_k(β) of eq. 2.19 for every scatterer: shape (rows, *beta.shape), rows = 1 or num_rcs."""
    if weighting is None:
        return None
    if isinstance(weighting, BladeFlash):
        peak = 10 ** (weighting.gain_db / 20.0) - 1.0
        sigma = np.deg2rad(weighting.width_deg) / (2 * np.sqrt(2 * np.log(2)))
        bump = sum(np.exp(-0.5 * (_wrap_pi(beta - np.deg2rad(a)) / sigma) ** 2)
                   for a in weighting.angle_deg)
        return (1.0 + peak * bump)[None]
    if isinstance(weighting, WeightTable):
        table = weighting.weights
        columns = table.shape[1]
        x = (beta % (2 * np.pi)) * (columns / (2 * np.pi))
        j0 = np.floor(x).astype(np.int64) % columns
        frac = x - np.floor(x)
        return table[:, j0] * (1.0 - frac) + table[:, (j0 + 1) % columns] * frac
    raise TypeError(f"unknown weighting {weighting!r}")


def shadow_factor(windmill: Windmill, beta: np.ndarray) -> np.ndarray | None:
    """Amplitude factor of the tower's shadow on a blade at angle β (180° = blade down).

    A raised-cosine dip of ``shadow_width_deg`` whose centre attenuates the
    blade's RCS by ``shadow_depth_db`` (seed Fig. 4.6: the shaded area at
    negative Doppler, when a blade passes behind the mast).
    """
    tower = windmill.tower
    if tower is None or tower.shadow_width_deg <= 0:
        return None
    half = np.deg2rad(tower.shadow_width_deg) / 2
    offset = np.abs(_wrap_pi(beta - np.pi))
    depth = 1.0 - 10 ** (-tower.shadow_depth_db / 20.0)
    dip = np.where(offset < half, np.cos(np.pi / 2 * offset / half) ** 2, 0.0)
    return 1.0 - depth * dip


def wire_return(windmill: Windmill, beta: np.ndarray, wavelength_m: float) -> np.ndarray:
    """Closed form of eq. 2.20 for a wire from r_min to r_max, per blade angle.

    ∫ α·e^{i·q·r} dr over [r_min, r_max] with q = 4π/λ·cos(θ)·sin β gives
    α·L·e^{i·q·r_mid}·sinc(q·L/2): a sinc about the wire's mid-point; eq. 2.23
    is the case r_min = 0. θ = rotor_angle + wire_view_angle. The flash (q = 0)
    comes when the blade is perpendicular to the line of sight.
    """
    wire = windmill.wire
    length = wire.radius_max_m - wire.radius_min_m
    mid = 0.5 * (wire.radius_max_m + wire.radius_min_m)
    theta = np.deg2rad(windmill.rotor_angle_deg + wire.view_angle_deg)
    q = 4 * np.pi / wavelength_m * np.cos(theta) * np.sin(beta)
    # np.sinc(x) is sin(πx)/(πx)
    return (wire.reflectivity * length * np.sinc(q * length / (2 * np.pi)) *
            np.exp(1j * (np.deg2rad(wire.phase_offset_deg) + q * mid)))


def _unit_phasors(turns: np.ndarray):
    """cos and sin of 2π·turns, accurate to about 3e-7 (float32 after exact reduction).

    The phase in turns is reduced to [−½, ½] in float64 first, so the large
    phases of long blades (thousands of turns) lose nothing; the trigonometry
    then runs in float32, about ten times faster than in float64. The error
    (≲ 3e-7 of each scatterer's amplitude, below −110 dB) is far under the
    16-bit stream word's quantisation noise (−98 dB).
    """
    reduced = turns - np.rint(turns)
    angle = (reduced * (2 * np.pi)).astype(np.float32)
    return np.cos(angle), np.sin(angle)


def _unit_phasors_stacked(turns: np.ndarray) -> np.ndarray:
    """[cos; sin] of 2π·turns as one float32 array of shape (2, *turns.shape),
    the same values as :func:`_unit_phasors` with fewer temporaries."""
    reduced = np.rint(turns)
    np.subtract(turns, reduced, out=reduced)
    angle = np.multiply(reduced, 2 * np.pi, out=np.empty(turns.shape, np.float32), casting="same_kind")
    out = np.empty((2, *turns.shape), dtype=np.float32)
    np.cos(angle, out=out[0])
    np.sin(angle, out=out[1])
    return out


def _modulation_chunk(windmill: Windmill, t_s: np.ndarray, wavelength_m: float) -> np.ndarray:
    beta = blade_angles(windmill, t_s)                      # (B, n)
    total = np.zeros(t_s.shape, dtype=complex)
    shadow = shadow_factor(windmill, beta)
    if windmill.num_rcs:
        # eq. 2.17–2.19: sqrt(rcs)·w(β)·exp(i(phase_start + 4π·r·cos(ra)·sin β/λ)),
        # the phase written in turns: 2·r·cos(ra)·sin β/λ.
        k_turns = 2 / wavelength_m * np.cos(np.deg2rad(windmill.rotor_angle_deg))
        turns = (k_turns * windmill.radius_m)[:, None, None] * np.sin(beta)[None]   # (K, B, n)
        phasors = _unit_phasors_stacked(turns)                                      # (2, K, B, n)
        weights = point_weights(windmill.weighting, beta)
        if weights is not None and weights.shape[0] > 1:      # one weight row per scatterer
            phasors *= weights.astype(np.float32)[None]
        amplitude = np.sqrt(windmill.rcs_m2) * np.exp(1j * np.deg2rad(windmill.phase_start_deg))
        shape = phasors.shape[2:]
        # [re; im] = [[Re a, −Im a], [Im a, Re a]] · [cos; sin]: one product, in float64.
        mix = np.block([[amplitude.real, -amplitude.imag], [amplitude.imag, amplitude.real]])
        re, im = mix @ phasors.reshape(2 * len(amplitude), -1).astype(np.float64)
        per_blade = (re + 1j * im).reshape(shape)                                  # (B, n)
        if weights is not None and weights.shape[0] == 1:     # one row for all scatterers
            per_blade *= weights[0]
        if shadow is not None:
            per_blade *= shadow
        total += per_blade.sum(axis=0)
    if windmill.wire is not None:
        wires = wire_return(windmill, beta, wavelength_m)
        if shadow is not None:
            wires *= shadow
        total += wires.sum(axis=0)
    if windmill.tower is not None and windmill.tower.rcs_m2 > 0:
        total += np.sqrt(windmill.tower.rcs_m2) * np.exp(1j * np.deg2rad(windmill.tower.phase_deg))
    return total


def modulation(windmill: Windmill, t_s, wavelength_m: float) -> np.ndarray:
    """m(t) of eq. 2.15: the sum over blades and scatterers (plus wire and tower), complex128.
    A delay tap of a range-extended turbine (``range_cell`` set) gets its share of it
    (:func:`tap_modulation`)."""
    if windmill.range_cell is not None:
        return tap_modulation(windmill, t_s, wavelength_m)
    return evaluate_in_chunks(_modulation_chunk, windmill, t_s, wavelength_m)


def evaluate_in_chunks(chunk_fn, windmill: Windmill, t_s, wavelength_m: float) -> np.ndarray:
    """``chunk_fn(windmill, t, wavelength_m)`` over ``t_s`` of any shape, CHUNK_SAMPLES
    times at a time (bounded memory), as one complex128 array of ``t_s``'s shape."""
    t_s = np.asarray(t_s, dtype=float)
    out = np.empty(t_s.shape, dtype=complex)
    flat_t, flat_out = t_s.reshape(-1), out.reshape(-1)
    for start in range(0, flat_t.size, CHUNK_SAMPLES):
        stop = start + CHUNK_SAMPLES
        flat_out[start:stop] = chunk_fn(windmill, flat_t[start:stop], wavelength_m)
    return out


def max_doppler_hz(windmill: Windmill, wavelength_m: float) -> float:
    """Largest Doppler of the windmill: 2·ω·r·cos(angle)/λ over its scatterers and wire tip."""
    omega = 2 * np.pi * windmill.rpm / 60.0
    best = 0.0
    if windmill.num_rcs:
        best = 2 * omega * float(np.max(windmill.radius_m)) * abs(np.cos(np.deg2rad(windmill.rotor_angle_deg))) / wavelength_m
    if windmill.wire is not None:
        theta = np.deg2rad(windmill.rotor_angle_deg + windmill.wire.view_angle_deg)
        best = max(best, 2 * omega * windmill.wire.radius_max_m * abs(np.cos(theta)) / wavelength_m)
    return float(best)


def modulation_reference(windmill: Windmill, t_s, wavelength_m: float) -> np.ndarray:
    """eq. 2.15–2.19 written as read, one blade and one scatterer at a time, all float64.

    Slow and plain: the yardstick that :func:`modulation` is tested against
    (the benchmark's baseline is a fair loop of its own, at the same precision).
    """
    t_s = np.asarray(t_s, dtype=float)
    total = np.zeros(t_s.shape, dtype=complex)
    omega = 2 * np.pi * windmill.rpm / 60.0
    rotor = np.deg2rad(windmill.rotor_angle_deg)
    for b in range(windmill.num_blades):
        beta = omega * t_s + np.deg2rad(windmill.start_angle_deg) + b * 2 * np.pi / windmill.num_blades
        shadow = shadow_factor(windmill, beta)
        blade = np.zeros(t_s.shape, dtype=complex)
        for k in range(windmill.num_rcs):
            delta_r = -windmill.radius_m[k] * np.cos(rotor) * np.sin(beta)
            phi = np.deg2rad(windmill.phase_start_deg[k]) - 4 * np.pi * delta_r / wavelength_m
            weights = point_weights(windmill.weighting, beta)
            w = 1.0 if weights is None else weights[k if weights.shape[0] > 1 else 0]
            blade += np.sqrt(windmill.rcs_m2[k]) * w * np.exp(1j * phi)
        if windmill.wire is not None:
            blade += wire_return(windmill, beta[None], wavelength_m)[0]
        total += blade if shadow is None else blade * shadow
    if windmill.tower is not None and windmill.tower.rcs_m2 > 0:
        total += np.sqrt(windmill.tower.rcs_m2) * np.exp(1j * np.deg2rad(windmill.tower.phase_deg))
    return total


# ---------------------------------------------------------------------------
# A delay tap of a range-extended turbine (rast.model.physics.extended): the
# turbine's echo, each scatterer weighted by the share of its delay in the tap.

#: A wire blade is cut into segments no longer than this fraction of one RTS
#: sample of range; each segment keeps the exact closed form of eq. 2.20 and
#: takes the range-cell weight of its mid-point.
WIRE_SEGMENT_CELLS = 1 / 8


def range_cell_weight(delay_samples: np.ndarray, tap: int) -> np.ndarray:
    """w_k(D) = max(0, 1 − |D − k|): the share of tap k of an echo at delay D (RTS samples)."""
    return np.maximum(0.0, 1.0 - np.abs(np.asarray(delay_samples, dtype=float) - tap))


def hub_delay_samples(range_km: float, sample_rate_hz: float) -> float:
    """Round-trip delay of a range in RTS samples, not rounded: 2·R·f_s/c."""
    return 2 * range_km * 1e3 / SPEED_OF_LIGHT_M_S * sample_rate_hz


def _turns(x):
    """exp(2πi·x) with the whole turns removed first (long blades: thousands of turns)."""
    return np.exp(2j * np.pi * (x - np.rint(x)))


def _tap_chunk(windmill: Windmill, t_s: np.ndarray, wavelength_m: float) -> np.ndarray:
    cell = windmill.range_cell
    per_m = 2 * cell.sample_rate_hz / SPEED_OF_LIGHT_M_S        # delay samples per metre of ΔR
    hub = hub_delay_samples(cell.hub_range_km, cell.sample_rate_hz)
    beta = blade_angles(windmill, t_s)                          # (B, n)
    sin_beta = np.sin(beta)
    shadow = shadow_factor(windmill, beta)
    blades = np.zeros(beta.shape, dtype=complex)
    if windmill.num_rcs:
        # eq. 2.17-2.19 per scatterer: ΔR = −r·cos(ra)·sin β, phase −4π·ΔR/λ.
        projected = windmill.radius_m * math.cos(math.radians(windmill.rotor_angle_deg))
        delta_r = -projected[:, None, None] * sin_beta
        amplitude = np.sqrt(windmill.rcs_m2) * np.exp(1j * np.deg2rad(windmill.phase_start_deg))
        echo = amplitude[:, None, None] * _turns(-2 * delta_r / wavelength_m)         # (K, B, n)
        weights = point_weights(windmill.weighting, beta)
        if weights is not None:
            echo = echo * weights
        blades += (echo * range_cell_weight(hub + per_m * delta_r, cell.delay_samples)).sum(axis=0)
    if windmill.wire is not None:
        # eq. 2.20 over each segment [a, b]: α·(b−a)·e^{i(φ0 + q·mid)}·sinc(q·(b−a)/2), exact;
        # the segments' sum is the whole wire's closed form.
        wire = windmill.wire
        cos_theta = math.cos(math.radians(windmill.rotor_angle_deg + wire.view_angle_deg))
        length = wire.radius_max_m - wire.radius_min_m
        cell_m = SPEED_OF_LIGHT_M_S / (2 * cell.sample_rate_hz)
        segments = max(1, math.ceil(length * abs(cos_theta) / (WIRE_SEGMENT_CELLS * cell_m)))
        seg = length / segments
        mids = wire.radius_min_m + seg * (np.arange(segments) + 0.5)
        q = 4 * np.pi / wavelength_m * cos_theta * sin_beta                             # (B, n)
        returns = (wire.reflectivity * seg * np.sinc(q * seg / (2 * np.pi)) *
                   np.exp(1j * np.deg2rad(wire.phase_offset_deg)) *
                   _turns(mids[:, None, None] * q / (2 * np.pi)))                       # (S, B, n)
        delta_r = -mids[:, None, None] * cos_theta * sin_beta
        blades += (returns * range_cell_weight(hub + per_m * delta_r, cell.delay_samples)).sum(axis=0)
    if shadow is not None:
        blades *= shadow
    total = blades.sum(axis=0)
    if windmill.tower is not None and windmill.tower.rcs_m2 > 0:
        total += (np.sqrt(windmill.tower.rcs_m2) * np.exp(1j * np.deg2rad(windmill.tower.phase_deg)) *
                  range_cell_weight(hub, cell.delay_samples))
    return total


def tap_modulation(windmill: Windmill, t_s, wavelength_m: float) -> np.ndarray:
    """m_k(t) of the tap ``windmill.range_cell``: the turbine's echo, every scatterer (and
    wire segment, and the tower at the hub) weighted by its range-cell weight; complex128.
    The taps of one turbine sum to :func:`modulation` of the turbine
    (``rast.model.physics.extended`` splits a turbine into its taps)."""
    if windmill.range_cell is None:
        raise ValueError(f"windmill {windmill.name!r} is not a delay tap")
    return evaluate_in_chunks(_tap_chunk, windmill, t_s, wavelength_m)
