"""Modulation streams: one seamless period per windmill, quantised for the replay RAM.

A stream holds exactly one period T_sim = 60/(rpm·num_blades) (eq. 2.13) in N
words read at ``stream_rate_hz = N / T_sim``, so the loop has no seam. The rate
is chosen per windmill:

* automatic: N = ceil(oversampling · max_doppler · T_sim) (at least
  ``MIN_STREAM_WORDS``), so the rate is at least ``oversampling`` × the largest
  Doppler of that windmill;
* forced (``stream_rate`` in Hz): N = round(stream_rate · T_sim), the rate then
  moved to N / T_sim so the loop stays seamless;
* ``"rts"``, the seed's mode: one word per RTS sample, N = round(T_sim ·
  sample_rate). The replayed period is N / sample_rate, which differs from
  T_sim by less than half an RTS sample; the samples are taken over exactly
  one period, so the loop is still seamless and the rotation speed is off by
  less than 1/(2N) (reported as ``rpm_replayed``).

The replay block steps its RAM address by ``phase_increment / 2**32`` words per
RTS sample and takes increments below 2**32; one word per sample is therefore
``2**32 − 1``: one extra held sample every 2**32 samples (215 s at 20 MHz), a
rate error of 2.3e-10, far below the rounding of the period itself.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import threading
from dataclasses import dataclass

import numpy as np

from rast.model.contract import fixedpoint as fx
from rast.model.physics.config import SPEED_OF_LIGHT_M_S, ConfigError, Farm, Windmill
from rast.model.physics.sharing import (Share, candidate_groups, pool_words_shared, region_layout,
                                       shared_replay_sfdr, word_offset, words_if_shared, GUARD_BINS)
from rast.model.physics.synthesis import ComputePool, Synthesis, synthesise_period
from rast.model.physics.turbine import max_doppler_hz
from rast.model.contract.regmap import stream_crc32
from rast.model.contract.scan import azimuth_code, pattern_words, scan_settings
from rast.model.contract.follow import follow_pattern

__all__ = ["MIN_STREAM_WORDS", "MAX_STREAM_WORDS", "StreamPlan", "WindmillStream", "FarmStreams", "EchoSum",
           "plan_stream", "stream_times", "quantise", "quantise_words", "build_farm_streams",
           "delay_samples", "farm_for_build"]

MIN_STREAM_WORDS = 16
#: Most words one stream may have: 2**28 words are 1 GiB of packed words and
#: 4 GiB of the complex period they are made from (the seed's mode at 15 rpm
#: and 20 MS/s is 26.7 M words); beyond it ``rast stream`` refuses before
#: allocating and says how many words were asked for.
MAX_STREAM_WORDS = 1 << 28
#: Samples quantised at a time (bounds the temporaries; one task of the pool).
_QUANTISE_BLOCK = 1 << 20
#: A windmill of at least this many words is computed with every core; shorter
#: ones are computed side by side, one per core.
_PARALLEL_WITHIN = 1 << 20


@dataclass(frozen=True)
class StreamPlan:
    """How one windmill's period is sampled."""
    length: int               # N, stream words in one period
    stream_rate_hz: float     # words per second as replayed
    period_s: float           # replayed period, N / stream_rate_hz
    phase_increment: int      # RAM address step per RTS sample, in 2**-PHASE_FRAC_BITS words
    max_doppler_hz: float


def plan_stream(windmill: Windmill, farm: Farm) -> StreamPlan:
    """Choose N and the stream rate for one windmill (see the module docstring)."""
    t_sim = windmill.period_s
    f_max = max_doppler_hz(windmill, farm.radar.wavelength_m)
    f_s = farm.sample_rate_hz
    max_increment = (1 << fx.PHASE_FRAC_BITS) - 1
    if windmill.stream_rate == "rts":
        length = max(1, round(t_sim * f_s))
        return StreamPlan(length, f_s, length / f_s, max_increment, f_max)
    if windmill.stream_rate is None:
        length = max(MIN_STREAM_WORDS, math.ceil(farm.stream_oversampling * f_max * t_sim))
    else:
        length = max(1, round(windmill.stream_rate * t_sim))
    rate = length / t_sim
    increment = min(max_increment, round(rate / f_s * (1 << fx.PHASE_FRAC_BITS)))
    return StreamPlan(length, rate, t_sim, increment, f_max)


def stream_times(plan: StreamPlan, windmill: Windmill) -> np.ndarray:
    """The N sample instants of one period, t_n = n·T_sim/N (seconds)."""
    return np.arange(plan.length) * (windmill.period_s / plan.length)


@functools.lru_cache(maxsize=1)
def _fir_taps() -> np.ndarray:
    """The FIR's integer coefficients (computed once: the farm's every windmill checks them)."""
    taps = np.array(fx.fir_coefficients(), dtype=np.int64)
    taps.flags.writeable = False
    return taps


def _fir_peak(i: np.ndarray, q: np.ndarray, limit: int) -> float:
    """Largest |I| or |Q| of the FIR interpolator's intermediate values before
    their saturation (in word units): the continuous signal between the words
    may overshoot the words' own peak.

    Exact wherever it exceeds ``limit``; where a bound (the taps' largest word
    times the largest Σ|c| of a phase) shows an output cannot exceed ``limit``,
    it is not computed, and a result ≤ ``limit`` only says so.
    """
    c = _fir_taps()
    L = len(i)
    # Output n of every phase reads the words (n + FIR_LEAD − k) mod L, k = 0 … FIR_TAPS − 1.
    start = (fx.FIR_LEAD - fx.FIR_TAPS + 1) % L
    largest = np.maximum(np.abs(i), np.abs(q))
    ring = np.take(largest, np.arange(start, start + L + fx.FIR_TAPS - 1) % L)
    window_max = ring[:L].copy()                  # max over the FIR_TAPS words of output n
    for k in range(1, fx.FIR_TAPS):
        np.maximum(window_max, ring[k:k + L], out=window_max)
    bound = fx.round_half_up(window_max * int(np.abs(c).sum(axis=1).max()), fx.FIR_COEF_FRAC)
    n = np.flatnonzero(bound > limit)
    if n.size == 0:
        return 0.0
    taps = (n[:, None] + fx.FIR_LEAD - np.arange(fx.FIR_TAPS)[None, :]) % L
    # Integer sums in float64 (BLAS): |word·c| < 2**33, ten of them < 2**37, every
    # partial sum exact in a 53-bit mantissa.
    acc = np.stack([i, q]).astype(np.float64)[:, taps] @ c.T.astype(np.float64)
    return float(np.abs(fx.round_half_up(acc.astype(np.int64), fx.FIR_COEF_FRAC)).max())


_scratch = threading.local()


def _quantise_block(period: np.ndarray, pairs: np.ndarray, block: slice, scale: float,
                    fmt: fx.Format, in_range: bool) -> tuple[float, float, float, float]:
    """Round ``period[block]·scale`` into the I and Q columns of ``pairs`` (int16 pairs);
    returns Σx² and Σ(x − word)² of I, then of Q (x the scaled value). ``in_range``:
    every rounded value is known to fit the words, so none is clipped."""
    size = block.stop - block.start
    if getattr(_scratch, "size", 0) < size:
        _scratch.scaled, _scratch.rounded, _scratch.size = np.empty(size), np.empty(size), size
    x = _scratch.scaled[:size]
    sums = []
    for part, column in ((period.real[block], 0), (period.imag[block], 1)):
        words = pairs[block, column]
        np.multiply(part, scale, out=x)
        sums.append(float(np.einsum("i,i->", x, x)))   # (not BLAS: its threads cost more than the sum here)
        if in_range:                                    # rounded (half to even) straight into the words
            np.rint(x, out=words, casting="unsafe")
            np.subtract(x, words, out=x)
        else:
            r = _scratch.rounded[:size]
            np.rint(x, out=r)
            np.clip(r, fmt.min, fmt.max, out=r)
            np.copyto(words, r, casting="unsafe")       # whole numbers in range: exact
            x -= r
        sums.append(float(np.einsum("i,i->", x, x)))
    return tuple(sums)


def _peak(period: np.ndarray, pool: ComputePool) -> float:
    """max(|Re|, |Im|) over a contiguous period, in blocks on the pool: the largest and
    smallest of its float64 view, read in cache-sized pieces (no temporaries)."""
    flat = period.view(np.float64)
    piece = 1 << 16

    def one(start):
        best = 0.0
        for k in range(start, min(flat.size, start + 2 * _QUANTISE_BLOCK), piece):
            part = flat[k:k + piece]
            best = max(best, float(part.max()), -float(part.min()))
        return best
    starts = range(0, flat.size, 2 * _QUANTISE_BLOCK)
    return max((f.result() for f in [pool.submit(one, k) for k in starts]), default=0.0)


def quantise_words(period: np.ndarray, fmt: fx.Format = fx.STREAM, interpolation: str = "hold",
                   *, pool: ComputePool | None = None, emit=None):
    """:func:`quantise`, the words packed as they are stored: little-endian uint32,
    I in the low half (``fixedpoint.pack_iq``). Returns ``(words, scale, snr_db)``.

    The blocks are rounded on ``pool`` (default: every core); ``emit(start, words)``
    is called, in order, as ``words[start:start + len(words)]`` becomes final.
    """
    if pool is None:
        with ComputePool() as pool:
            return quantise_words(period, fmt, interpolation, pool=pool, emit=emit)
    period = np.ascontiguousarray(period, dtype=complex).reshape(-1)
    peak = _peak(period, pool)
    scale = fmt.max / peak if peak > 0 else 1.0
    words = np.empty(period.size, dtype="<u4")
    pairs = words.view("<i2").reshape(-1, 2)          # (I, Q) of each word
    blocks = [slice(s, min(period.size, s + _QUANTISE_BLOCK)) for s in range(0, period.size, _QUANTISE_BLOCK)]
    checked = interpolation == "fir" and peak > 0     # the FIR's headroom may ask to scale again
    while True:
        # |x| ≤ peak·scale (rounding is monotonic): below fmt.max + ½, no word needs clipping.
        in_range = peak * scale < fmt.max + 0.5 and -peak * scale > fmt.min - 0.5
        futures = [pool.submit(_quantise_block, period, pairs, b, scale, fmt, in_range) for b in blocks]
        error = signal = 0.0
        for block, future in zip(blocks, futures):
            signal_i, error_i, signal_q, error_q = future.result()
            signal += signal_i                        # summed in the order of one pass over
            error += error_i                          # the blocks, I then Q: the same
            signal += signal_q                        # figures on any number of cores
            error += error_q
            if emit and not checked:
                emit(block.start, words[block])
        if not checked:
            break
        over = _fir_peak(pairs[:, 0].astype(np.int64), pairs[:, 1].astype(np.int64), fmt.max)
        if over <= fmt.max:
            if emit:
                for block in blocks:
                    emit(block.start, words[block])
            break
        scale *= (fmt.max - 1) / over
    snr_db = 10 * np.log10(signal / error) if error > 0 else math.inf
    return words, scale, float(snr_db)


def quantise(period: np.ndarray, fmt: fx.Format = fx.STREAM, interpolation: str = "hold"):
    """Scale a complex period to the full signed word range and round.

    With ``interpolation="fir"`` the scale leaves the headroom the
    interpolator's overshoot between words needs, so that its intermediate
    values never saturate (checked on the quantised words).
    Returns ``(i, q, scale, snr_db)``: integer I and Q (int64), the scale
    (word units per unit of modulation) and the quantisation SNR in dB.
    """
    words, scale, snr_db = quantise_words(period, fmt, interpolation)
    pairs = words.view("<i2").reshape(-1, 2)
    return (pairs[:, 0].astype(np.int64).reshape(np.shape(period)),
            pairs[:, 1].astype(np.int64).reshape(np.shape(period)), scale, snr_db)


def delay_samples(range_km: float, sample_rate_hz: float) -> int:
    """Round-trip delay 2R/c in RTS samples (seed section 2.6)."""
    return round(2 * range_km * 1e3 / SPEED_OF_LIGHT_M_S * sample_rate_hz)


@dataclass
class WindmillStream:
    windmill: Windmill
    plan: StreamPlan
    period: np.ndarray        # complex128, unquantised m(t_n)
    i: np.ndarray             # int64 words
    q: np.ndarray
    scale: float
    snr_db: float
    delay_samples: int
    relative_amplitude: float  # K_l / K_nearest = (R_nearest / R_l)² (eq. 2.6, 2.24)
    #: Set when the windmill plays a stream shared with others (rast.model.physics.sharing).
    share: Share | None = None
    gain: float = 0.0
    gain_word: int = 0
    tap: int = 0
    synthesis: Synthesis | None = None   # how the period was made (rast.model.physics.synthesis)
    # The words as stored (little-endian uint32, I low); when set, ``i`` and ``q``
    # are int16 views of it (build_farm_streams: no second copy of 26.7 M words).
    packed: np.ndarray | None = None

    @property
    def words(self) -> np.ndarray:
        if self.packed is not None:
            return self.packed.astype(np.int64)
        return fx.pack_iq(self.i, self.q)

    def words_u32(self) -> np.ndarray:
        """The same words as uint32, in blocks (the file writers' form: half the memory)."""
        if self.packed is not None:
            return self.packed
        out = np.empty(self.i.shape, dtype=np.uint32)
        for start in range(0, out.size, _QUANTISE_BLOCK):
            block = slice(start, start + _QUANTISE_BLOCK)
            out[block] = fx.pack_iq(self.i[block], self.q[block])
        return out


@dataclass(frozen=True)
class EchoSum:
    """The loudest output one RTS sample can hold: the sum of the echo peaks of
    every channel whose delayed pulse covers it, for a full-scale pulse.

    A pulse of ``pulse_samples`` leaves channel l's echo in the output from
    ``d_l`` to ``d_l + pulse_samples − 1`` (seed eq. 2.3); echoes whose delays
    lie closer than a pulse overlap, and the block adds them before it
    saturates (``datapath.channel_sum``). With an input of magnitude 1 (a
    complex tone reaching full scale on I and Q), channel l's output is at
    most ``g_l·|w_l|`` of full scale on either component (g_l the gain word
    over 2**GAIN_FRAC, |w_l| its largest word's magnitude over 2**STREAM.frac): the
    sum of those over the overlapping channels bounds the output, reached
    when their phases line up. Above 1.0 (0 dBFS) the output can clip.
    """
    level: float                    # fraction of output full scale
    delay_samples: int              # the nearest of the channels that add up there
    pulse_samples: int
    windmills: tuple[str, ...]

    @property
    def level_dbfs(self) -> float:
        return 20 * math.log10(self.level) if self.level > 0 else -math.inf

    @property
    def clips(self) -> bool:
        """Over full scale by more than the rounding of the loudest gain (which
        ``output_gain_db`` = 0 puts at full scale exactly)."""
        return self.level_dbfs >= 0.05

    def describe(self) -> str:
        n = len(self.windmills)
        where = f"{n} echoes within one {self.pulse_samples}-sample pulse from delay {self.delay_samples}" \
            if n > 1 else f"one echo at delay {self.delay_samples}"
        text = f"loudest echo sum for a full-scale pulse: {round(self.level_dbfs, 1) + 0.0:+.1f} dBFS ({where})"
        if self.clips:
            text += (f": they saturate the output where they line up; keep the radar's pulse under "
                     f"{-self.level_dbfs:.1f} dBFS, or lower output_gain_db by {self.level_dbfs:.1f} dB")
        return text


@dataclass
class FarmStreams:
    farm: Farm
    streams: list[WindmillStream]   # sorted by range, nearest first: the channel order
    taps: list[dict]
    #: What the block will play otherwise than the config says, one line per
    #: windmill (a gain that rounds to 0); ``rast stream`` prints them.
    warnings: list[str] = dataclasses.field(default_factory=list)
    #: ``(windmill, stream, sfdr_db, doppler_error_hz)`` of each windmill that
    #: would have shared a stream by aspect but failed its checks
    #: (``rast.model.physics.sharing``): it plays its own stream.
    refused_shares: list[tuple] = dataclasses.field(default_factory=list)

    @property
    def pool_words(self) -> int:
        """Stream pool words these streams take together (a shared region once)."""
        return _pool_words(self.streams)

    def sharing_summary(self) -> str | None:
        """What sharing saved, in words and in fidelity, or would save without
        touching an echo when it is off, for ``rast stream``; None when
        nothing is or would be shared."""
        shared = [s for s in self.streams if s.share is not None]
        if not shared:
            if self.farm.sharing.enabled:
                return ("shared streams: none (no two windmills differ only by their start and rotor angles"
                        + (f" within {self.farm.sharing.aspect_tolerance_deg:g} deg" if
                           self.farm.sharing.aspect_tolerance_deg else "") + ")" + self._refused_text())
            lengths = [s.plan.length for s in self.streams]
            words = words_if_shared(dataclasses.replace(self.farm, windmills=tuple(s.windmill for s in self.streams)),
                                    lengths)
            if words >= sum(lengths):
                return None
            return (f"share_streams = true would hold these streams in {words:,} pool words instead of "
                    f"{sum(lengths):,}: windmills that differ only by their blades' start angle")
        unshared = sum(plan_stream(s.windmill, self.farm).length for s in self.streams)   # each its own
        regions = len({s.share.stream for s in shared})
        start = max(abs(s.share.start_error_deg) for s in shared)
        text = (f"shared streams: {len(shared)} windmills play {regions} stream(s); the pool holds "
                f"{self.pool_words:,} words instead of {unshared:,} (saved {unshared - self.pool_words:,}, "
                f"{100 * (unshared - self.pool_words) / unshared:.1f} %); start angles rounded to the "
                f"streams' word grids by at most {start:.3g} deg")
        by_aspect = [s for s in shared if s.share.sfdr_db is not None]
        if by_aspect:
            worst = min(by_aspect, key=lambda s: s.share.sfdr_db)
            text += (f"; {len(by_aspect)} by aspect (up to {max(abs(s.share.aspect_error_deg) for s in by_aspect):.3g} "
                     f"deg apart, maximum Doppler off by up to "
                     f"{max(abs(s.share.doppler_error_hz) for s in by_aspect):.3g} Hz), worst replay SFDR "
                     f"{worst.share.sfdr_db:.1f} dB ({worst.windmill.name!r}, at least "
                     f"{self.farm.sharing.min_sfdr_db:g} dB asked)")
        return text + self._refused_text()

    def _refused_text(self) -> str:
        if not self.refused_shares:
            return ""
        guard = GUARD_BINS / (self.farm.radar.cpi_ms * 1e-3)
        # NaN (nothing outside the band to measure) first: the worst is what could not be measured
        name, stream, sfdr_db, doppler = min(self.refused_shares,
                                             key=lambda r: (-math.inf if math.isnan(r[2]) else r[2], -abs(r[3])))
        sfdr = ("no SFDR measurable, the stream's band holds nothing outside the windmill's: "
                "raise stream_oversampling" if math.isnan(sfdr_db) else f"{sfdr_db:.1f} dB")
        return (f"; {len(self.refused_shares)} kept their own stream (an aspect-shared stream must keep "
                f"{self.farm.sharing.min_sfdr_db:g} dB of SFDR and its maximum Doppler within {guard:.3g} Hz; "
                f"worst {name!r} on {stream!r}'s: {sfdr}, {doppler:+.3g} Hz)")

    def smallest_contract(self, channels: int | None = None) -> fx.ReplayContract:
        """The smallest replay block that holds these streams (all of them in
        the pool at once; delay RAM depths are powers of two), at the farm's
        sample rate and interpolation: the common delay reaches the nearest
        windmill, the window the farm's depth."""
        ch = self.manifest()["registers"]["channels"]
        delays = [c["delay_samples"] for c in ch]
        return fx.ReplayContract(
            channels=channels or len(ch),
            pool_words=fx.pool_words_for(self.pool_words),
            max_delay=fx.delay_depth(min(delays)) - 2,
            max_tap=max(2, fx.delay_depth(max(delays) - min(delays)) - 2),
            interpolation=self.farm.interpolation, sample_rate_hz=round(self.farm.sample_rate_hz),
            scan=self.farm.scan.turning)

    def echo_sum(self, pulse_samples: int | None = None) -> EchoSum:
        """The loudest sum of overlapping echoes (:class:`EchoSum`) for pulses of
        ``pulse_samples`` (default: the radar's pulse width at the sample rate)."""
        if pulse_samples is None:
            pulse_samples = max(1, round(self.farm.radar.pulse_width_us * self.farm.sample_rate_mhz))
        def largest_word(s):            # |w|, in blocks: a seed-mode stream holds 26.7 M words
            top = 0
            for start in range(0, s.i.size, _QUANTISE_BLOCK):
                i, q = (v[start:start + _QUANTISE_BLOCK].astype(np.int64) for v in (s.i, s.q))
                top = max(top, int(np.max(i * i + q * q)))
            return math.sqrt(top) / (1 << fx.STREAM.frac)

        delays = np.array([s.delay_samples for s in self.streams], dtype=np.int64)
        peaks = np.array([s.gain_word / (1 << fx.GAIN_FRAC) * largest_word(s) for s in self.streams])
        # The loudest window starts at some channel's delay: sum those up to a pulse later.
        order = np.argsort(delays, kind="stable")
        delays, peaks = delays[order], peaks[order]
        ends = np.searchsorted(delays, delays + pulse_samples, side="left")
        sums = np.concatenate([[0.0], np.cumsum(peaks)])
        k = int(np.argmax(sums[ends] - sums[:delays.size]))
        return EchoSum(float(sums[ends[k]] - sums[k]), int(delays[k]), int(pulse_samples),
                       tuple(self.streams[j].windmill.name for j in order[k:ends[k]]))

    def manifest(self, file_names: dict[str, dict[str, str]] | None = None) -> dict:
        """The farm's manifest: per windmill its stream, delay and gain, and register values."""
        farm = self.farm
        windmills = []
        for s in self.streams:
            w = s.windmill
            entry = {
                "name": w.name,
                **(file_names or {}).get(w.name, {}),
                "range_km": w.range_km,
                "rpm": w.rpm,
                "rpm_replayed": w.rpm * w.period_s / s.plan.period_s,
                "num_blades": w.num_blades,
                "length": s.plan.length,
                "stream_rate_hz": s.plan.stream_rate_hz,
                "period_s": s.plan.period_s,
                "max_doppler_hz": s.plan.max_doppler_hz,
                "phase_increment": s.plan.phase_increment,
                # what the block plays: the increment it steps by, in words per
                # second, and the period that makes
                "played_stream_rate_hz": s.plan.phase_increment / (1 << fx.PHASE_FRAC_BITS) * farm.sample_rate_hz,
                "played_period_s": s.plan.length * (1 << fx.PHASE_FRAC_BITS) / s.plan.phase_increment
                / farm.sample_rate_hz,
                # what the block checks a switch against (CH[l].CRC), and the
                # loaders check the stream file against
                "crc32": stream_crc32(s.words_u32()),
                "delay_samples": s.delay_samples,
                "tap": s.tap,
                "relative_amplitude": s.relative_amplitude,
                "gain": s.gain,
                "gain_word": s.gain_word,
                "scale": s.scale,
                "snr_db": s.snr_db,
            }
            if s.share is not None:          # plays a stream shared with alike windmills
                entry["shared"] = {"stream": s.share.stream, "offset_words": s.share.offset_words,
                                   "start_error_deg": s.share.start_error_deg,
                                   "aspect_error_deg": s.share.aspect_error_deg,
                                   "doppler_error_hz": s.share.doppler_error_hz,
                                   **({"sfdr_db": s.share.sfdr_db} if s.share.sfdr_db is not None else {})}
            if w.range_cell is not None:     # one delay tap of a range-extended turbine
                entry["range_cell"] = {"turbine": w.range_cell.turbine,
                                       "hub_range_km": w.range_cell.hub_range_km,
                                       "tap": w.range_cell.index, "taps": w.range_cell.count}
            windmills.append(entry)
        channels = []
        for s in self.streams:
            channels.append({
                "windmill": s.windmill.name,
                "enable": 1,
                "length": s.plan.length,
                "phase_increment": s.plan.phase_increment,
                # what the block plays: the increment it steps by, in words per
                # second, and the period that makes
                "played_stream_rate_hz": s.plan.phase_increment / (1 << fx.PHASE_FRAC_BITS) * farm.sample_rate_hz,
                "played_period_s": s.plan.length * (1 << fx.PHASE_FRAC_BITS) / s.plan.phase_increment
                / farm.sample_rate_hz,
                "gain": s.gain_word,
                "delay_samples": s.delay_samples,
                # the turbine's azimuth code (AZIMUTH) where the antenna turns
                **({"azimuth": int(azimuth_code(s.windmill.azimuth_deg))} if farm.scan.turning else {}),
                # a shared stream: its words lie `offset` words into the
                # region of `words` words that holds `stream`'s period
                # (rast.model.contract.loadplan.pool_layout)
                **({"pool_region": {"stream": s.share.stream, "offset": s.share.region_offset,
                                    "words": s.share.region_words}} if s.share is not None else {}),
            })
        scan = {}
        if farm.scan.turning:
            sc = farm.scan
            scan = {"scan": {"scan_mode": sc.mode, "scan_rpm": sc.rpm, "scan_start_deg": sc.start_deg,
                             "acp_per_rev": sc.acp_per_rev, "beamwidth_deg": sc.beamwidth_deg,
                             "sidelobe_db": sc.sidelobe_db,
                             **scan_settings(sc, farm.sample_rate_hz)}}
            # a board whose channels follow the beam loads the pattern with the
            # entries at or below assign_below_db at 0 (rast.model.contract.follow)
            try:
                window = follow_pattern(sc, pattern_words(sc))
            except ValueError:
                window = None
            if window is not None:
                scan["follow"] = {"assign_below_db": sc.assign_below_db, "lo": window.lo, "hi": window.hi,
                                  "words": [int(w) for w in window.table.words]}
        return {
            "format": "rast-manifest/2",
            "sample_rate_hz": farm.sample_rate_hz,
            "radar_frequency_hz": farm.radar.frequency_mhz * 1e6,
            "radar": {"prf_hz": farm.radar.prf_hz, "pulse_width_us": farm.radar.pulse_width_us,
                      "cpi_ms": farm.radar.cpi_ms},
            "ram_depth": farm.ram_depth,
            "interpolation": farm.interpolation,
            "fixed_point": {"stream_width": fx.STREAM_WIDTH, "gain_width": fx.GAIN_WIDTH,
                            "gain_frac": fx.GAIN_FRAC, "phase_frac_bits": fx.PHASE_FRAC_BITS},
            # Range calibration (RTS samples): the converters' latencies from the
            # config. Loading into a board subtracts them and the board's own
            # latency (the build's: its slots and pipeline) from the common delay
            # (rast.model.contract.loadplan.manifest_to_register_writes, target "board").
            "calibration": {"adc_latency_samples": farm.adc_latency,
                            "dac_latency_samples": farm.dac_latency},
            "windmills": windmills,
            "taps": self.taps,
            "registers": {"channels": channels},
            **scan,
        }


def farm_for_build(farm: Farm, contract: fx.ReplayContract) -> Farm:
    """``farm`` sized for the replay block ``contract`` describes: its stream
    depth becomes ``ram_depth``, its interpolation the farm's. Raises
    :class:`ConfigError` when the config's sample rate is not the build's,
    the farm has more windmills than the block has channels, or its antenna
    turns and the block has no scan."""
    problems = []
    if contract.sample_rate_hz and round(farm.sample_rate_hz) != contract.sample_rate_hz:
        problems.append(f"'sample_rate' is {farm.sample_rate_mhz:g} MHz but the build replays at "
                        f"{contract.sample_rate_hz / 1e6:g} MHz (sample_rate_hz "
                        f"{contract.sample_rate_hz}): the streams would be made for the wrong rate and "
                        f"{fx.rate_mismatch(farm.sample_rate_hz, contract.sample_rate_hz)}; set "
                        f"sample_rate = {contract.sample_rate_hz / 1e6:g} or build for "
                        f"{farm.sample_rate_mhz:g} MHz")
    if contract.follow_rows:
        # channels that follow the beam: a row per windmill; the channels the
        # scene needs at once are checked by the plan (beam_window.farm_follow_plan)
        if len(farm.windmills) > contract.follow_rows:
            problems.append(f"the farm has {len(farm.windmills)} windmills but the build's turbine table "
                            f"holds {contract.follow_rows} rows")
        if not farm.scan.turning:
            problems.append("the build's channels follow the beam but 'scan_mode' is \"stare\": set "
                            "scan_mode = \"free\" or \"acp\"")
    elif len(farm.windmills) > contract.channels:
        problems.append(f"the farm has {len(farm.windmills)} windmills but the build has "
                        f"{contract.channels} channels")
    if farm.scan.turning and not contract.scan:
        problems.append(f"'scan_mode' is {farm.scan.mode!r} but the build has no antenna scan: build it "
                        "with --scan (or set scan_mode = \"stare\")")
    if problems:
        raise ConfigError(problems)
    return dataclasses.replace(farm, ram_depth=contract.pool_words,
                               interpolation=contract.interpolation)


def _pool_words(streams) -> int:
    """Stream pool words of ``streams`` together, a shared region once."""
    regions = {s.share.stream: s.share.region_words for s in streams if s.share is not None}
    return sum(s.plan.length for s in streams if s.share is None) + sum(regions.values())


def _sharing_hint(farm: Farm, lengths, shared: bool) -> str:
    """How many words ``share_streams = true`` would save, when it would."""
    if shared:
        return ""
    words = words_if_shared(farm, lengths)
    return "" if words >= sum(lengths) else f", or set share_streams = true (then {words} words)"


def _share_streams(farm: Farm, groups, offsets, streams, sink, own, nearest_km) -> tuple[list, list]:
    """Fill in the groups' members (their first windmill's words, rolled to
    their start word) and every member's :class:`Share`; a member whose rotor
    angle differs from the stream's and whose replay SFDR, measured, falls
    under ``share_min_sfdr_db``, or whose maximum Doppler lies more than
    GUARD_BINS Doppler bins from the stream's, gets its own stream
    (``own(k)``). Returns the groups that still share and ``(windmill,
    stream, sfdr_db, doppler_error_hz)`` of each member refused."""
    kept, refused = [], []
    for g in groups:
        first = streams[g[0]]
        plan = first.plan
        taken, sfdr_of = [g[0]], {}
        doppler_error = {k: plan.max_doppler_hz - max_doppler_hz(farm.windmills[k], farm.radar.wavelength_m)
                         for k in g}
        for k in g[1:]:
            w = farm.windmills[k]
            packed = np.roll(first.packed, -offsets[k][0])
            if w.rotor_angle_deg != first.windmill.rotor_angle_deg:
                cpi_s = farm.radar.cpi_ms * 1e-3
                sfdr_of[k] = shared_replay_sfdr(plan.max_doppler_hz - doppler_error[k], packed,
                                                plan.stream_rate_hz, cpi_s)
                # (NaN, nothing outside the band to measure, is not at least the minimum)
                if not sfdr_of[k] >= farm.sharing.min_sfdr_db or abs(doppler_error[k]) > GUARD_BINS / cpi_s:
                    refused.append((w.name, first.windmill.name, sfdr_of[k], doppler_error[k]))
                    streams[k] = own(k)
                    continue
            period = np.roll(first.period, -offsets[k][0])
            if sink:
                sink.start(w, plan.length)
                sink.period(w, 0, period)
                sink.words(w, 0, packed)
            pairs = packed.view("<i2").reshape(-1, 2)
            streams[k] = WindmillStream(
                w, plan, period, pairs[:, 0], pairs[:, 1], first.scale, first.snr_db,
                delay_samples=delay_samples(w.range_km, farm.sample_rate_hz),
                relative_amplitude=(nearest_km / w.echo_range_km) ** 2,
                synthesis=first.synthesis, packed=packed)
            taken.append(k)
        if len(taken) < 2:
            continue
        _, rel, words = region_layout([offsets[k][0] for k in taken], plan.length)
        for k, r in zip(taken, rel):
            w = farm.windmills[k]
            streams[k].share = Share(first.windmill.name, offsets[k][0], r, words, offsets[k][1],
                                     first.windmill.rotor_angle_deg - w.rotor_angle_deg, doppler_error[k],
                                     sfdr_of.get(k))
        kept.append(taken)
    return kept, refused


def build_farm_streams(farm: Farm, *, check_ram_depth: bool = True, progress=None,
                       sink=None) -> FarmStreams:
    """Compute every windmill's period, quantise it, and derive delays, taps and gains.

    The periods come from :func:`rast.model.physics.synthesis.synthesise_period` (grid
    interpolation where the stream oversamples its band, else direct), on every
    core: a long stream in pieces, short ones side by side.
    ``progress(name, done, total)`` is called as each windmill's samples are made.
    ``sink``, when given, receives each windmill's results as they become final,
    for writing them while the rest is computed (``rast.model.files.ramfiles.make_farm_files``):
    ``sink.start(windmill, length)``, then ``sink.period(windmill, start, values)``
    and ``sink.words(windmill, start, words)`` for pieces of the complex128 period
    and of the packed words; calls for different windmills may come from different
    threads at once.

    Raises :class:`ConfigError` (naming the windmill) when a stream does not
    fit ``ram_depth`` (the build's stream pool: each stream, and all of them
    together) or a gain does not fit the gain register.
    """
    problems = []
    plans = [plan_stream(w, farm) for w in farm.windmills]
    # Shared streams (rast.model.physics.sharing): a group's members play its
    # first windmill's plan, from their own start word.
    groups = candidate_groups(farm) if farm.sharing.enabled else []
    offsets = {}
    for g in groups:
        for k in g:
            plans[k] = plans[g[0]]
            offsets[k] = word_offset(farm.windmills[k], farm.windmills[g[0]], plans[k].length)
    for w, plan in zip(farm.windmills, plans):
        if plan.length > MAX_STREAM_WORDS:
            problems.append(f"windmill '{w.name}': its stream needs {plan.length:,} words (one period of "
                            f"{plan.period_s:.4g} s at {plan.stream_rate_hz:.6g} Hz), more than the "
                            f"{MAX_STREAM_WORDS:,} RAST makes: raise 'rpm' or lower the stream rate")
        elif w.stream_rate not in (None, "rts") and w.stream_rate > farm.sample_rate_hz:
            problems.append(f"windmill '{w.name}': 'stream_rate' ({w.stream_rate:g} Hz) must not "
                            f"exceed the RTS sample rate ({farm.sample_rate_hz:g} Hz)")
        elif w.stream_rate is None and plan.stream_rate_hz > farm.sample_rate_hz:
            problems.append(
                f"windmill '{w.name}': its automatic stream rate {plan.stream_rate_hz:.6g} Hz "
                f"({farm.stream_oversampling:g} x its {plan.max_doppler_hz:.6g} Hz maximum Doppler) "
                f"exceeds the RTS sample rate ({farm.sample_rate_hz:g} Hz), which the block cannot "
                f"play: set stream_rate = \"rts\" (one word per sample) or lower 'stream_oversampling'")
        elif plan.phase_increment == 0:
            problems.append(
                f"windmill '{w.name}': its stream rate {plan.stream_rate_hz:.6g} Hz is below the "
                f"block's step of {farm.sample_rate_hz / (1 << fx.PHASE_FRAC_BITS):.3g} Hz: the "
                f"phase increment rounds to 0 and the stream would never move; raise 'rpm' or the "
                f"stream rate")
        elif farm.interpolation == "fir" and plan.phase_increment > fx.FIR_MAX_INCREMENT:
            limit = fx.FIR_MAX_INCREMENT / (1 << fx.PHASE_FRAC_BITS) * farm.sample_rate_hz
            problems.append(
                f"windmill '{w.name}': its stream rate {plan.stream_rate_hz:.6g} Hz exceeds the FIR "
                f"interpolator's {limit:.6g} Hz (sample rate / "
                f"{(1 << fx.PHASE_FRAC_BITS) / fx.FIR_MAX_INCREMENT:.0f}): lower 'stream_rate' or "
                f"'stream_oversampling', or raise 'sample_rate'")
        elif check_ram_depth and farm.ram_depth is not None and plan.length > farm.ram_depth:
            problems.append(
                f"windmill '{w.name}': its stream needs {plan.length} words (one period of "
                f"{plan.period_s:.4g} s at {plan.stream_rate_hz:.6g} Hz) but 'ram_depth' is "
                f"{farm.ram_depth}: lower 'stream_oversampling' or 'stream_rate', or raise 'ram_depth'")
    lengths = [max(p.length, fx.min_stream_length(farm.interpolation)) for p in plans]

    def check_pool(total, shared):
        if check_ram_depth and farm.ram_depth is not None and not problems and total > farm.ram_depth:
            problems.append(
                f"the streams need {total} words together{' (shared)' if shared else ''} but 'ram_depth' "
                f"(the stream pool of the build) is {farm.ram_depth}: lower 'stream_oversampling' or "
                f"'stream_rate', or raise 'ram_depth'" + _sharing_hint(farm, lengths, shared))
        if problems:
            raise ConfigError(problems)

    # (before any synthesis: the most the groups can save)
    check_pool(pool_words_shared(lengths, groups, {k: o for k, (o, _) in offsets.items()}), bool(groups))

    nearest_km = min(w.echo_range_km for w in farm.windmills)

    def one(w, plan, pool):
        report = (lambda done, total: progress(w.name, done, total)) if progress else None
        if sink:
            sink.start(w, plan.length)
        period, synthesis = synthesise_period(
            w, plan.length, farm.radar.wavelength_m, progress=report, pool=pool,
            emit=(lambda start, values: sink.period(w, start, values)) if sink else None)
        words, scale, snr = quantise_words(
            period, interpolation=farm.interpolation, pool=pool,
            emit=(lambda start, values: sink.words(w, start, values)) if sink else None)
        pairs = words.view("<i2").reshape(-1, 2)
        return WindmillStream(
            w, plan, period, pairs[:, 0], pairs[:, 1], scale, snr,
            delay_samples=delay_samples(w.range_km, farm.sample_rate_hz),
            relative_amplitude=(nearest_km / w.echo_range_km) ** 2, synthesis=synthesis, packed=words)

    # A long stream is computed in pieces on every core, one such windmill at a
    # time; the short ones (a farm at the automatic rate) one per core. A
    # group's members are its first windmill's stream, rolled.
    members = {k for g in groups for k in g[1:]}
    streams = [None] * len(plans)
    with ComputePool() as pool:
        inline = ComputePool(1)
        long = [k for k, p in enumerate(plans)
                if k not in members and (p.length >= _PARALLEL_WITHIN or pool.workers == 1)]
        for k in long:
            streams[k] = one(farm.windmills[k], plans[k], pool)
        short = {k: pool.submit(one, farm.windmills[k], plans[k], inline)
                 for k in range(len(plans)) if streams[k] is None and k not in members}
        for k, future in short.items():
            streams[k] = future.result()
        groups, refused = _share_streams(farm, groups, offsets, streams, sink,
                                         lambda k: one(farm.windmills[k], plan_stream(farm.windmills[k], farm), inline),
                                         nearest_km)
    if groups:
        check_pool(_pool_words(streams), True)
    streams.sort(key=lambda s: (s.delay_samples, s.windmill.range_km))

    # g_l ∝ K_l / scale_l: one stream word of windmill l is worth 1/scale_l of its
    # modulation. The loudest windmill's peak reaches output_gain_db.
    silent = [s.windmill.name for s in streams if not s.packed.any()]
    if silent:
        raise ConfigError([f"windmill '{name}': its echo is identically zero (every scatterer, wire "
                           f"and tower reflects nothing at this geometry): it would play silence"
                           for name in silent])
    per_word = np.array([s.relative_amplitude / s.scale for s in streams])
    level = 10 ** (farm.output_gain_db / 20.0)
    warnings = []
    for s, amplitude in zip(streams, per_word):
        s.gain = float(amplitude / per_word.max() * level)
        s.gain_word = round(s.gain * (1 << fx.GAIN_FRAC))
        if s.gain_word > fx.GAIN.max:
            problems.append(f"windmill '{s.windmill.name}': its gain {s.gain:.4g} exceeds the gain "
                            f"register's {fx.GAIN.max / (1 << fx.GAIN_FRAC):.4g}: lower 'output_gain_db'")
        elif s.gain_word == 0:
            warnings.append(f"windmill '{s.windmill.name}': its gain {s.gain:.3g} rounds to 0 in the "
                            f"{fx.GAIN_WIDTH}-bit gain register (below 2^-{fx.GAIN_FRAC + 1}): the block "
                            f"plays it silent")
    if not problems and all(s.gain_word == 0 for s in streams):
        problems.append(f"'output_gain_db' ({farm.output_gain_db:g} dB) makes every gain word 0: the "
                        f"block would play silence; raise it (the loudest windmill's gain is "
                        f"{max(s.gain for s in streams):.3g})")

    taps = []
    for s in streams:
        if not taps or taps[-1]["delay_samples"] != s.delay_samples:
            taps.append({"delay_samples": s.delay_samples, "windmills": []})
        taps[-1]["windmills"].append(s.windmill.name)
        s.tap = len(taps) - 1
    if problems:
        raise ConfigError(problems)
    return FarmStreams(farm, streams, taps, warnings, refused)
