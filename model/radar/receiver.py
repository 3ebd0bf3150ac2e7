"""A model radar: one sample per pulse at each windmill's range, and the
micro-Doppler spectrogram of seed section 2.2.2 (eq. 2.11, 2.12).

Each windmill l returns ``K_l·Π_l(t)·m_l(t)`` (eq. 2.24), K_l relative to the
nearest windmill (∝ 1/R_l², eq. 2.6). A range bin sampled at ``t_{d,k}`` after
each pulse holds every windmill whose echo is then being received:
``0 ≤ t_{d,k} − t_{d,l} < τ`` (eq. 2.3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rast.model.physics.config import SPEED_OF_LIGHT_M_S, Farm
from rast.model.physics.stream import FarmStreams
from rast.model.physics.turbine import modulation
from rast.model.contract import fixedpoint as fx
from rast.model.contract import scan as sc

__all__ = ["RangeBin", "range_bins", "pulse_times", "receive", "echo_samples", "spectrogram", "Spectrogram", "MAX_PREVIEW_SAMPLES",
           "spectrogram_correlation", "NOISE_SEED", "receiver_noise", "physics_full_scale"]


@dataclass(frozen=True)
class RangeBin:
    range_km: float
    members: tuple[int, ...]     # indices into farm.windmills whose echo is in this bin


#: Most complex samples (pulses x range bins) a preview computes: 2**25 of
#: them, with the spectrogram's frames, are about 2 GB.
MAX_PREVIEW_SAMPLES = 1 << 25


def range_bins(farm: Farm) -> list[RangeBin]:
    """One bin per distinct windmill range, with the windmills eq. 2.3 puts in it."""
    tau_s = farm.radar.pulse_width_us * 1e-6
    ranges = sorted({w.range_km for w in farm.windmills})
    bins = []
    for r in ranges:
        t_k = 2 * r * 1e3 / SPEED_OF_LIGHT_M_S
        members = tuple(i for i, w in enumerate(farm.windmills)
                        if 0 <= t_k - 2 * w.range_km * 1e3 / SPEED_OF_LIGHT_M_S < tau_s)
        bins.append(RangeBin(r, members))
    return bins


def pulse_times(prf_hz: float, duration_s: float) -> np.ndarray:
    return np.arange(int(round(duration_s * prf_hz))) / prf_hz


def _replayed(farm_streams: FarmStreams, index: int, t_s: np.ndarray) -> np.ndarray:
    """What the RTS plays for windmill ``index`` at times t: the stream word
    at the multiplier, under the farm's interpolation, integer for integer as
    the bit-exact model (``stream_words``), times the gain and, with a turning
    antenna, the pattern word of the beam's offset at that sample
    (``rast.model.contract.scan``)."""
    from rast.model.contract.datapath import stream_words
    farm = farm_streams.farm
    s = next(s for s in farm_streams.streams if s.windmill is farm.windmills[index])
    n = np.round(t_s * farm.sample_rate_hz).astype(np.int64)
    # n * increment passes 2**63 after 2**31 samples at one word per sample:
    # reduce n by the phase's period first (exact, Python integers).
    modulus = s.plan.length << fx.PHASE_FRAC_BITS
    period = modulus // math.gcd(modulus, s.plan.phase_increment) if s.plan.phase_increment else 1
    phase = ((n % period) * s.plan.phase_increment) % modulus if period < (1 << 31) else np.array(
        [(int(k) * s.plan.phase_increment) % modulus for k in n], dtype=np.int64)
    wi, wq = stream_words(farm.interpolation, s.words, s.plan.length, phase)
    echo = (wi + 1j * wq) * (s.gain / (1 << (fx.STREAM_WIDTH - 1)))
    if farm.scan.turning:
        table = sc.pattern_words(farm.scan)
        offset = sc.beam_codes(farm.scan, farm.sample_rate_hz, n) - sc.azimuth_code(s.windmill.azimuth_deg)
        echo = echo * (sc.pattern_lookup(table, offset) / sc.PATTERN_ONE)
    return echo


def echo_samples(farm: Farm, t_s: np.ndarray, farm_streams: FarmStreams | None = None):
    """The samples of every range bin at pulse times ``t_s`` (any spacing),
    without noise: each bin the sum of its windmills' echoes (eq. 2.3, 2.24),
    each weighed by the antenna's two-way pattern when it turns. Returns
    ``(bins, samples)``, samples of shape (bins, pulses)."""
    bins = range_bins(farm)
    nearest = min(w.echo_range_km for w in farm.windmills)
    samples = np.zeros((len(bins), np.size(t_s)), dtype=complex)
    for k, b in enumerate(bins):
        for index in b.members:
            w = farm.windmills[index]
            if farm_streams is None:
                samples[k] += ((nearest / w.echo_range_km) ** 2 * modulation(w, t_s, farm.radar.wavelength_m)
                               * farm.scan.amplitude(t_s, w.azimuth_deg))
            else:
                samples[k] += _replayed(farm_streams, index, t_s)
    return bins, samples


def receive(farm: Farm, duration_s: float, farm_streams: FarmStreams | None = None, *,
            noise_seed: int | None = None):
    """Complex samples per pulse in every range bin.

    With ``farm_streams`` the samples are what the RTS replays (quantised,
    interpolated stream words and gains); without, the physics model itself.
    Returns ``(pulse_times_s, bins, samples)`` with samples of shape (bins, pulses).

    With the config's ``noise_dbfs`` every sample gets the receiver's noise
    (:func:`receiver_noise`, seeded by ``noise_seed``, default :data:`NOISE_SEED`:
    the same noise on every run); the physics' samples get it at the level the
    replay would have (:func:`physics_full_scale`), so both see the same SNR.
    """
    t = pulse_times(farm.radar.prf_hz, duration_s)
    bins, samples = echo_samples(farm, t, farm_streams)
    if farm.noise_dbfs is not None:
        unit = 1.0 if farm_streams is not None else 1.0 / physics_full_scale(farm)
        samples += receiver_noise(samples.shape, farm.noise_dbfs,
                                  NOISE_SEED if noise_seed is None else noise_seed, unit)
    return t, bins, samples


# ---------------------------------------------------------------------------
# Receiver noise (config key ``noise_dbfs``), so that detection sees a floor.

#: The noise's seed when none is given: runs are reproducible.
NOISE_SEED = 64


def receiver_noise(shape, noise_dbfs: float, seed: int = NOISE_SEED, full_scale: float = 1.0) -> np.ndarray:
    """Complex white Gaussian noise of ``noise_dbfs`` per complex sample: power
    ``10**(noise_dbfs/10)·full_scale²`` split evenly between I and Q
    (``full_scale``: the samples' unit worth full scale, 1 for the replay's).
    The same ``seed`` gives the same noise."""
    if not math.isfinite(noise_dbfs):
        raise ValueError(f"noise_dbfs must be a finite number of dB, not {noise_dbfs!r}")
    sigma = full_scale * math.sqrt(10 ** (noise_dbfs / 10) / 2)
    rng = np.random.default_rng(seed)
    noise = rng.standard_normal((2, *np.atleast_1d(shape)))
    return sigma * (noise[0] + 1j * noise[1])


#: Samples of a period at most that :func:`physics_full_scale` evaluates per windmill.
_PEAK_SAMPLES = 1 << 18


def physics_full_scale(farm: Farm) -> float:
    """What one unit of the physics' samples (``receive`` without streams) is
    worth in the replay's full scale: the streams scale the loudest windmill's
    peak I or Q (``K_l·max|Re m|, |Im m|`` over its period) to ``output_gain_db``
    (``rast.model.physics.stream.build_farm_streams``). Evaluated on the
    stream's own grid (at most 2**18 samples of the period), without the FIR
    interpolator's headroom (a fraction of a dB)."""
    from rast.model.physics.stream import plan_stream
    nearest = min(w.echo_range_km for w in farm.windmills)
    loudest = 0.0
    for w in farm.windmills:
        n = min(plan_stream(w, farm).length, _PEAK_SAMPLES)
        m = modulation(w, np.arange(n) * (w.period_s / n), farm.radar.wavelength_m)
        peak = max(float(np.abs(m.real).max()), float(np.abs(m.imag).max()))
        loudest = max(loudest, (nearest / w.echo_range_km) ** 2 * peak)
    if loudest == 0:
        return 1.0
    return 10 ** (farm.output_gain_db / 20) / loudest


@dataclass(frozen=True)
class Spectrogram:
    times_s: np.ndarray      # centre of each CPI
    doppler_hz: np.ndarray   # DFT bin frequencies, ascending
    power_db: np.ndarray     # (frames, bins), 10·log10 of |DFT|² normalised to the window's gain

    @property
    def resolution_hz(self) -> float:
        return float(self.doppler_hz[1] - self.doppler_hz[0])


def spectrogram(samples: np.ndarray, prf_hz: float, cpi_s: float, *,
                overlap: float = 0.0, window: str = "hann") -> Spectrogram:
    """DFT of the per-pulse samples over each CPI (eq. 2.12), one frame per CPI.

    ``overlap`` (0 ≤ overlap < 1) lets consecutive CPIs share pulses for a
    smoother picture; a real radar uses 0. A Hann window keeps the strong
    zero-Doppler tower line from leaking across the spectrum.
    """
    if not 0 <= overlap < 1:
        raise ValueError(f"overlap must be in [0, 1), not {overlap!r}")
    samples = np.asarray(samples)
    n = int(round(cpi_s * prf_hz))
    if n < 2 or samples.size < n:
        raise ValueError(f"need at least one CPI of {n} pulses, have {samples.size}")
    hop = max(1, int(round(n * (1 - overlap))))
    starts = np.arange(0, samples.size - n + 1, hop)
    frames = samples[starts[:, None] + np.arange(n)[None, :]]
    taper = np.hanning(n) if window == "hann" else np.ones(n)
    spectrum = np.fft.fftshift(np.fft.fft(frames * taper, axis=1), axes=1) / taper.sum()
    power = np.abs(spectrum) ** 2
    with np.errstate(divide="ignore"):
        power_db = 10 * np.log10(np.maximum(power, 1e-30))
    doppler = np.fft.fftshift(np.fft.fftfreq(n, 1.0 / prf_hz))
    times = (starts + n / 2) / prf_hz
    return Spectrogram(times, doppler, power_db)


def spectrogram_correlation(samples: np.ndarray, loop: "Loop", farm_streams: FarmStreams, *,
                            dynamic_range_db: float = 40.0) -> float:
    """How well a replayed recording matches it (``rast import``): the
    Pearson correlation of two spectrograms in dB, each clipped at ``dynamic_range_db``
    below its peak: the model radar's of the replayed stream words (as the RTS plays them)
    and the recording's own, over the whole periods the loop was cut from, CPI for CPI."""
    from rast.model.physics.recording import RecordingError
    farm = farm_streams.farm
    prf = farm.radar.prf_hz
    pulses = int(loop.periods * loop.period_s * prf)
    cpi_s = farm.radar.cpi_ms * 1e-3
    if pulses < round(cpi_s * prf):
        raise RecordingError(f"the recording's {pulses} whole-period pulses are fewer than one CPI "
                             f"of {farm.radar.cpi_ms:g} ms")
    _, _, replayed = receive(farm, pulses / prf, farm_streams)
    recorded = samples[loop.start_sample:loop.start_sample + replayed.shape[1]]

    def clipped(x):
        p = spectrogram(x, prf, cpi_s).power_db
        return np.maximum(p, p.max() - dynamic_range_db).ravel()
    a, b = clipped(replayed[0]), clipped(recorded)
    return float(np.corrcoef(a, b)[0, 1])
