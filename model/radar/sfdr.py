"""Spur-free dynamic range of the per-pulse samples a radar sees, over the whole Doppler band.

Each consecutive, non-overlapping CPI is windowed (4-term Blackman-Harris,
sidelobes below −92 dB) and transformed over the full band ±PRF/2. The
turbines' own Doppler band, centred on 0 Hz, is excluded:
``|f| ≤ max(max_doppler_hz) + guard_bins·bin_width``. A CPI's SFDR is its
strongest line (anywhere) over the highest line outside that band, in dB;
the result is the worst CPI.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

__all__ = ["SfdrResult", "blackman_harris", "sfdr", "farm_sfdr", "worst"]

#: 4-term Blackman-Harris coefficients (Harris 1978, the −92 dB window).
_BH4 = (0.35875, 0.48829, 0.14128, 0.01168)


@dataclass(frozen=True)
class SfdrResult:
    sfdr_db: float          # worst CPI: strongest line minus highest line outside the excluded band (dB)
    spur_hz: float          # frequency of that highest outside line
    cpi_index: int          # which CPI (0-based, consecutive non-overlapping CPIs)
    per_cpi_db: np.ndarray  # SFDR of every CPI


def blackman_harris(n: int) -> np.ndarray:
    """Periodic (DFT-even) 4-term Blackman-Harris window of ``n`` points."""
    x = 2 * np.pi * np.arange(n) / n
    a0, a1, a2, a3 = _BH4
    return a0 - a1 * np.cos(x) + a2 * np.cos(2 * x) - a3 * np.cos(3 * x)


def sfdr(samples, prf_hz: float, cpi_s: float, max_doppler_hz: Sequence[float], *,
         guard_bins: int = 6) -> SfdrResult:
    """SFDR of one range gate's complex per-pulse ``samples`` (worst CPI).

    A CPI without any line outside the excluded band (all zero there) has an
    SFDR of +inf.
    """
    samples = np.asarray(samples)
    if samples.ndim != 1:
        raise ValueError(f"samples must be 1-D (one range gate's per-pulse samples), not of shape {samples.shape}")
    if not np.isfinite(prf_hz) or prf_hz <= 0:
        raise ValueError(f"prf_hz must be a positive number, not {prf_hz!r}")
    if not np.isfinite(cpi_s) or cpi_s <= 0:
        raise ValueError(f"cpi_s must be a positive number, not {cpi_s!r}")
    n = int(round(cpi_s * prf_hz))
    if n < 2:
        raise ValueError(f"cpi_s = {cpi_s:g} s holds {n} pulse(s) at prf_hz = {prf_hz:g}; a CPI needs at least 2")
    if samples.size < n:
        raise ValueError(f"samples: {samples.size} are fewer than one CPI ({n} pulses)")
    doppler = np.asarray(max_doppler_hz, dtype=float).ravel()
    if doppler.size == 0:
        raise ValueError("max_doppler_hz is empty: give the maximum Doppler of each turbine in the gate")
    if not np.all(np.isfinite(doppler)):
        raise ValueError(f"max_doppler_hz must be finite, not {doppler.tolist()}")
    if guard_bins < 0:
        raise ValueError(f"guard_bins must be >= 0, not {guard_bins!r}")
    bin_hz = prf_hz / n
    freqs = np.fft.fftshift(np.fft.fftfreq(n, 1.0 / prf_hz))
    excluded_hz = float(np.max(np.abs(doppler))) + guard_bins * bin_hz
    outside = np.abs(freqs) > excluded_hz
    if not outside.any():
        raise ValueError(f"max_doppler_hz ({np.max(np.abs(doppler)):g} Hz) plus guard_bins ({guard_bins} × "
                         f"{bin_hz:g} Hz) covers the whole band ±{prf_hz / 2:g} Hz: nothing left to measure")
    frames = samples[: (samples.size // n) * n].reshape(-1, n)
    power = np.abs(np.fft.fftshift(np.fft.fft(frames * blackman_harris(n), axis=1), axes=1)) ** 2
    peak = power.max(axis=1)
    out_power = power[:, outside]
    spur_index = out_power.argmax(axis=1)
    spur = out_power[np.arange(frames.shape[0]), spur_index]
    with np.errstate(divide="ignore", invalid="ignore"):
        per_cpi = np.where(spur > 0, 10 * np.log10(peak / np.where(spur > 0, spur, 1.0)), np.inf)
    k = int(np.argmin(per_cpi))
    return SfdrResult(float(per_cpi[k]), float(freqs[outside][spur_index[k]]), k, per_cpi)


def farm_sfdr(farm, samples, bins) -> list[SfdrResult]:
    """:func:`sfdr` of each range bin's row of ``samples`` (shape (bins, pulses)).

    ``bins`` are :class:`rast.model.radar.receiver.RangeBin`; each is measured outside
    the largest maximum Doppler of its member windmills.
    """
    from rast.model.physics.turbine import max_doppler_hz
    samples = np.asarray(samples)
    bins = list(bins)
    if samples.ndim != 2 or samples.shape[0] != len(bins):
        raise ValueError(f"samples must have shape (bins, pulses) with {len(bins)} bin(s), not {samples.shape}")
    radar = farm.radar
    out = []
    for row, b in zip(samples, bins):
        if not b.members:
            raise ValueError(f"range bin {b.range_km:g} km has no windmills: no Doppler band to exclude")
        fmax = [max_doppler_hz(farm.windmills[i], radar.wavelength_m) for i in b.members]
        out.append(sfdr(row, radar.prf_hz, radar.cpi_ms * 1e-3, fmax))
    return out


def worst(results: Sequence[SfdrResult]) -> SfdrResult:
    """The result with the smallest SFDR."""
    results = list(results)
    if not results:
        raise ValueError("results is empty")
    return min(results, key=lambda r: r.sfdr_db)
