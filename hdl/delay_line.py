"""RAM-based delay line with a run-time programmable length."""

from amaranth.hdl import Module, Signal, unsigned
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from .ecp5_primitives import RegisteredRAM
from ..model.fixedpoint import delay_depth

__all__ = ["DelayLine"]


class DelayLine(wiring.Component):
    """``o[n] = i[n - latency - delay[n - latency]]``, advancing when ``en``.

    One block RAM of ``depth`` words (the power of two >= ``max_delay + 2``),
    written at a free-running pointer and read ``delay + 1`` words behind it;
    the read address comes from a register and the RAM output is registered
    (``latency = 3``). Words never written read as zero.

    Parameters
    ----------
    width : int
        Bits per word.
    max_delay : int
        Largest programmable delay.

    Members
    -------
    en : In(1)
    i : In(width)
    delay : In(range(max_delay + 1))
        Programmed delay; values above ``max_delay`` must not be applied.
    o : Out(width)
    """

    latency = 3

    def __init__(self, width, max_delay):
        if not isinstance(width, int) or isinstance(width, bool) or width <= 0:
            raise TypeError(f"Delay line width must be a positive integer, not {width!r}")
        if not isinstance(max_delay, int) or isinstance(max_delay, bool) or max_delay < 0:
            raise TypeError(f"Maximum delay must be a non-negative integer, not {max_delay!r}")
        self._width = width
        self._max_delay = max_delay
        self._depth = delay_depth(max_delay)
        super().__init__({
            "en": In(1),
            "i": In(unsigned(width)),
            "delay": In(range(max_delay + 1)),
            "o": Out(unsigned(width)),
        })

    @property
    def width(self):
        return self._width

    @property
    def max_delay(self):
        return self._max_delay

    @property
    def depth(self):
        return self._depth

    def elaborate(self, platform):
        m = Module()
        # Block RAM with its output register (DP16KD OUTREG on ECP5): the
        # read address is a register and the RAM output register is ``o``.
        m.submodules.mem = mem = RegisteredRAM(self._width, self._depth)
        wp = Signal(range(self._depth))
        # The read address starts one word away from the write address: in the
        # first enabled cycle both would otherwise be word 0, a same-edge
        # read of the word being written, undefined on the DP16KD (the
        # netlist simulation's model poisons it, and a common delay line
        # then writes that word into every window). Word 1 is unwritten: 0.
        ra = Signal(range(self._depth), init=1)
        self.wp, self.ra = wp, ra           # for formal checks
        m.d.comb += [mem.w_addr.eq(wp), mem.w_data.eq(self.i), mem.w_en.eq(self.en),
                     mem.r_addr.eq(ra), mem.r_en.eq(self.en), self.o.eq(mem.r_data)]
        with m.If(self.en):
            m.d.sync += [wp.eq(wp + 1), ra.eq(wp - self.delay)]
        return m
