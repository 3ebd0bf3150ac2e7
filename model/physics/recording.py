"""Recorded micro-Doppler signatures made into streams (seed chapter 5, outlook 2).

A recording is the slow-time I/Q series of one turbine's range cell: one
complex sample per pulse, at the radar's PRF. Replaying it takes
"filtering and interpolation" (seed chapter 5):

1. the period: the turbine's echo repeats every blade period T (every
   revolution if the blades differ); :func:`estimate_period` finds it from the
   normalised autocorrelation of the series (its mean, the static tower and
   clutter, removed) at lags of 1/8 pulse interval, refined by fitting a
   parabola to the peak at the largest whole multiple m·T the recording holds;
   when the phase does not repeat (a drifting rpm), from the repeat of its log
   spectrogram instead (the mean period);
2. the cut and the loop: the recording is cut into the M whole periods it
   holds and each is read at the N stream instants ``t_n = n·T/N`` of one
   period by band-limited (Kaiser-windowed sinc) interpolation, which also
   removes everything above the stream's band; the M readings are averaged
   (synchronous averaging: noise down by √M, the period kept). The loop is
   one period sampled over exactly one period, so it is seamless for a
   periodic echo; T need not be a multiple of the PRI;
3. the stream: the loop is band-limited once more as a periodic signal (its
   DFT zeroed outside the band), quantised by ``rast.model.physics.stream.quantise``
   and written with the manifest as by ``rast stream``.

:func:`rast.model.radar.receiver.spectrogram_correlation` checks the result: the model radar's
spectrogram of the replayed stream words against the recording's own.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rast.model.contract import fixedpoint as fx
from rast.model.physics.config import Farm, Radar, Windmill
from rast.model.physics.stream import FarmStreams, StreamPlan, WindmillStream, delay_samples, quantise

__all__ = ["RecordingError", "Recording", "read_recording", "PeriodEstimate", "estimate_period",
           "band_limited_read", "kernel_half_width", "make_loop", "Loop", "occupied_doppler_hz",
           "stream_increment", "recording_streams", "synthetic_recording",
           "SYNTHETIC_TURBINE", "KERNEL_ZEROS", "KAISER_BETA", "MIN_CORRELATION",
           "MIN_PATTERN_CORRELATION", "UPSAMPLE", "FRAME_PULSES", "HOP_PULSES"]

#: Zero crossings of the interpolating sinc on each side (its half-length in band-limited samples).
KERNEL_ZEROS = 16
#: Kaiser window of the sinc: sidelobes about −80 dB, transition band ≈ 2·5/KERNEL_ZEROS of the band.
KAISER_BETA = 8.0
#: A normalised autocorrelation peak below this is no repeat: of the I/Q series (a noise
#: power N beside a signal S caps it at S/(S+N)), and of its log spectrogram.
MIN_CORRELATION = 0.5
MIN_PATTERN_CORRELATION = 0.3


#: Most band-limited reads :func:`make_loop` makes (periods x words): each is
#: a windowed-sinc sum, and 2**26 of them take seconds and a few GB.
MAX_LOOP_READS = 1 << 26


class RecordingError(ValueError):
    """A recording cannot be read or made into a stream; the message says why."""


@dataclass(frozen=True)
class Recording:
    samples: np.ndarray                 # complex128, one per pulse
    sample_rate_hz: float | None        # from the file (SigMF), else None
    frequency_hz: float | None          # the radar's carrier, from the file (SigMF), else None


def _read_npy(path: Path) -> np.ndarray:
    try:
        data = np.load(path, allow_pickle=False)
    except (OSError, ValueError, EOFError) as error:
        raise RecordingError(f"{path} is not a NumPy .npy file: {error or 'it is empty'}") from None
    if data.ndim == 2 and data.shape[1] == 2 and np.isrealobj(data):
        data = data[:, 0] + 1j * data[:, 1]
    if data.ndim != 1 or not np.issubdtype(data.dtype, np.number) or not np.iscomplexobj(data):
        raise RecordingError(f"{path} holds an array of shape {data.shape} and type {data.dtype}: "
                             "give one complex sample per pulse (1-D complex, or N×2 real I, Q)")
    return data.astype(complex)


def _read_csv(path: Path) -> np.ndarray:
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as error:
        raise RecordingError(f"cannot read {path}: {getattr(error, 'strerror', None) or error}") from None
    rows = []
    for number, line in enumerate(lines, start=1):
        cells = [c.strip() for c in re.split(r"[,;\t]", line)]
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        if len(cells) != 2:
            raise RecordingError(f"{path} row {number}: has {len(cells)} columns, give two (I, Q)")
        try:
            values = [float(c) for c in cells]
        except ValueError:
            if not rows:            # a header line
                continue
            raise RecordingError(f"{path} row {number}: {line.strip()!r} is not two numbers (I, Q)") from None
        if not all(math.isfinite(v) for v in values):
            raise RecordingError(f"{path} row {number}: {line.strip()!r} is not finite")
        rows.append(values)
    if not rows:
        raise RecordingError(f"{path} holds no samples")
    data = np.asarray(rows)
    return data[:, 0] + 1j * data[:, 1]


def _read_sigmf(path: Path) -> Recording:
    from sigmf import sigmffile
    from sigmf.error import SigMFError
    meta = path.with_suffix(".sigmf-meta") if path.suffix in (".sigmf-data", ".sigmf-meta") else path
    try:
        handle = sigmffile.fromfile(str(meta))
        samples = np.asarray(handle.read_samples())
    except (OSError, SigMFError, ValueError, KeyError) as error:
        raise RecordingError(f"cannot read the SigMF recording {meta}: {error}") from None
    if not np.iscomplexobj(samples):
        raise RecordingError(f"{meta}: the samples are real ({handle.get_global_field('core:datatype')}); "
                             "give a complex recording (core:datatype c…)")
    rate = handle.get_global_field("core:sample_rate")
    captures = handle.get_captures()
    freq = captures[0].get("core:frequency") if captures else None
    for key, value in (("core:sample_rate", rate), ("core:frequency", freq)):
        if value is not None and not (isinstance(value, (int, float)) and not isinstance(value, bool)
                                      and math.isfinite(value) and value > 0):
            raise RecordingError(f"{meta}: '{key}' must be a positive number of Hz, not {value!r}")
    return Recording(samples.reshape(-1).astype(complex), float(rate) if rate else None,
                     float(freq) if freq else None)


def read_recording(path) -> Recording:
    """Read a slow-time I/Q recording: ``.npy``, SigMF (``.sigmf-meta``/``.sigmf-data``) or CSV (I, Q)."""
    path = Path(path)
    if not path.exists():
        raise RecordingError(f"{path} does not exist")
    suffix = path.suffix.lower()
    if suffix in (".sigmf-meta", ".sigmf-data"):
        rec = _read_sigmf(path)
    elif suffix == ".npy":
        rec = Recording(_read_npy(path), None, None)
    elif suffix in (".csv", ".txt"):
        rec = Recording(_read_csv(path), None, None)
    else:
        raise RecordingError(f"{path}: unknown recording type {suffix!r}; give .npy (complex), "
                             ".sigmf-meta / .sigmf-data, or .csv (two columns I, Q)")
    if not np.all(np.isfinite(rec.samples)):
        bad = int(np.flatnonzero(~np.isfinite(rec.samples))[0])
        raise RecordingError(f"{path}: sample {bad} is not finite")
    if rec.samples.size < 4:
        raise RecordingError(f"{path} holds {rec.samples.size} samples: far too short for one period")
    return rec


#: The autocorrelation is evaluated at lags of 1/UPSAMPLE pulse intervals (band-limited
#: interpolation): a period that is not a whole number of PRIs is still a sharp peak.
UPSAMPLE = 8


def _autocorrelation(x: np.ndarray, upsample: int) -> np.ndarray:
    """|Σ x(n+τ)·x*(n)| over the overlap, normalised by the overlap's energies, at lags
    τ = j/upsample pulse intervals, j = 0 … upsample·N − 1: the linear autocorrelation
    interpolated by zero-padding its spectrum (exact for a series band-limited to ±PRF/2)."""
    x = x.reshape(len(x), -1)                         # columns: channels summed (spectrogram bins)
    n = len(x)
    size = 1 << (2 * n - 1).bit_length()
    power = (np.abs(np.fft.fft(x, size, axis=0)) ** 2).sum(axis=1)
    padded = np.zeros(size * upsample)
    padded[:size // 2] = power[:size // 2]
    padded[-(size // 2):] = power[size // 2:]
    r = np.abs(np.fft.ifft(padded))[:n * upsample] * upsample
    lags = np.arange(n * upsample) / upsample
    energy = np.concatenate([[0.0], np.cumsum((np.abs(x) ** 2).sum(axis=1))])
    head = np.interp(n - lags, np.arange(n + 1), energy)              # x[0 : n−τ]
    tail = energy[n] - np.interp(lags, np.arange(n + 1), energy)      # x[τ : n]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(head * tail > 0, r / np.sqrt(head * tail), 0.0)


def _parabola(r: np.ndarray, k: int) -> float:
    """Sub-sample position of the peak at k (a parabola through k−1, k, k+1)."""
    if k <= 0 or k >= r.size - 1:
        return float(k)
    a, b, c = r[k - 1], r[k], r[k + 1]
    denom = a - 2 * b + c
    return float(k) if denom >= 0 else k + 0.5 * (a - c) / denom


@dataclass(frozen=True)
class PeriodEstimate:
    period_s: float
    multiple: int            # the peak at multiple·period was used to refine it
    correlation: float       # the normalised autocorrelation at that peak (1: a perfect repeat)
    method: str              # "coherent" (the I/Q series) or "spectrogram" (its Doppler pattern)


#: Frames of the spectrogram the non-coherent estimate correlates: length and hop in pulses.
FRAME_PULSES, HOP_PULSES = 256, 16


def _repeat(r: np.ndarray, threshold: float):
    """``(lag, multiple, correlation)`` of the fundamental repeat in a normalised
    autocorrelation r (lag in r's steps), or None: past the main lobe, the first peak within
    90 % of the highest, refined by a parabola at its largest multiple still above ``threshold``."""
    half = len(r) // 2                                 # the overlap at a lag is at least one lag
    below = np.flatnonzero(r[1:half + 1] < threshold)
    if below.size == 0:
        return None
    start = int(below[0]) + 1                          # past the main lobe around lag 0
    seg = r[start:half + 1]
    if seg.size < 3:
        return None
    peaks = np.flatnonzero((seg[1:-1] >= seg[:-2]) & (seg[1:-1] >= seg[2:])) + 1
    if peaks.size == 0 or seg[peaks].max() < threshold:
        return None
    best = seg[peaks].max()
    fundamental = start + int(peaks[np.flatnonzero(seg[peaks] >= 0.9 * best)[0]])
    lag, multiple = _parabola(r, fundamental), 1
    width = max(2, int(round(lag / 64)))               # search window about a multiple
    for m in range(2, int((len(r) - lag) // lag) + 1):   # overlap of at least one period
        guess = int(round(m * lag))
        lo, hi = max(1, guess - width), min(len(r) - 2, guess + width)
        if hi <= lo:
            break
        k = lo + int(np.argmax(r[lo:hi + 1]))
        if r[k] < threshold:
            break
        lag, multiple = _parabola(r, k) / m, m
    return lag, multiple, float(r[int(round(lag * multiple))])


def _doppler_frames(x: np.ndarray) -> np.ndarray:
    """Log power spectrogram (frames × bins), each bin's mean over time removed."""
    starts = np.arange(0, len(x) - FRAME_PULSES + 1, HOP_PULSES)
    frames = x[starts[:, None] + np.arange(FRAME_PULSES)[None, :]] * np.hanning(FRAME_PULSES)
    power_db = 10 * np.log10(np.abs(np.fft.fft(frames, axis=1)) ** 2 + 1e-30)
    power_db = np.maximum(power_db, power_db.max() - 60.0)
    return power_db - power_db.mean(axis=0)


def estimate_period(samples: np.ndarray, prf_hz: float) -> PeriodEstimate:
    """The repeat period of a slow-time series (seconds). First coherently: the fundamental
    peak of the series' normalised autocorrelation (band-limited to 1/8 PRI), refined at its
    largest whole multiple within the recording. When the phase does not repeat (a drifting
    rpm decorrelates a long blade's phase within a fraction of a percent, strong noise), from
    the autocorrelation of its Doppler pattern: the log spectrogram over time. Needs at least
    two periods; raises :class:`RecordingError` when no repeat is found."""
    x = np.asarray(samples, dtype=complex)
    x = x - x.mean()
    n = x.size
    if not np.any(np.abs(x) > 0):
        raise RecordingError("the recording is constant: it has no rotating echo to repeat")
    upsample = max(1, min(UPSAMPLE, (1 << 24) // (2 * n)))          # bounds the work array
    found = _repeat(_autocorrelation(x, upsample), MIN_CORRELATION)
    if found is not None:
        lag, multiple, corr = found
        return PeriodEstimate(float(lag / upsample / prf_hz), multiple, corr, "coherent")
    if n >= 4 * FRAME_PULSES:
        found = _repeat(_autocorrelation(_doppler_frames(x), 1), MIN_PATTERN_CORRELATION)
        if found is not None:
            lag, multiple, corr = found
            return PeriodEstimate(float(lag * HOP_PULSES / prf_hz), multiple, corr, "spectrogram")
    raise RecordingError(
        f"the recording holds {n} samples ({n / prf_hz:.4g} s at {prf_hz:g} Hz) and no repeat of "
        f"it: estimating the rotation period needs at least two periods of the turbine's echo "
        f"(give a longer recording, or the period with --period)")


def band_limited_read(samples: np.ndarray, prf_hz: float, times_s: np.ndarray,
                      bandwidth_hz: float) -> np.ndarray:
    """x(t) at arbitrary times from samples at ``prf_hz``, through an ideal low-pass of two-sided
    width ``bandwidth_hz`` (≤ prf) approximated by a Kaiser-windowed sinc of ``KERNEL_ZEROS``
    zero crossings a side. The times must keep the kernel inside the recording
    (see :func:`kernel_half_width`)."""
    ratio = bandwidth_hz / prf_hz
    half = kernel_half_width(prf_hz, bandwidth_hz)
    u = np.asarray(times_s, dtype=float) * prf_hz
    base = np.floor(u).astype(np.int64)
    offsets = np.arange(-half + 1, half + 1)
    out = np.empty(u.shape, dtype=complex)
    for start in range(0, u.size, 4096):
        b, uu = base[start:start + 4096], u[start:start + 4096]
        idx = b[:, None] + offsets[None, :]
        d = uu[:, None] - idx
        arg = np.clip(d / half, -1.0, 1.0)
        kaiser = np.i0(KAISER_BETA * np.sqrt(1.0 - arg ** 2)) / np.i0(KAISER_BETA)
        kernel = ratio * np.sinc(ratio * d) * kaiser
        out[start:start + 4096] = (samples[idx] * kernel).sum(axis=1)
    return out


def kernel_half_width(prf_hz: float, bandwidth_hz: float) -> int:
    """Half-length of the interpolating kernel in recording samples."""
    return int(math.ceil(KERNEL_ZEROS * prf_hz / bandwidth_hz))


@dataclass(frozen=True)
class Loop:
    words: np.ndarray          # complex128, N samples of one period
    period_s: float
    periods: int               # M, whole periods averaged
    start_sample: int          # recording sample at the loop's t = 0
    bandwidth_hz: float        # two-sided band kept


def make_loop(samples: np.ndarray, prf_hz: float, period_s: float, length: int,
              bandwidth_hz: float) -> Loop:
    """One seamless period of ``length`` words: the recording's whole periods read at
    t_n = n·T/N (band-limited) and averaged, then band-limited as a periodic signal."""
    n = samples.size
    half = kernel_half_width(prf_hz, bandwidth_hz)
    usable = (n - 1 - 2 * half) / prf_hz
    periods = int(math.floor(usable / period_s)) if usable > 0 else 0
    if periods < 1:
        raise RecordingError(
            f"the recording holds {n} samples ({n / prf_hz:.4g} s at {prf_hz:g} Hz) but one period of "
            f"{period_s:.4g} s and the interpolator's {2 * half} samples need "
            f"{math.ceil(period_s * prf_hz) + 2 * half + 1}: the recording is too short for one period")
    if periods * length > MAX_LOOP_READS:
        raise RecordingError(
            f"a period of {period_s:.4g} s fits {periods:,} times in the recording and each takes "
            f"{length:,} words: {periods * length:.3g} reads, more than the {MAX_LOOP_READS:,} RAST "
            f"averages; give a longer --period or a lower --rate")
    t_n = np.arange(length) * (period_s / length)
    times = half / prf_hz + (np.arange(periods) * period_s)[:, None] + t_n[None, :]
    reads = band_limited_read(samples, prf_hz, times.reshape(-1), bandwidth_hz).reshape(periods, length)
    loop = reads.mean(axis=0)
    spectrum = np.fft.fft(loop)
    f = np.fft.fftfreq(length, period_s / length)
    spectrum[np.abs(f) > bandwidth_hz / 2] = 0
    return Loop(np.fft.ifft(spectrum), period_s, periods, half, bandwidth_hz)


def occupied_doppler_hz(loop: Loop, fraction: float = 0.999) -> float:
    """The smallest |f| holding ``fraction`` of the loop's power outside zero Doppler."""
    spectrum = np.abs(np.fft.fft(loop.words - loop.words.mean())) ** 2
    f = np.abs(np.fft.fftfreq(loop.words.size, loop.period_s / loop.words.size))
    order = np.argsort(f, kind="stable")
    cumulative = np.cumsum(spectrum[order])
    if cumulative[-1] == 0:
        return 0.0
    return float(f[order][np.searchsorted(cumulative, fraction * cumulative[-1])])


def stream_increment(rate_hz: float, sample_rate_mhz: float, interpolation: str) -> int:
    """The RAM address step per RTS sample of a stream at ``rate_hz``; raises
    :class:`RecordingError` when the replay block's interpolation cannot play that rate."""
    f_s = sample_rate_mhz * 1e6
    increment = round(rate_hz / f_s * (1 << fx.PHASE_FRAC_BITS))
    limit = fx.FIR_MAX_INCREMENT if interpolation == "fir" else (1 << fx.PHASE_FRAC_BITS) - 1
    if increment > limit:
        raise RecordingError(f"the stream rate {rate_hz:.6g} Hz is too high for {interpolation} "
                             f"interpolation at {sample_rate_mhz:g} MHz (at most "
                             f"{limit / (1 << fx.PHASE_FRAC_BITS) * f_s:.6g} Hz): lower --rate")
    return increment


def recording_streams(loop: Loop, *, name: str, range_km: float, num_blades: int,
                      sample_rate_mhz: float, radar: Radar, interpolation: str = "fir",
                      output_gain_db: float = 0.0) -> FarmStreams:
    """The loop as a one-windmill farm's streams, manifest-ready as ``rast stream``'s."""
    f_s = sample_rate_mhz * 1e6
    length = loop.words.size
    rate = float(length / loop.period_s)
    increment = stream_increment(rate, sample_rate_mhz, interpolation)
    windmill = Windmill(name=name, range_km=range_km, num_blades=num_blades,
                        rpm=60.0 / (loop.period_s * num_blades), stream_rate=rate)
    farm = Farm(sample_rate_mhz, radar, (windmill,), None, 2.0, output_gain_db, interpolation)
    plan = StreamPlan(length, rate, loop.period_s, increment, occupied_doppler_hz(loop))
    i, q, scale, snr = quantise(loop.words, interpolation=interpolation)
    stream = WindmillStream(windmill, plan, loop.words, i, q, scale, snr,
                            delay_samples=delay_samples(range_km, f_s), relative_amplitude=1.0)
    # one windmill: the loudest, its peak at output_gain_db (as build_farm_streams)
    stream.gain = 10 ** (output_gain_db / 20.0)
    stream.gain_word = round(stream.gain * (1 << fx.GAIN_FRAC))
    if stream.gain_word > fx.GAIN.max:
        raise RecordingError(f"the gain {stream.gain:.4g} exceeds the gain register's "
                             f"{fx.GAIN.max / (1 << fx.GAIN_FRAC):.4g}")
    taps = [{"delay_samples": stream.delay_samples, "increment_samples": stream.delay_samples,
             "windmills": [name]}]
    return FarmStreams(farm, [stream], taps)


#: The turbine of the synthetic recordings (examples/make_recording.py, the tests).
SYNTHETIC_TURBINE = dict(name="recorded", range=2.0, num_blades=3, rpm=15, radius=[26.0, 12.0],
                         rsc=[1.0, 0.5], tower_rcs=0.5,
                         rsc_weighting={"angle": [0, 180], "width": 6, "gain_db": 12})


def synthetic_recording(prf_hz=5000.0, seconds=8.0, snr_db=20.0, seed=0, rpm_drift=0.0, **turbine):
    """A recording made by RAST's physics model: the slow-time echo of
    :data:`SYNTHETIC_TURBINE` (``turbine`` overrides its keys) at ``prf_hz``, with
    white noise ``snr_db`` below its mean power (None: none). ``rpm_drift``: the
    rpm changes linearly by this fraction over the recording."""
    from rast.model.physics.farm import parse_config
    from rast.model.physics.turbine import modulation
    farm = parse_config({"sample_rate": 20, "radar_frequency": 5350,
                         "windmill": [dict(SYNTHETIC_TURBINE, **turbine)]})
    t = np.arange(int(round(seconds * prf_hz))) / prf_hz
    warped = t + 0.5 * rpm_drift / seconds * t ** 2     # β = ω0·(t + ½·(drift/T)·t²)
    x = modulation(farm.windmills[0], warped, farm.radar.wavelength_m)
    if snr_db is not None:
        rng = np.random.default_rng(seed)
        sigma = np.sqrt(np.mean(np.abs(x) ** 2) / 10 ** (snr_db / 10) / 2)
        x = x + sigma * (rng.standard_normal(x.size) + 1j * rng.standard_normal(x.size))
    return x
