"""Complex (I/Q) sample layouts: ``re`` (I) in the low bits, ``im`` (Q) above."""

from functools import lru_cache

from amaranth.hdl import signed
from amaranth.lib import data

__all__ = ["IQ"]


@lru_cache(maxsize=None)
def IQ(width: int) -> data.StructLayout:
    """Layout of a complex sample with signed ``width``-bit parts, I in the low half.

    The packed value equals :func:`rast.model.contract.fixedpoint.pack_iq` of the parts.
    """
    if not isinstance(width, int) or isinstance(width, bool) or width <= 0:
        raise TypeError(f"I/Q width must be a positive integer, not {width!r}")
    return data.StructLayout({"re": signed(width), "im": signed(width)})
