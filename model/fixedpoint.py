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
