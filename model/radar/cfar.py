"""Detection: cell-averaging CFAR over range, the zero-velocity clutter map,
and the closed forms they are designed and checked with.

Square-law detected noise (complex Gaussian in, ``|x|²`` out) is exponential
in every cell, after any linear filter. A cell-averaging CFAR compares the
cell under test with ``α`` times the mean of ``N`` reference cells (guard
cells left out on both sides); with ``α = N·(Pfa^(−1/N) − 1)`` the
false-alarm probability is exactly ``Pfa`` whatever the noise level
(Finn & Johnson 1968). Near the ends of the range window a cell has fewer
reference cells; its ``α`` is computed for the number it has, so ``Pfa``
holds there too.

The clutter map keeps, per range gate and azimuth cell, an exponential
average of the zero-velocity filter's power over scans (weight ``w`` for the
newest scan). A cell detects when its power exceeds ``α`` times the map of
the scans before. In steady state the map is ``Σ_k w(1−w)^k P_k`` of
independent exponential powers, and ``P(P > α·M) = Π_k 1/(1 + α·w(1−w)^k)``:
``α`` is solved from that product for the map's ``Pfa``.

For a steady (Swerling 0) target of SNR ``S`` in one cell the detection
probability against a known noise level is Marcum's ``Q1(√(2S), √(−2 ln Pfa))``;
against the CA-CFAR's estimate it is that averaged over the Gamma-distributed
reference sum (:func:`ca_cfar_pd`). Albersheim's equation gives the SNR needed
for a ``Pd`` at a ``Pfa`` (:func:`albersheim_snr_db`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["CfarConfig", "ClutterMapConfig", "ca_alpha", "ca_cfar", "clutter_map_alpha", "map_alpha", "marcum_q1",
           "ca_cfar_pd", "albersheim_snr_db", "binomial_interval"]


@dataclass(frozen=True)
class CfarConfig:
    """CA-CFAR over range: ``reference_cells`` in all (half on each side),
    ``guard_cells`` on each side of the cell under test, false-alarm
    probability ``pfa`` per cell tested."""
    reference_cells: int = 16
    guard_cells: int = 1
    pfa: float = 1e-6

    def __post_init__(self):
        if not (isinstance(self.reference_cells, (int, np.integer)) and self.reference_cells >= 2
                and self.reference_cells % 2 == 0):
            raise ValueError(f"reference_cells must be an even whole number of at least 2, not "
                             f"{self.reference_cells!r}")
        if not (isinstance(self.guard_cells, (int, np.integer)) and self.guard_cells >= 0):
            raise ValueError(f"guard_cells must be a whole number of at least 0, not {self.guard_cells!r}")
        if not (isinstance(self.pfa, (int, float)) and 0 < self.pfa < 1):
            raise ValueError(f"pfa must be a probability in (0, 1), not {self.pfa!r}")

    @property
    def reach(self) -> int:
        """Gates on each side the window spans."""
        return self.guard_cells + self.reference_cells // 2


@dataclass(frozen=True)
class ClutterMapConfig:
    """The zero-velocity clutter map: ``weight`` of the newest scan in the
    exponential average (1/8: about eight scans), ``pfa`` of its threshold."""
    weight: float = 0.125
    pfa: float = 1e-6

    def __post_init__(self):
        if not (isinstance(self.weight, (int, float)) and 0 < self.weight <= 1):
            raise ValueError(f"weight must be in (0, 1], not {self.weight!r}")
        if not (isinstance(self.pfa, (int, float)) and 0 < self.pfa < 1):
            raise ValueError(f"pfa must be a probability in (0, 1), not {self.pfa!r}")


def ca_alpha(cells, pfa: float) -> np.ndarray:
    """α of a CA-CFAR with ``cells`` reference cells (array): ``N·(Pfa^(−1/N) − 1)``;
    NaN where there are none."""
    n = np.asarray(cells, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(n > 0, n * (pfa ** (-1.0 / np.maximum(n, 1)) - 1.0), np.nan)


def ca_cfar(power: np.ndarray, cfg: CfarConfig):
    """CA-CFAR along the last axis (range gates) of ``power`` (|x|², any leading axes).

    Returns ``(detected, noise, alpha)``: boolean mask of ``power``'s shape, the
    reference mean per cell (the noise estimate) and α per gate. Gates with no
    reference cell are never detected.
    """
    power = np.asarray(power, dtype=float)
    gates = power.shape[-1]
    half, guard = cfg.reference_cells // 2, cfg.guard_cells
    csum = np.concatenate([np.zeros(power.shape[:-1] + (1,)), np.cumsum(power, axis=-1)], axis=-1)
    g = np.arange(gates)

    def window(lo, hi):                  # sums over gates [lo, hi), clipped to the run
        lo, hi = np.clip(lo, 0, gates), np.clip(hi, 0, gates)
        return csum[..., hi] - csum[..., lo], hi - lo
    lead, n_lead = window(g - guard - half, g - guard)
    lag, n_lag = window(g + guard + 1, g + guard + 1 + half)
    cells = n_lead + n_lag
    alpha = ca_alpha(cells, cfg.pfa)
    with np.errstate(invalid="ignore", divide="ignore"):
        noise = (lead + lag) / np.where(cells > 0, cells, np.nan)
    detected = (cells > 0) & (power > alpha * noise)
    return detected, noise, alpha


def clutter_map_alpha(weight: float, pfa: float) -> float:
    """α with ``Π_k 1/(1 + α·w(1−w)^k) = Pfa`` (steady-state map of exponential
    powers), by bisection on log α."""
    if weight >= 1:
        return 1.0 / pfa - 1.0         # the map is the previous scan alone
    k = np.arange(int(math.ceil(math.log(1e-18) / math.log(1 - weight))) + 1)
    c = weight * (1 - weight) ** k

    def log_pfa(a):
        return -float(np.sum(np.log1p(a * c)))
    lo, hi = 1e-12, 1.0
    while log_pfa(hi) > math.log(pfa):
        hi *= 2
    for _ in range(200):
        mid = math.sqrt(lo * hi)
        if log_pfa(mid) > math.log(pfa):
            lo = mid
        else:
            hi = mid
    return hi


def map_alpha(weights: np.ndarray, counts: np.ndarray, pfa: float) -> np.ndarray:
    """α per cell for a map that is a weighted sum of independent means:
    ``M = Σ_j c_j·mean_j``, mean j of ``m_j`` exponential powers, so that
    ``P(P > α·M) = Π_j (1 + α·c_j/m_j)^(−m_j) = pfa`` exactly (the map while it
    fills, as well as in steady state). ``weights`` and ``counts`` have shape
    (history, cells), a count 0 meaning no term; NaN for a cell with none."""
    c = np.asarray(weights, dtype=float)
    m = np.asarray(counts, dtype=float)
    use = (m > 0) & (c > 0)
    target = math.log(1 / pfa)

    def excess(a):                       # Σ m log(1 + a c/m) − ln(1/Pfa), increasing in a
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(use, m * np.log1p(a[None] * c / np.where(use, m, 1)), 0.0).sum(axis=0) - target
    cells = c.shape[1]
    lo, hi = np.full(cells, -30.0), np.full(cells, 60.0)     # log α
    for _ in range(60):                  # 90/2**60: α to double precision
        mid = (lo + hi) / 2
        up = excess(np.exp(mid)) > 0
        hi, lo = np.where(up, mid, hi), np.where(up, lo, mid)
    alpha = np.exp(hi)
    return np.where(use.any(axis=0) & (excess(np.exp(np.full(cells, 60.0))) > 0), alpha, np.nan)


def marcum_q1(a, b) -> np.ndarray:
    """Marcum's Q-function Q1(a, b) = P(|s + n|² > b²) for |s| = a and complex
    noise of unit variance per component: the noncentral χ² with two degrees of
    freedom as a Poisson mixture of central ones, summed to double precision."""
    a, b = np.broadcast_arrays(np.asarray(a, dtype=float), np.asarray(b, dtype=float))
    mu, x = a ** 2 / 2, b ** 2 / 2
    top = int(np.ceil(np.max(mu, initial=0) + 14 * np.sqrt(np.max(mu, initial=0)) + 60))
    j = np.arange(top + 1)
    log_fact = np.concatenate([[0.0], np.cumsum(np.log(np.arange(1, top + 1)))])
    with np.errstate(divide="ignore"):
        log_mu, log_x = np.log(mu)[..., None], np.log(x)[..., None]
    log_mu = np.where(mu[..., None] > 0, log_mu, -np.inf)
    log_x = np.where(x[..., None] > 0, log_x, -np.inf)
    with np.errstate(invalid="ignore"):              # 0·(−inf) at j = 0, replaced by 0
        poisson = np.exp(np.where(j == 0, 0.0, j * log_mu) - mu[..., None] - log_fact)
        terms = np.exp(np.where(j == 0, 0.0, j * log_x) - x[..., None] - log_fact)
    upper = np.cumsum(terms, axis=-1)                  # P(Gamma(j+1) > x) = e^-x Σ_{k≤j} x^k/k!
    return np.clip(np.sum(poisson * upper, axis=-1), 0.0, 1.0)


def ca_cfar_pd(snr, reference_cells: int, pfa: float, points: int = 4000) -> np.ndarray:
    """Detection probability of a CA-CFAR (``reference_cells`` cells, ``α`` for
    ``pfa``) for a steady target of linear ``snr`` per cell: ``E[Q1(√(2S),
    √(2αY/N))]``, ``Y ~ Gamma(N, 1)`` the reference sum over the noise power.
    The expectation is a trapezoid sum over ``ln Y`` (both the Gamma density
    and the threshold's ``e^(−αY/N)`` are smooth bumps there, where the rule
    converges geometrically). At ``snr = 0`` it is ``(1 + α/N)^(−N) = pfa``."""
    n = int(reference_cells)
    alpha = float(ca_alpha(n, pfa))
    v = np.linspace(math.log(1e-12), math.log(n + 14 * math.sqrt(n) + 40), points)
    y = np.exp(v)
    weight = np.exp(n * v - y - math.lgamma(n)) * (v[1] - v[0])    # Gamma(N) density × dy/dv
    weight[[0, -1]] /= 2
    s = np.asarray(snr, dtype=float)
    q = marcum_q1(np.sqrt(2 * s)[..., None], np.sqrt(2 * alpha * y / n))
    return np.sum(q * weight, axis=-1)


def albersheim_snr_db(pd: float, pfa: float, pulses: int = 1) -> float:
    """Albersheim's equation: the SNR per pulse (dB) a steady target needs for
    ``pd`` at ``pfa`` with ``pulses`` noncoherently integrated (within about
    0.2 dB for 0.1 ≤ Pd ≤ 0.9, 1e-7 ≤ Pfa ≤ 1e-3)."""
    a = math.log(0.62 / pfa)
    b = math.log(pd / (1 - pd))
    return (-5 * math.log10(pulses) +
            (6.2 + 4.54 / math.sqrt(pulses + 0.44)) * math.log10(a + 0.12 * a * b + 1.7 * b))


def binomial_interval(n: int, p: float, confidence: float = 0.999) -> tuple[int, int]:
    """The central ``confidence`` interval of a Binomial(n, p) count, from its
    exact distribution (summed in log space)."""
    k = np.arange(n + 1)
    log_fact = np.concatenate([[0.0], np.cumsum(np.log(np.arange(1, n + 1)))])
    with np.errstate(divide="ignore"):
        log_pmf = log_fact[n] - log_fact - log_fact[::-1] + k * math.log(p) + (n - k) * math.log1p(-p)
    cdf = np.cumsum(np.exp(log_pmf - log_pmf.max()))
    cdf /= cdf[-1]
    tail = (1 - confidence) / 2
    lo = int(np.searchsorted(cdf, tail))
    hi = int(np.searchsorted(cdf, 1 - tail))
    return lo, hi
