"""Fast synthesis of one stream period by exploiting band-limitation.

A windmill's modulation m(t) is a band-limited signal: its spectrum lies
within ±max Doppler (the blade flashes and the tower's shadow widen it
slightly). A stream sampled far above that band, such as the seed's
one-word-per-RTS-sample mode (26.7 M words at 20 MS/s for a band of a few
kHz), is then almost entirely redundant. This module evaluates the physics
(:func:`rast.model.physics.turbine.modulation`) only on a *grid* of every h-th output
sample and fills the h − 1 samples between grid points with a fixed 8-tap
Lagrange (degree-7) interpolator: h polyphase filters with the same weights
in every interval, applied as matrix products written straight into the
period.

Error bound (Lagrange's remainder for a tone a·e^{2πi·f·t} on a grid of rate
f_g): |error| ≤ |a|·max|ω|·(2π·f/f_g)**8 / 8!, with ω(x) = Π (x − node) and
max|ω| = 43.07 (x = ½, nodes −3 … 4). The grid step h is chosen so that the
band edge lies at f/f_g ≤ ``GRID_BAND_FRACTION`` / 4 = 1/40 on the output
grid (1/20 on the check grid, below), which bounds the error of every tone
inside the band by 4e-10 (1e-7 on the check grid) of its amplitude: far below
the float32 trigonometry of ``modulation`` itself (≈ −148 dBc, which is what
the check measures on the seed-mode benchmark's windmill).

The band is an assumption, so it is *measured*, every time: the grid is
evaluated at h, and the grid points at 2h (every other one) are interpolated
to the odd grid points (the midpoints, where Lagrange interpolation is
worst) and compared with their direct evaluation, over the whole period.
That measures the error of the same interpolator on a grid twice as coarse;
the output's own error is smaller (2**8 times for a band-limited signal, at
least 2 times for a kink). If the measured RMS error exceeds
``CHECK_LIMIT_DBC`` (10 dB below the −100 dBc the streams promise, a 16-bit
word's quantisation floor being about −98 dBc), or a weighting feature (a
flash, a table column, the shadow) is narrower than ``MIN_FEATURE_GRID_STEPS``
grid steps, the stream is evaluated directly instead, and the report says
why. Streams at the automatic rate (4 × max Doppler) have no redundancy to
exploit and are always evaluated directly.

Every core is used: the grid (or, directly, the period) and the interpolated
blocks are computed in pieces on a :class:`ComputePool` of threads (numpy
releases the GIL), with BLAS held to one thread meanwhile, so that the
values do not depend on the number of cores. ``emit(start, values)`` hands
each finished piece of the period to a consumer (the file writers of
:func:`rast.model.files.ramfiles.make_farm_files`) while the rest is computed.
"""

from __future__ import annotations

import ctypes
import math
import os
import threading
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from rast.model.physics.config import BladeFlash, WeightTable, Windmill
from rast.model.physics.turbine import CHUNK_SAMPLES, max_doppler_hz, modulation

__all__ = ["Synthesis", "synthesise_period", "lagrange_weights", "ComputePool", "usable_cores",
           "GRID_BAND_FRACTION", "CHECK_LIMIT_DBC", "MIN_GRID_STEP", "MIN_FEATURE_GRID_STEPS", "TAPS"]

#: Interpolator taps (degree TAPS − 1), nodes −3 … 4 around the interval [0, 1).
TAPS = 8
_LEFT = TAPS // 2 - 1
#: Twice the band edge / rate of the *check* grid (2h); the output grid (h) has half of
#: that again (1/40). 0.05 before: the check measured the same float32 floor at both.
GRID_BAND_FRACTION = 0.1
#: Largest accepted RMS error measured by the midpoint check, dB relative to the stream's RMS.
CHECK_LIMIT_DBC = -110.0
#: Below this grid step (output samples per grid point) direct evaluation is as cheap.
MIN_GRID_STEP = 8
#: A weighting feature (flash FWHM, table column, shadow width) must span this many check-grid steps.
MIN_FEATURE_GRID_STEPS = 8
#: Output samples per interpolated block (one task of the pool; a few MB, cache-sized).
SAMPLES_PER_BLOCK = 1 << 18
#: Rows (grid intervals) of every BLAS product of the interpolation, the last one
#: padded. OpenBLAS's last bits of a row depend on the product's shape (seen on
#: an AVX-512 machine: products of 64 to 1024 rows agreed, 1472-row ones not),
#: so only products of one shape make the values independent of the block size.
BLAS_ROWS = 128
#: Samples per directly evaluated piece, at most (a whole number of the physics' chunks).
SAMPLES_PER_PIECE = 64 * CHUNK_SAMPLES


def usable_cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:                      # not Linux
        return os.cpu_count() or 1


class _Blas:
    """Set and read OpenBLAS's thread count through its C API (what threadpoolctl
    does); no effect when numpy's BLAS is not OpenBLAS or cannot be found."""
    _NAMES = [(f"{prefix}set_num_threads{suffix}", f"{prefix}get_num_threads{suffix}")
              for prefix in ("scipy_openblas_", "openblas_") for suffix in ("64_", "")]

    def __init__(self):
        self.set = self.get = None
        try:
            with open("/proc/self/maps", encoding="utf-8", errors="replace") as maps:
                paths = sorted({line.split(None, 5)[5].strip() for line in maps
                                if "openblas" in line.lower() and len(line.split(None, 5)) == 6})
        except OSError:
            return
        for path in paths:
            try:
                lib = ctypes.CDLL(path)
            except OSError:
                continue
            for set_name, get_name in self._NAMES:
                if hasattr(lib, set_name) and hasattr(lib, get_name):
                    self.set, self.get = getattr(lib, set_name), getattr(lib, get_name)
                    self.set.argtypes, self.set.restype = [ctypes.c_int], None
                    self.get.argtypes, self.get.restype = [], ctypes.c_int
                    return


_blas = None
_blas_lock = threading.Lock()
_blas_users = 0
_blas_threads = 0


class ComputePool:
    """Threads for pieces of numpy work, BLAS held to one thread while the pool is open.

    numpy's ufuncs and BLAS release the GIL, so pieces computed in threads use
    every core. OpenBLAS's own threads would compete with them, and on a shared
    machine they spin waiting for a busy core (300 000 evaluations of the
    seed-mode windmill took 0.9 to 1.5 s with them, 0.3 s without); with BLAS
    single-threaded every product is also the same on any number of cores.
    ``workers=1`` runs every task inline. Use as a context manager.
    """

    def __init__(self, workers: int | None = None):
        self.workers = max(1, workers or usable_cores())
        self._executor = ThreadPoolExecutor(self.workers) if self.workers > 1 else None

    def submit(self, fn, *args) -> Future:
        if self._executor is not None:
            return self._executor.submit(fn, *args)
        future = Future()
        try:
            future.set_result(fn(*args))
        except BaseException as error:          # raised again by future.result()
            future.set_exception(error)
        return future

    def __enter__(self):
        global _blas, _blas_users, _blas_threads
        with _blas_lock:
            if _blas is None:
                _blas = _Blas()
            if _blas_users == 0 and _blas.set is not None:
                _blas_threads = _blas.get()
                _blas.set(1)
            _blas_users += 1
        return self

    def __exit__(self, *exc):
        global _blas_users
        if self._executor is not None:
            self._executor.shutdown(wait=True, cancel_futures=exc[0] is not None)
        with _blas_lock:
            _blas_users -= 1
            if _blas_users == 0 and _blas.set is not None:
                _blas.set(_blas_threads)
        return False


def _in_order(pool: ComputePool, tasks, done=None) -> None:
    """Run ``tasks`` (``(fn, args, start, stop)``) on the pool; call ``done(start, stop)``
    in task order as each finishes, in the calling thread."""
    futures = [(pool.submit(fn, *args), start, stop) for fn, args, start, stop in tasks]
    for future, start, stop in futures:
        future.result()
        if done:
            done(start, stop)


@dataclass(frozen=True)
class Synthesis:
    """How a period was made: ``"grid"`` (interpolated) or ``"direct"``, and why."""
    method: str
    grid_step: int = 1               # h, output samples per grid point (1: direct)
    grid_points: int = 0             # physics evaluations on the grid
    check_error_dbc: float | None = None   # midpoint check's RMS error (grid 2h), dB re RMS
    reason: str = ""


def lagrange_weights(fractions: np.ndarray) -> np.ndarray:
    """Lagrange basis on the nodes −3 … 4 at the given fractions of [0, 1): shape (TAPS, n)."""
    x = np.asarray(fractions, dtype=float)
    nodes = np.arange(TAPS) - _LEFT
    weights = np.ones((TAPS, x.size))
    for j in range(TAPS):
        for m in range(TAPS):
            if m != j:
                weights[j] *= (x - nodes[m]) / (nodes[j] - nodes[m])
    return weights


def _narrowest_feature_s(windmill: Windmill) -> float:
    """Time span of the narrowest weighting feature: a flash's FWHM, a weight
    table's column spacing, the tower shadow's width (inf without any)."""
    seconds_per_deg = 60.0 / (360.0 * windmill.rpm)
    widths = []
    weighting = windmill.weighting
    if isinstance(weighting, BladeFlash):
        widths.append(weighting.width_deg)
    elif isinstance(weighting, WeightTable):
        table = weighting.weights
        if np.ptp(table, axis=1).max() > 0:        # a constant table has no feature
            widths.append(360.0 / table.shape[1])
    if windmill.tower is not None and windmill.tower.shadow_width_deg > 0:
        widths.append(windmill.tower.shadow_width_deg)
    return min(widths) * seconds_per_deg if widths else math.inf


def _evaluate(windmill: Windmill, t_s: np.ndarray, wavelength_m: float, out: np.ndarray,
              pool: ComputePool, done=None) -> None:
    """out = modulation(windmill, t_s), in pieces of whole CHUNK_SAMPLES on the pool:
    the physics sees the same chunks as in one call, so the values are the same."""
    n = t_s.size
    chunks = max(1, min(SAMPLES_PER_PIECE // CHUNK_SAMPLES, n // (4 * pool.workers * CHUNK_SAMPLES)))
    piece = chunks * CHUNK_SAMPLES

    def one(start, stop):
        out[start:stop] = modulation(windmill, t_s[start:stop], wavelength_m)

    _in_order(pool, [(one, (s, min(n, s + piece)), s, min(n, s + piece)) for s in range(0, n, piece)], done)


def synthesise_period(windmill: Windmill, length: int, wavelength_m: float, *,
                      progress=None, emit=None, pool: ComputePool | None = None
                      ) -> tuple[np.ndarray, Synthesis]:
    """m(t_n) at the ``length`` instants t_n = n·T_sim/length of one period (complex128),
    by grid interpolation when the stream oversamples its band enough, else directly.

    ``progress(done, total)`` is called as output samples are made, ``emit(start, values)``
    when ``values``, the view ``period[start:start + len(values)]``, is final (both in
    order, in the calling thread).
    ``pool`` computes the pieces (default: a :class:`ComputePool` of every core).
    """
    if pool is None:
        with ComputePool() as pool:
            return synthesise_period(windmill, length, wavelength_m, progress=progress, emit=emit, pool=pool)
    t_step = windmill.period_s / length
    times = lambda n: np.asarray(n, dtype=float) * t_step           # noqa: E731  (as stream_times)
    f_max = max_doppler_hz(windmill, wavelength_m)
    rate_hz = 1.0 / t_step
    # h: the check grid (2h) puts the band edge at GRID_BAND_FRACTION / 2 of its rate, and
    # spans every weighting feature with MIN_FEATURE_GRID_STEPS of its steps.
    h_band = int(GRID_BAND_FRACTION * rate_hz / (2 * f_max)) // 2 if f_max > 0 else length
    feature_s = _narrowest_feature_s(windmill)
    h_feature = (int(feature_s / (MIN_FEATURE_GRID_STEPS * 2 * t_step)) if math.isfinite(feature_s)
                 else length)
    h = min(h_band, h_feature, length // (4 * TAPS))

    def finished(period):
        def done(start, stop):
            if emit:
                emit(start, period[start:stop])
            if progress:
                progress(stop, length)
        return done

    def direct(reason, check=None):
        period = np.empty(length, dtype=complex)
        _evaluate(windmill, times(np.arange(length)), wavelength_m, period, pool, finished(period))
        return period, Synthesis("direct", 1, length, check, reason)

    if h_band < MIN_GRID_STEP:
        return direct(f"the stream rate is only {rate_hz / f_max:.3g}× the maximum Doppler: "
                      "nothing to interpolate")
    if h_feature < MIN_GRID_STEP:
        return direct(f"a weighting feature spans only {feature_s * 1e3:.3g} ms "
                      f"({feature_s / t_step:.3g} stream samples): too narrow for a grid")
    if h < MIN_GRID_STEP:
        return direct("the stream is too short for a grid")
    rows = -(-length // h)                                  # output grid intervals
    # Grid points at samples j·h, j = first … first + count − 1: an even count from an
    # even first, so that grid[0::2] is the 2h grid, wide enough that the midpoint
    # check (odd j from first + 7) covers the whole period and the wrap at both ends.
    first = -(TAPS + _LEFT % 2)
    count = rows + 2 * TAPS + 2
    count += count % 2
    grid = np.empty(count, dtype=complex)
    _evaluate(windmill, times(h * np.arange(first, first + count)), wavelength_m, grid, pool)

    # Midpoint check: the even points (grid 2h) interpolated to the odd ones.
    even, odd = grid[0::2], grid[1::2]
    mid = lagrange_weights(np.array([0.5]))[:, 0]
    window = np.lib.stride_tricks.sliding_window_view(even, TAPS)
    predicted = window @ mid                               # at odd index _LEFT + j of odd
    actual = odd[_LEFT:_LEFT + len(predicted)]
    power = float(np.mean(np.abs(grid) ** 2))
    error = float(np.mean(np.abs(predicted - actual) ** 2))
    check_dbc = 10 * math.log10(error / power) if error > 0 and power > 0 else -math.inf
    if check_dbc > CHECK_LIMIT_DBC:
        return direct(f"the band assumption fails: interpolation on a grid of {2 * h} samples "
                      f"misses by {check_dbc:.1f} dBc RMS (limit {CHECK_LIMIT_DBC:g} dBc)", check_dbc)

    # Interpolation as one real product per block: row j of the output holds the h
    # samples from j·h on, as (re, im) pairs; its inputs are the 8 grid values from
    # grid[j + offset], as (re, im) pairs, and the weights act on re and im alike.
    weights = lagrange_weights(np.arange(h) / h)
    pairs = np.zeros((2 * TAPS, 2 * h))
    pairs[0::2, 0::2] = weights
    pairs[1::2, 1::2] = weights
    out = np.empty(rows * h, dtype=complex)
    out_rows = out.view(np.float64).reshape(rows, 2 * h)
    offset = -first - _LEFT                       # grid index of output sample −_LEFT·h
    windows = np.lib.stride_tricks.sliding_window_view(grid[offset:].view(np.float64), 2 * TAPS)[::2]

    def block(start, stop):
        for j in range(start, stop, BLAS_ROWS):
            k = j + BLAS_ROWS
            if k <= rows:
                np.matmul(np.ascontiguousarray(windows[j:k]), pairs, out=out_rows[j:k])
            else:                                   # the last rows, padded to BLAS_ROWS
                padded = np.zeros((BLAS_ROWS, 2 * TAPS))
                padded[:rows - j] = windows[j:rows]
                out_rows[j:] = (padded @ pairs)[:rows - j]

    step = max(1, SAMPLES_PER_BLOCK // h // BLAS_ROWS) * BLAS_ROWS
    _in_order(pool, [(block, (j, min(rows, j + step)), j * h, min(length, (j + step) * h))
                     for j in range(0, rows, step)], finished(out))
    return out[:length], Synthesis("grid", h, count, check_dbc, "")
