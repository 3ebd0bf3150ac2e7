"""RAM-based delay line with a run-time programmable length."""

from amaranth.hdl import Module, Signal, unsigned
from amaranth.lib import wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

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
        self._depth = 1 << max(1, (max_delay + 1).bit_length())
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
        m.submodules.mem = mem = Memory(shape=unsigned(self._width), depth=self._depth, init=[])
        wr = mem.write_port()
        rd = mem.read_port(domain="sync")
        wp = Signal(range(self._depth))
        ra = Signal(range(self._depth))
        self.wp, self.ra = wp, ra           # for formal checks
        m.d.comb += [wr.addr.eq(wp), wr.data.eq(self.i), wr.en.eq(self.en),
                     rd.addr.eq(ra), rd.en.eq(self.en)]
        # The RAM read register has no defined power-up value (X in Icarus):
        # the first enabled sample keeps the output at its initial 0 instead of
        # loading it (a clock enable, no data multiplexer).
        primed = Signal()
        with m.If(self.en):
            m.d.sync += [wp.eq(wp + 1), ra.eq(wp - self.delay), primed.eq(1)]
            with m.If(primed):
                m.d.sync += self.o.eq(rd.data)
        return m
