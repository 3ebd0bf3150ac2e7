"""Range-extended turbines: one turbine split over adjacent delay taps (seed chapter 5, outlook 1).

A scatterer at radius r is ``ΔR = −r·cos(rotor_angle)·sin β`` further than the
hub (the ΔR of ``rast.model.turbine``), so its round-trip delay in RTS samples
is ``D(t) = 2·(R_hub + ΔR(t))·f_s/c``: for a 60 m blade at 20 MS/s it sweeps
±8 samples. The RTS can only delay by whole samples, so a turbine whose blades
sweep more than a sample is given one channel per delay tap k, and each
scatterer's contribution goes to the taps around its delay with the
*triangular range-cell weight*

    w_k(D) = max(0, 1 − |D − k|)

(linear interpolation between the two adjacent samples). This weight

* sums to one over the taps for every D (a partition of unity), so the taps
  add up to the turbine's echo exactly: at a coarse range resolution, where
  one range cell holds every tap, the radar sees the single-tap echo;
* keeps the first moment: ``Σ_k k·w_k(D) = D``, so the echo's range centroid
  is the scatterer's true, time-varying range, not a rounded one;
* is never negative and touches at most two taps at a time, so a turbine
  needs ``ceil(D_max) − floor(D_min) + 1`` channels and no tap carries a
  large cancelling component (a band-limited, sinc-like kernel would ring
  over many more taps with negative weights, costing channels and stream
  headroom for an accuracy the radar's range cell cannot resolve: a pulse of
  bandwidth B ≪ f_s changes little over one sample of delay).

The price: a point scatterer between two taps is seen as the pulse plus its
copy one sample later, a smear of at most one RTS sample in range.

The weights move slowly: ``dD/dt = f_D·f_s/f_radar`` samples per second, about
270 times slower than the phase at 20 MS/s and 5.35 GHz, so a tap's stream has
the turbine's Doppler band (its stream plan is the turbine's).

Every tap is an ordinary windmill of the farm (a copy of the turbine named
``<name>.t<j>``, its ``range_km`` the tap's delay, its ``range_cell`` saying
which tap it is), so streams, manifest, register writes and the model radar
carry the taps without special cases; :func:`rast.model.turbine.modulation`
hands a tap to :func:`tap_modulation`.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .config import SPEED_OF_LIGHT_M_S, ConfigError, Farm, RangeCell, Windmill

__all__ = ["range_cell_weight", "blade_reach_m", "delay_sweep_samples", "tap_delays",
           "split_windmill", "extend_farm", "tap_modulation", "WIRE_SEGMENT_CELLS"]

#: A wire blade is cut into segments no longer than this fraction of one RTS
#: sample of range; each segment keeps the exact closed form of eq. 2.20 and
#: takes the range-cell weight of its mid-point.
WIRE_SEGMENT_CELLS = 1 / 8


def range_cell_weight(delay_samples: np.ndarray, tap: int) -> np.ndarray:
    """w_k(D) = max(0, 1 − |D − k|): the share of tap k of an echo at delay D (RTS samples)."""
    return np.maximum(0.0, 1.0 - np.abs(np.asarray(delay_samples, dtype=float) - tap))


def blade_reach_m(windmill: Windmill) -> float:
    """Largest |ΔR| any part of the windmill reaches (m): radius × |cos| of its view angle."""
    reach = 0.0
    if windmill.num_rcs:
        reach = float(np.max(windmill.radius_m)) * abs(math.cos(math.radians(windmill.rotor_angle_deg)))
    if windmill.wire is not None:
        theta = math.radians(windmill.rotor_angle_deg + windmill.wire.view_angle_deg)
        reach = max(reach, windmill.wire.radius_max_m * abs(math.cos(theta)))
    return reach


def _hub_delay(range_km: float, sample_rate_hz: float) -> float:
    return 2 * range_km * 1e3 / SPEED_OF_LIGHT_M_S * sample_rate_hz


def delay_sweep_samples(windmill: Windmill, sample_rate_hz: float) -> float:
    """Round-trip delay the blades sweep, peak to peak, in RTS samples: 2 · 2·reach·f_s/c."""
    return 2 * _hub_delay(blade_reach_m(windmill) * 1e-3, sample_rate_hz)


def tap_delays(windmill: Windmill, sample_rate_hz: float) -> list[int]:
    """The delay taps (RTS samples) a split windmill needs: floor(D_min) … ceil(D_max)."""
    centre = _hub_delay(windmill.range_km, sample_rate_hz)
    half = delay_sweep_samples(windmill, sample_rate_hz) / 2
    return list(range(math.floor(centre - half), math.ceil(centre + half) + 1))


def split_windmill(windmill: Windmill, sample_rate_hz: float) -> list[Windmill]:
    """The taps of one range-extended windmill, nearest first."""
    delays = tap_delays(windmill, sample_rate_hz)
    taps = []
    for j, d in enumerate(delays):
        cell = RangeCell(turbine=windmill.name, hub_range_km=windmill.range_km, delay_samples=d,
                         sample_rate_hz=sample_rate_hz, index=j, count=len(delays))
        taps.append(dataclasses.replace(
            windmill, name=f"{windmill.name}.t{j}", output_file=None, range_cell=cell,
            range_km=d * SPEED_OF_LIGHT_M_S / (2 * sample_rate_hz) / 1e3))
    return taps


def _extends(windmill: Windmill, farm: Farm) -> bool:
    if windmill.range_extended is not None:
        return windmill.range_extended
    return (farm.range_extend_above is not None and
            delay_sweep_samples(windmill, farm.sample_rate_hz) > farm.range_extend_above)


def extend_farm(farm: Farm) -> Farm:
    """The farm with every range-extended windmill replaced by its delay taps.

    Raises :class:`ConfigError` when a tap's name is taken by another windmill.
    """
    if not any(w.range_cell is None and _extends(w, farm) for w in farm.windmills):
        return farm
    out = []
    for w in farm.windmills:
        out += split_windmill(w, farm.sample_rate_hz) if w.range_cell is None and _extends(w, farm) else [w]
    names = [w.name for w in out]
    clashes = sorted({n for n in names if names.count(n) > 1})
    if clashes:
        raise ConfigError([f"windmill '{n}': the name is also that of a delay tap of a range-extended "
                           f"turbine (taps are named <turbine>.t<j>); rename it" for n in clashes])
    return dataclasses.replace(farm, windmills=tuple(out))


def _turns(x):
    """exp(2πi·x) with the whole turns removed first (long blades: thousands of turns)."""
    return np.exp(2j * np.pi * (x - np.rint(x)))


def _tap_chunk(windmill: Windmill, t_s: np.ndarray, wavelength_m: float) -> np.ndarray:
    from .turbine import blade_angles, point_weights, shadow_factor
    cell = windmill.range_cell
    per_m = 2 * cell.sample_rate_hz / SPEED_OF_LIGHT_M_S        # delay samples per metre of ΔR
    hub = _hub_delay(cell.hub_range_km, cell.sample_rate_hz)
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
    The taps of one turbine sum to :func:`rast.model.turbine.modulation` of the turbine."""
    from .turbine import evaluate_in_chunks
    if windmill.range_cell is None:
        raise ValueError(f"windmill {windmill.name!r} is not a delay tap")
    return evaluate_in_chunks(_tap_chunk, windmill, t_s, wavelength_m)
