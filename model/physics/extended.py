"""Range-extended turbines: one turbine split over adjacent delay taps (seed chapter 5, outlook 1).

A scatterer at radius r is ``ΔR = −r·cos(rotor_angle)·sin β`` further than the
hub (the ΔR of ``rast.model.physics.turbine``), so its round-trip delay in RTS samples
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
carry the taps without special cases; :func:`rast.model.physics.turbine.modulation`
gives a tap its share of the echo (:func:`~rast.model.physics.turbine.tap_modulation`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from rast.model.physics.config import SPEED_OF_LIGHT_M_S, ConfigError, Farm, RangeCell, Windmill
from rast.model.physics.turbine import hub_delay_samples

__all__ = ["blade_reach_m", "delay_sweep_samples", "tap_delays", "split_windmill", "extend_farm"]



def blade_reach_m(windmill: Windmill) -> float:
    """Largest |ΔR| any part of the windmill reaches (m): radius × |cos| of its view angle."""
    reach = 0.0
    if windmill.num_rcs:
        reach = float(np.max(windmill.radius_m)) * abs(math.cos(math.radians(windmill.rotor_angle_deg)))
    if windmill.wire is not None:
        theta = math.radians(windmill.rotor_angle_deg + windmill.wire.view_angle_deg)
        reach = max(reach, windmill.wire.radius_max_m * abs(math.cos(theta)))
    return reach


def delay_sweep_samples(windmill: Windmill, sample_rate_hz: float) -> float:
    """Round-trip delay the blades sweep, peak to peak, in RTS samples: 2 · 2·reach·f_s/c."""
    return 2 * hub_delay_samples(blade_reach_m(windmill) * 1e-3, sample_rate_hz)


def tap_delays(windmill: Windmill, sample_rate_hz: float) -> list[int]:
    """The delay taps (RTS samples) a split windmill needs: floor(D_min) … ceil(D_max)."""
    centre = hub_delay_samples(windmill.range_km, sample_rate_hz)
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
