"""Sampled radar pulses: the stimulus an RTS receives, as integer I/Q words.

A pulse train is described by :class:`PulseConfig` (units in the names) and
sampled at the RTS sample rate. Pulse ``p`` starts at sample ``p·PRI`` where
the pulse repetition interval in samples, ``samples_per_pri =
round(sample_rate / prf)``, is an integer (the RTS runs from one clock; a
non-integer PRI would move the pulse by one sample now and then, which the
config rejects so that the radar receiver samples at fixed offsets).

Shapes (seed Table 4.1: linear chirp up, 20 MHz, 10 µs):

* ``"rect"``:  ``a·e^{i(2π f_c t + φ0)}`` for ``0 ≤ t < τ``
* ``"chirp"``: ``a·e^{i(2π f_c t + π k t² − π B t + φ0)}``, ``k = B/τ``: the
  instantaneous frequency ``f_c − B/2 + k·t`` sweeps ``B`` up across the pulse,
  centred on the carrier offset ``f_c``.

``t`` is time since the pulse start. The pulse start phase is the same for
every pulse (a coherent radar), so the per-pulse samples at a fixed range see
only what the target does to them. Additive complex Gaussian noise (σ per I
and Q, as a fraction of full scale) comes from ``numpy.random.default_rng(seed)``
and is added to every sample, including the idle ones, unless
``noise_in_pulse_only``.

Quantisation to the input format (``rast.model.contract.fixedpoint.INPUT``, full scale
1.0 = ``2**(width-1)``): ``round`` half away from zero (``numpy.rint`` is
half-even; the choice is irrelevant for the model, which only sees the
integers), then saturation to ``[INPUT.min, INPUT.max]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rast.model.contract import fixedpoint as fx

__all__ = ["PulseConfig", "PulseTrain", "generate", "pulse_waveform", "quantise_iq",
           "TABLE_4_1"]

_SHAPES = ("rect", "chirp")


@dataclass(frozen=True)
class PulseConfig:
    """A sampled pulse train.

    Parameters
    ----------
    sample_rate_mhz : RTS sample rate, MHz.
    prf_hz : pulse repetition frequency, Hz; ``sample_rate/prf`` must be an integer.
    pulse_width_us : pulse width τ, µs (at least one sample).
    shape : ``"rect"`` or ``"chirp"`` (linear up-chirp).
    bandwidth_mhz : chirp bandwidth B, MHz (0 for ``"rect"``); ``≤ sample_rate``.
    amplitude : peak amplitude as a fraction of full scale, ``0 ≤ a ≤ 1``
        (a full-scale complex tone reaches ``a`` on I and Q; with noise it can saturate).
    carrier_offset_hz : residual carrier after down-conversion, Hz.
    start_phase_deg : phase of every pulse at its first sample, degrees.
    noise_rms : σ of the additive noise per I and per Q, fraction of full scale.
    seed : seed of the noise generator.
    n_pulses : pulses in the train (or give ``seconds``).
    noise_in_pulse_only : add noise only inside the pulse (idle samples exactly 0).
    """
    sample_rate_mhz: float
    prf_hz: float
    pulse_width_us: float
    shape: str = "rect"
    bandwidth_mhz: float = 0.0
    amplitude: float = 0.5
    carrier_offset_hz: float = 0.0
    start_phase_deg: float = 0.0
    noise_rms: float = 0.0
    seed: int = 0
    n_pulses: int = 1
    noise_in_pulse_only: bool = False

    def __post_init__(self):
        def positive(name):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v) or v <= 0:
                raise ValueError(f"{name} must be a positive number, not {v!r}")
        for name in ("sample_rate_mhz", "prf_hz", "pulse_width_us"):
            positive(name)
        if self.shape not in _SHAPES:
            raise ValueError(f"shape must be one of {_SHAPES}, not {self.shape!r}")
        if not isinstance(self.n_pulses, int) or isinstance(self.n_pulses, bool) or self.n_pulses < 1:
            raise ValueError(f"n_pulses must be a positive integer, not {self.n_pulses!r}")
        if not (isinstance(self.amplitude, (int, float)) and 0 <= self.amplitude <= 1):
            raise ValueError(f"amplitude must be a fraction of full scale in [0, 1], not {self.amplitude!r}")
        if not (isinstance(self.noise_rms, (int, float)) and self.noise_rms >= 0):
            raise ValueError(f"noise_rms must be a non-negative number, not {self.noise_rms!r}")
        if not (isinstance(self.bandwidth_mhz, (int, float)) and 0 <= self.bandwidth_mhz <= self.sample_rate_mhz):
            raise ValueError(f"bandwidth_mhz must be in [0, sample_rate_mhz={self.sample_rate_mhz}], "
                             f"not {self.bandwidth_mhz!r}")
        if self.shape == "chirp" and self.bandwidth_mhz == 0:
            raise ValueError("a chirp needs bandwidth_mhz > 0")
        if abs(self.carrier_offset_hz) >= self.sample_rate_mhz * 1e6 / 2:
            raise ValueError(f"carrier_offset_hz must be below half the sample rate, "
                             f"not {self.carrier_offset_hz!r}")
        ratio = self.sample_rate_mhz * 1e6 / self.prf_hz
        if abs(ratio - round(ratio)) > 1e-9 * ratio:
            fs, lo = self.sample_rate_mhz * 1e6, int(ratio)
            raise ValueError(f"the PRI must be a whole number of RTS samples: {self.sample_rate_mhz:g} MHz / "
                             f"prf {self.prf_hz:g} Hz = {ratio:.6g} samples (prf {fs / (lo + 1):.6g} Hz "
                             f"gives {lo + 1}, {fs / lo:.6g} Hz gives {lo})")
        if self.pulse_samples < 1:
            raise ValueError(f"pulse_width_us must be at least one sample, not {self.pulse_width_us!r}")
        if self.pulse_samples > self.samples_per_pri:
            raise ValueError(f"pulse_width_us ({self.pulse_width_us}) must not exceed the PRI "
                             f"({1e6 / self.prf_hz} µs)")

    @classmethod
    def for_seconds(cls, seconds: float, **kw) -> "PulseConfig":
        """The train of ``seconds`` of radar time: ``round(seconds·prf)`` pulses."""
        if not seconds > 0:
            raise ValueError(f"seconds must be positive, not {seconds!r}")
        return cls(n_pulses=max(1, round(seconds * kw["prf_hz"])), **kw)

    @property
    def samples_per_pri(self) -> int:
        return round(self.sample_rate_mhz * 1e6 / self.prf_hz)

    @property
    def pulse_samples(self) -> int:
        return round(self.pulse_width_us * self.sample_rate_mhz)

    @property
    def total_samples(self) -> int:
        return self.n_pulses * self.samples_per_pri

    @property
    def seconds(self) -> float:
        return self.n_pulses / self.prf_hz


#: The C-band radar of seed Table 4.1 (PRF 20 kHz, 10 µs linear chirp up, 20 MHz).
TABLE_4_1 = dict(prf_hz=20_000.0, pulse_width_us=10.0, shape="chirp", bandwidth_mhz=20.0)


def pulse_waveform(cfg: PulseConfig) -> np.ndarray:
    """One noise-free pulse, complex, ``cfg.pulse_samples`` long, full scale 1.0."""
    fs = cfg.sample_rate_mhz * 1e6
    t = np.arange(cfg.pulse_samples) / fs
    phase = 2 * np.pi * cfg.carrier_offset_hz * t + np.deg2rad(cfg.start_phase_deg)
    if cfg.shape == "chirp":
        tau = cfg.pulse_width_us * 1e-6
        b = cfg.bandwidth_mhz * 1e6
        phase = phase + np.pi * (b / tau) * t ** 2 - np.pi * b * t
    return cfg.amplitude * np.exp(1j * phase)


def quantise_iq(x: np.ndarray, fmt: fx.Format = fx.INPUT) -> tuple[np.ndarray, np.ndarray]:
    """Complex (full scale 1.0) to saturated integer I, Q (int64) of ``fmt``."""
    scale = float(1 << fmt.frac)

    def q(v):
        r = np.sign(v) * np.floor(np.abs(v) * scale + 0.5)
        return np.clip(r, fmt.min, fmt.max).astype(np.int64)
    return q(x.real), q(x.imag)


@dataclass
class PulseTrain:
    """Integer samples of a pulse train, shape ``(n_pulses, samples_per_pri)`` each.

    ``i``, ``q``: int64 in the input format's range. ``pulse_starts``: the
    sample index of each pulse in the flattened sequence.
    """
    config: PulseConfig
    i: np.ndarray
    q: np.ndarray

    @property
    def pulse_starts(self) -> np.ndarray:
        return np.arange(self.config.n_pulses, dtype=np.int64) * self.config.samples_per_pri

    def flat(self) -> tuple[np.ndarray, np.ndarray]:
        return self.i.reshape(-1), self.q.reshape(-1)

    def words(self) -> np.ndarray:
        """Packed input words (I low), flattened, as ``rast.model.contract.fixedpoint.pack_iq``."""
        i, q = self.flat()
        return fx.pack_iq(i, q, fx.INPUT.width)


def generate(cfg: PulseConfig, *, active_samples: int | None = None) -> PulseTrain:
    """Sample the pulse train.

    ``active_samples`` keeps only the first ``active_samples`` of each PRI
    (shape ``(n_pulses, active_samples)``): the part a testbench has to carry
    explicitly when the rest of each PRI is idle (requires
    ``noise_in_pulse_only`` or zero noise, so that the rest is exactly 0).
    """
    width = cfg.samples_per_pri
    if active_samples is not None:
        if not isinstance(active_samples, int) or not cfg.pulse_samples <= active_samples <= width:
            raise ValueError(f"active_samples must be an integer in [{cfg.pulse_samples}, {width}], "
                             f"not {active_samples!r}")
        if cfg.noise_rms > 0 and not cfg.noise_in_pulse_only:
            raise ValueError("active_samples drops idle samples, which must then be noise-free: "
                             "set noise_in_pulse_only or noise_rms=0")
        width = active_samples
    row = np.zeros(width, dtype=complex)
    row[:cfg.pulse_samples] = pulse_waveform(cfg)
    x = np.broadcast_to(row, (cfg.n_pulses, width))
    if cfg.noise_rms > 0:
        rng = np.random.default_rng(cfg.seed)
        cols = cfg.pulse_samples if cfg.noise_in_pulse_only else width
        noise = cfg.noise_rms * (rng.standard_normal((cfg.n_pulses, cols)) +
                                 1j * rng.standard_normal((cfg.n_pulses, cols)))
        x = np.array(x)
        x[:, :cols] += noise
    i, q = quantise_iq(np.asarray(x))
    return PulseTrain(cfg, i, q)
