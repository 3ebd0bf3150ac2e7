"""Moving-target detection on slow-time samples: the MTI canceller, the
Doppler filter bank over coherent processing intervals, and how a run is cut
into CPIs, dwells and scans.

A CPI of ``N`` pulses goes through an ``n``-pulse canceller (binomial
weights, n = 2: ``x[k] − x[k−1]``, n = 3: ``x[k] − 2x[k−1] + x[k−2]``), whose
power response is ``|2 sin(π f T)|^(2(n−1))``: it removes the zero-Doppler
return (a tower, ground clutter) and keeps ``N − n + 1`` pulses, which a
windowed FFT of ``nfft`` points splits into Doppler filters (Lincoln
Laboratory's MTD: a 3-pulse canceller and an 8-point FFT over a 10-pulse
CPI). The zero-velocity filter is the same FFT's bin 0 on the *uncancelled*
CPI: the channel the clutter map watches (:mod:`rast.model.radar.cfar`).

The dwell is a parameter: without azimuths, a stare radar's run is cut into
consecutive CPIs and a "scan" is a fixed number of them; with a per-pulse
antenna azimuth, the pulses are grouped into dwells (consecutive pulses
within one beamwidth of azimuth), the CPIs are aligned to the dwells, and a
scan is one revolution (:func:`plan_cpis`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["MtdConfig", "canceller_weights", "canceller_response", "doppler_window", "CpiPlan",
           "plan_cpis", "doppler_filter_bank", "zero_velocity_filter", "WINDOWS"]

WINDOWS = ("rect", "hann", "hamming", "blackman")


@dataclass(frozen=True)
class MtdConfig:
    """The air-traffic processor's coherent part.

    ``cpi_pulses``: pulses per CPI (N); ``canceller_pulses``: 2 or 3 for a 2- or
    3-pulse MTI canceller, 0 for none; ``nfft``: Doppler filters (default: the
    pulses the canceller leaves, N − n + 1); ``window``: the taper of the FFT
    (one of :data:`WINDOWS`);
    ``stagger_prf_hz``: a second PRF for every other CPI (blind speeds), None
    for a constant PRF.
    """
    cpi_pulses: int = 10
    canceller_pulses: int = 3
    nfft: int | None = None
    window: str = "hann"
    stagger_prf_hz: float | None = None

    def __post_init__(self):
        if not (isinstance(self.cpi_pulses, (int, np.integer)) and self.cpi_pulses >= 2):
            raise ValueError(f"cpi_pulses must be a whole number of at least 2, not {self.cpi_pulses!r}")
        if self.canceller_pulses not in (0, 2, 3):
            raise ValueError(f"canceller_pulses must be 0 (none), 2 or 3, not {self.canceller_pulses!r}")
        if self.cpi_pulses - max(self.canceller_pulses - 1, 0) < 2:
            raise ValueError(f"cpi_pulses ({self.cpi_pulses}) must leave at least 2 pulses after the "
                             f"{self.canceller_pulses}-pulse canceller")
        if self.nfft is not None and not (isinstance(self.nfft, (int, np.integer)) and self.nfft >= self.kept_pulses):
            raise ValueError(f"nfft must be a whole number of at least the {self.kept_pulses} pulses the "
                             f"canceller leaves, not {self.nfft!r}")
        if self.window not in WINDOWS:
            raise ValueError(f"window must be one of {', '.join(WINDOWS)}, not {self.window!r}")
        if self.stagger_prf_hz is not None and not (math.isfinite(self.stagger_prf_hz) and self.stagger_prf_hz > 0):
            raise ValueError(f"stagger_prf_hz must be a positive frequency, not {self.stagger_prf_hz!r}")

    @property
    def kept_pulses(self) -> int:
        """Pulses per CPI after the canceller."""
        return self.cpi_pulses - max(self.canceller_pulses - 1, 0)

    @property
    def filters(self) -> int:
        return self.nfft or self.kept_pulses


def canceller_weights(pulses: int) -> np.ndarray:
    """Binomial weights of an n-pulse canceller, (1, −1) or (1, −2, 1); (1,) for none."""
    if pulses == 0:
        return np.ones(1)
    return np.array([(-1) ** k * math.comb(pulses - 1, k) for k in range(pulses)], dtype=float)


def canceller_response(doppler_hz, prf_hz: float, pulses: int) -> np.ndarray:
    """The canceller's amplitude response at ``doppler_hz``: |Σ c_k e^{-2πi f k T}|,
    computed from its weights (the closed form is |2 sin(π f T)|^(n−1))."""
    f = np.asarray(doppler_hz, dtype=float)
    c = canceller_weights(pulses)
    k = np.arange(c.size)
    return np.abs(np.exp(-2j * np.pi * f[..., None] * k / prf_hz) @ c)


def doppler_window(n: int, window: str) -> np.ndarray:
    """The Doppler filters' taper over ``n`` pulses."""
    if window == "rect":
        return np.ones(n)
    if window == "hann":
        return np.hanning(n + 2)[1:-1]          # no zero end points: every pulse counts
    if window == "hamming":
        return np.hamming(n)
    if window == "blackman":
        return np.blackman(n + 2)[1:-1]
    raise ValueError(f"window must be one of {', '.join(WINDOWS)}, not {window!r}")


@dataclass(frozen=True)
class CpiPlan:
    """Which pulses make each CPI, and where each CPI sits.

    ``start``: first pulse of each CPI (CPIs are ``cpi_pulses`` consecutive
    pulses); ``scan``: the scan each CPI belongs to; ``cell``: its azimuth cell
    within the scan (the clutter map's column: the dwell's index in the
    revolution, or the CPI's index in the stare radar's scan); ``azimuth_deg``:
    the antenna's mean azimuth over the CPI (NaN for a stare radar); ``dwell``:
    the dwell it belongs to (its index in the whole run).
    """
    start: np.ndarray
    scan: np.ndarray
    cell: np.ndarray
    azimuth_deg: np.ndarray
    dwell: np.ndarray
    cells: int                  # azimuth cells per scan (1 for a stare radar)
    scans: int

    @property
    def count(self) -> int:
        return int(self.start.size)


def plan_cpis(pulses: int, cpi_pulses: int, *, azimuth_deg=None, beamwidth_deg: float = 1.4,
              scan_cpis: int | None = None) -> CpiPlan:
    """Cut ``pulses`` pulses into CPIs.

    Without ``azimuth_deg`` (a stare radar): consecutive CPIs of ``cpi_pulses``
    (leftover pulses at the end unused); a scan is ``scan_cpis`` CPIs (None:
    the whole run); the clutter map has one cell, updated once per scan.

    With ``azimuth_deg`` (one antenna azimuth per pulse, degrees clockwise
    from north, the antenna turning clockwise): a dwell is the run of
    consecutive pulses whose azimuth lies in one cell of ``beamwidth_deg``
    (cells counted from 0° north; 360/beamwidth rounded up to whole cells);
    each dwell holds as many whole CPIs as fit, starting at its first pulse;
    a scan is one revolution, starting where the azimuth wraps past north.
    """
    if not (isinstance(pulses, (int, np.integer)) and pulses >= 0):
        raise ValueError(f"pulses must be a whole number, not {pulses!r}")
    if azimuth_deg is None:
        count = pulses // cpi_pulses
        if scan_cpis is not None and not (isinstance(scan_cpis, (int, np.integer)) and scan_cpis >= 1):
            raise ValueError(f"scan_cpis must be a positive whole number of CPIs, not {scan_cpis!r}")
        per_scan = max(count, 1) if scan_cpis is None else scan_cpis
        index = np.arange(count)
        return CpiPlan(start=index * cpi_pulses, scan=index // per_scan, cell=np.zeros(count, dtype=np.int64),
                       azimuth_deg=np.full(count, np.nan), dwell=index, cells=1,
                       scans=max(1, -(-count // per_scan)))
    az = np.asarray(azimuth_deg, dtype=float)
    if az.shape != (pulses,):
        raise ValueError(f"azimuth_deg must hold one azimuth per pulse ({pulses}), not shape {az.shape}")
    if not np.all(np.isfinite(az)):
        raise ValueError("azimuth_deg must hold finite numbers of degrees")
    if not (math.isfinite(beamwidth_deg) and 0 < beamwidth_deg <= 360):
        raise ValueError(f"beamwidth_deg must be in (0, 360] degrees, not {beamwidth_deg!r}")
    cells = math.ceil(360 / beamwidth_deg - 1e-9)
    wrapped = np.mod(az, 360.0)
    cell = np.minimum((wrapped / beamwidth_deg).astype(np.int64), cells - 1)
    # a new revolution where the azimuth passes north (the cell index falls)
    revolution = np.concatenate([[0], np.cumsum(np.diff(cell) < -cells // 2)])
    change = np.flatnonzero((np.diff(cell) != 0) | (np.diff(revolution) != 0)) + 1
    dwell_start = np.concatenate([[0], change]) if pulses else np.zeros(0, dtype=np.int64)
    dwell_end = np.concatenate([change, [pulses]]) if pulses else np.zeros(0, dtype=np.int64)
    fits = (dwell_end - dwell_start) // cpi_pulses
    dwell_of_cpi = np.repeat(np.arange(dwell_start.size), fits)
    within = np.arange(dwell_of_cpi.size) - np.repeat(np.cumsum(fits) - fits, fits)
    start = dwell_start[dwell_of_cpi] + within * cpi_pulses
    idx = start[:, None] + np.arange(cpi_pulses)[None, :]
    rad = np.deg2rad(az[idx]) if start.size else np.zeros((0, cpi_pulses))
    mean_az = np.mod(np.rad2deg(np.arctan2(np.sin(rad).mean(axis=1), np.cos(rad).mean(axis=1))), 360.0)
    scan = revolution[start] - (revolution[0] if pulses else 0)
    return CpiPlan(start=start, scan=scan, cell=cell[start], azimuth_deg=mean_az, dwell=dwell_of_cpi,
                   cells=cells, scans=int(scan.max()) + 1 if scan.size else 1)


def _cpi_blocks(samples: np.ndarray, plan: CpiPlan, cpi_pulses: int) -> np.ndarray:
    """The CPIs' samples, shape (CPIs, gates, cpi_pulses)."""
    idx = plan.start[:, None] + np.arange(cpi_pulses)[None, :]
    return np.moveaxis(samples[:, idx], 0, 1)


def doppler_filter_bank(samples: np.ndarray, plan: CpiPlan, cfg: MtdConfig) -> np.ndarray:
    """Canceller and windowed FFT of every CPI: complex, shape (CPIs, gates,
    filters), filter k at ``k·PRF/nfft`` (0 … PRF, not shifted). Normalised to
    the window's coherent gain: a tone at a filter's centre keeps its
    amplitude times the canceller's response."""
    blocks = _cpi_blocks(samples, plan, cfg.cpi_pulses)
    c = canceller_weights(cfg.canceller_pulses)
    kept = cfg.kept_pulses
    cancelled = sum(c[k] * blocks[..., c.size - 1 - k:c.size - 1 - k + kept] for k in range(c.size))
    w = doppler_window(kept, cfg.window)
    return np.fft.fft(cancelled * w, n=cfg.filters, axis=-1) / w.sum()


def zero_velocity_filter(samples: np.ndarray, plan: CpiPlan, cfg: MtdConfig) -> np.ndarray:
    """The zero-Doppler filter on the uncancelled CPI (the same window over all
    its pulses): complex, shape (CPIs, gates)."""
    blocks = _cpi_blocks(samples, plan, cfg.cpi_pulses)
    w = doppler_window(cfg.cpi_pulses, cfg.window)
    return blocks @ w / w.sum()
