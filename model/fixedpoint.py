"""The fixed-point contract of the replay block, written down once.

Every width, rounding step and saturation of the data path is defined here and
read from here by three users: the stream quantiser (``rast.model.stream``),
the bit-exact datapath model and the Amaranth gateware (``rast.hdl``).

Formats are two's complement integers with an implied binary point:

* input sample ``x``      : signed ``INPUT_WIDTH`` bits per I and Q, full scale 1.0
* stream word ``m``       : signed ``STREAM_WIDTH`` bits per I and Q, full scale 1.0;
  packed into one ``2*STREAM_WIDTH``-bit word with I in the low half
* channel gain ``g``      : unsigned ``GAIN_WIDTH`` bits, ``GAIN_FRAC`` of them
  fractional (``g = word / 2**GAIN_FRAC``)
* output sample ``y``     : signed ``OUTPUT_WIDTH`` bits per I and Q, same scale as ``x``
"""

from dataclasses import dataclass

__all__ = ["Format", "INPUT", "STREAM", "GAIN", "OUTPUT", "GAIN_FRAC",
           "INPUT_WIDTH", "STREAM_WIDTH", "GAIN_WIDTH", "OUTPUT_WIDTH",
           "PHASE_FRAC_BITS", "pack_iq", "unpack_iq"]


@dataclass(frozen=True)
class Format:
    """An integer format: ``width`` bits, ``frac`` of them after the binary point."""
    width: int
    frac: int
    signed: bool

    @property
    def min(self) -> int:
        return -(1 << (self.width - 1)) if self.signed else 0

    @property
    def max(self) -> int:
        return (1 << (self.width - 1)) - 1 if self.signed else (1 << self.width) - 1


INPUT_WIDTH = 16
STREAM_WIDTH = 16
GAIN_WIDTH = 17
GAIN_FRAC = 16
OUTPUT_WIDTH = 16

#: Fractional bits of the stream-rate phase accumulator (the increment per RTS
#: sample is ``round(stream_rate / sample_rate * 2**PHASE_FRAC_BITS)``).
PHASE_FRAC_BITS = 32

INPUT = Format(INPUT_WIDTH, INPUT_WIDTH - 1, signed=True)
STREAM = Format(STREAM_WIDTH, STREAM_WIDTH - 1, signed=True)
GAIN = Format(GAIN_WIDTH, GAIN_FRAC, signed=False)
OUTPUT = Format(OUTPUT_WIDTH, INPUT_WIDTH - 1, signed=True)


def pack_iq(i, q, width=STREAM_WIDTH):
    """Pack signed I and Q integers (numpy arrays) into unsigned words, I low."""
    import numpy as np
    mask = (1 << width) - 1
    i = np.asarray(i, dtype=np.int64)
    q = np.asarray(q, dtype=np.int64)
    return ((q & mask) << width) | (i & mask)


def unpack_iq(words, width=STREAM_WIDTH):
    """Inverse of :func:`pack_iq`: unsigned words to signed (I, Q) int64 arrays."""
    import numpy as np
    words = np.asarray(words, dtype=np.int64)
    mask = (1 << width) - 1
    half = 1 << (width - 1)
    i = ((words & mask) ^ half) - half
    q = (((words >> width) & mask) ^ half) - half
    return i, q


# ---------------------------------------------------------------------------
# The replay data path: rounding, guard bits, saturation and latency.
#
# Per channel l, with x the (delayed) input, m the stream word and g the gain
# word (all integers):
#
#   full   = x * m                       exact complex product, 33 bits per part
#   p      = round_half_up(full, 15)     PRODUCT_WIDTH (18) bits, scale of x
#   q      = round_half_up(p * g, 16)    SCALED_WIDTH (19) bits, scale of x
#   s      = sum over channels of q      SCALED_WIDTH + guard_bits(N) bits, exact
#   y      = saturate(s, OUTPUT_WIDTH)   sticky overflow flag if I or Q clipped
#
# round_half_up(v, s) = (v + 2**(s-1)) >> s  (arithmetic shift; ties go up,
# towards +inf). Every product fits one ECP5 MULT18X18D: 16x16 (or 17x16 in
# the 3-multiplier form) for the complex product, 18x17 for the gain.
# ---------------------------------------------------------------------------

import math as _math

__all__ += ["PRODUCT_SHIFT", "PRODUCT_WIDTH", "GAIN_SHIFT", "SCALED_WIDTH",
            "INTERP_FRAC_BITS", "SEGMENT_LATENCY", "GAIN_LATENCY", "CHAIN_LATENCY",
            "CMULT_FORMS", "guard_bits", "sum_width", "round_half_up", "saturate",
            "cmult_latency", "stream_latency", "ReplayContract"]

#: The complex product is rounded by this many bits: Q15 x Q15 -> Q15.
PRODUCT_SHIFT = STREAM_WIDTH - 1
#: Width of the rounded complex product: |x*m| <= 2 (full scale), plus sign.
PRODUCT_WIDTH = INPUT_WIDTH + STREAM_WIDTH + 1 - PRODUCT_SHIFT   # 18
#: The gain product is rounded by this many bits.
GAIN_SHIFT = GAIN_FRAC
#: Width of one channel's scaled product: |p| <= 2**16, g < 2 -> |q| <= 2**17.
SCALED_WIDTH = PRODUCT_WIDTH + (GAIN_WIDTH - GAIN_FRAC)             # 19
#: Fractional phase bits used by the linear interpolator (top bits of the phase).
INTERP_FRAC_BITS = 16

#: Pipeline latency (in samples) of one delay segment beyond its programmed
#: delay: registered read address, block-RAM read, registered RAM output.
SEGMENT_LATENCY = 3
#: Gain stage: registered product, registered rounding.
GAIN_LATENCY = 2
#: First register of the systolic adder chain.
CHAIN_LATENCY = 1

CMULT_FORMS = ("4mult", "3mult")


def guard_bits(channels: int) -> int:
    """Guard bits of the channel sum: ``ceil(log2(channels))``."""
    return (channels - 1).bit_length()


def sum_width(channels: int) -> int:
    return SCALED_WIDTH + guard_bits(channels)


def round_half_up(v, shift: int):
    """``(v + 2**(shift-1)) >> shift`` on int64 numpy arrays or Python ints."""
    return (v + (1 << (shift - 1))) >> shift


def saturate(v, width: int = OUTPUT_WIDTH):
    """Clip to a signed ``width``-bit range; returns (clipped, overflowed)."""
    import numpy as np
    lo, hi = -(1 << (width - 1)), (1 << (width - 1)) - 1
    v = np.asarray(v, dtype=np.int64)
    return np.clip(v, lo, hi), (v < lo) | (v > hi)


def cmult_latency(form: str) -> int:
    """Samples from the complex multiplier's inputs to its rounded output."""
    return {"4mult": 3, "3mult": 4}[form]


def stream_latency(interpolate: bool) -> int:
    """Samples from the phase register to the stream word at the multiplier:
    read address register, block RAM read, block RAM output register (plus
    three interpolation stages)."""
    return 6 if interpolate else 3


@dataclass(frozen=True)
class ReplayContract:
    """Elaboration-time parameters of the replay block and everything derived.

    Parameters
    ----------
    channels : int
        Number of windmill channels N (1 to 64).
    stream_depth : int
        Words per stream RAM bank (each channel has two banks).
    max_delay : int
        Largest programmable common delay (segment of channel 0), samples.
    max_increment : int
        Largest programmable delay increment of channels 1..N-1, samples.
    interpolate : bool
        Linear interpolation between adjacent stream words.
    cmult_form : str
        ``"4mult"`` or ``"3mult"`` complex multiplier (identical results).
    """
    channels: int = 4
    stream_depth: int = 4096
    max_delay: int = 4094
    max_increment: int = 1022
    interpolate: bool = False
    cmult_form: str = "4mult"

    def __post_init__(self):
        def posint(name, what, v, lo=1, hi=None):
            kind = "a positive integer" if lo == 1 else "a non-negative integer"
            if not isinstance(v, int) or isinstance(v, bool):
                raise TypeError(f"{what} must be {kind}, not {v!r}")
            if v < lo:
                raise ValueError(f"{what} must be {kind}, not {v!r}")
            if hi is not None and v > hi:
                raise ValueError(f"{what} must be at most {hi}, not {v!r}")
        posint("channels", "Channel count", self.channels, 1, 64)
        posint("stream_depth", "Stream depth", self.stream_depth, 1, 1 << 16)
        if self.stream_depth < 2 or self.stream_depth & (self.stream_depth - 1):
            raise ValueError(f"Stream depth must be a power of two of at least 2, not {self.stream_depth!r}")
        posint("max_delay", "Maximum delay", self.max_delay, 0, 1 << 20)
        posint("max_increment", "Maximum delay increment", self.max_increment, 0, 1 << 20)
        if not isinstance(self.interpolate, bool):
            raise TypeError(f"Interpolate must be a bool, not {self.interpolate!r}")
        if self.cmult_form not in CMULT_FORMS:
            raise ValueError(f"Complex multiplier form must be one of 4mult, 3mult, not {self.cmult_form!r}")

    @property
    def guard_bits(self) -> int:
        return guard_bits(self.channels)

    @property
    def sum_width(self) -> int:
        return sum_width(self.channels)

    @property
    def cmult_latency(self) -> int:
        return cmult_latency(self.cmult_form)

    @property
    def stream_latency(self) -> int:
        return stream_latency(self.interpolate)

    @property
    def latency(self) -> int:
        """Fixed latency L: an echo of channel l appears ``L + sum(delay[0..l])``
        samples after its input sample. ``L = 3*N + 1 + 2 + cmult_latency``."""
        return (SEGMENT_LATENCY * self.channels + CHAIN_LATENCY + GAIN_LATENCY
                + self.cmult_latency)

    def delay_depth(self, channel: int) -> int:
        """Words of the RAM of delay segment ``channel`` (power of two >= max + 2)."""
        m = self.max_delay if channel == 0 else self.max_increment
        return 1 << max(1, (m + 1).bit_length())

    def max_segment_delay(self, channel: int) -> int:
        return self.max_delay if channel == 0 else self.max_increment

    @property
    def length_width(self) -> int:
        return self.stream_depth.bit_length()
