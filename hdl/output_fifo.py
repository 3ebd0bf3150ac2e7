"""The replay block's output FIFO: first word fall-through, writes never refused.

The block accepts an input only when the FIFO will have room for every
sample in flight (its credit counter, ``rast.hdl.replay_top``), so a write
never meets a full FIFO. Amaranth's ``SyncFIFO`` still gates each write with
its fill level (``w_rdy``), which put the level's compare and its fan-out to
every distributed-RAM write enable in one clock: 6.9 ns, a 16-channel
build's worst path. Here the write enable is the caller's ``w_en`` alone,
and the level only decides ``r_rdy`` (through a register of its own).
"""

from amaranth.hdl import Cat, Module, Signal, Mux
from amaranth.lib import wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

__all__ = ["OutputFIFO"]


class OutputFIFO(wiring.Component):
    """A FIFO of ``depth`` words of ``width`` bits whose caller never writes
    into it when full. Such a write is an error: it overwrites the oldest
    word, and sets ``overrun``, which stays set.

    Members
    -------
    w_en : In(1), w_data : In(width)
        A word written in every clock with ``w_en``.
    r_rdy : Out(1), r_data : Out(width), r_en : In(1)
        The oldest word, readable with ``r_rdy``; taken in a clock with both.
    overrun : Out(1)
        A write met a full FIFO (the caller's room accounting is wrong).
    """

    def __init__(self, width, depth):
        if not isinstance(width, int) or isinstance(width, bool) or width <= 0:
            raise TypeError(f"Output FIFO width must be a positive integer, not {width!r}")
        if not isinstance(depth, int) or isinstance(depth, bool) or depth < 2:
            raise TypeError(f"Output FIFO depth must be an integer of at least 2, not {depth!r}")
        self._width, self._depth = width, depth
        super().__init__({
            "w_en": In(1), "w_data": In(width),
            "r_rdy": Out(1), "r_data": Out(width), "r_en": In(1),
            "overrun": Out(1),
        })

    def elaborate(self, platform):
        m = Module()
        D = self._depth
        m.submodules.storage = storage = Memory(shape=self._width, depth=D, init=[])
        w_port = storage.write_port()
        r_port = storage.read_port(domain="comb")
        produce = Signal(range(D))
        consume = Signal(range(D))
        level = Signal(range(D + 2))      # D + 1 after an overrun (an error, flagged)
        # level != 0 in a register of its own: the level's compare in front of
        # the read's enables was a 16-channel build's latest path (5.9 ns)
        nonempty = Signal()
        do_read = Signal()
        m.d.comb += [
            self.r_rdy.eq(nonempty),
            do_read.eq(self.r_rdy & self.r_en),
            w_port.en.eq(self.w_en), w_port.addr.eq(produce), w_port.data.eq(self.w_data),
            r_port.addr.eq(consume), self.r_data.eq(r_port.data),
        ]
        with m.If(self.w_en):
            m.d.sync += produce.eq(Mux(produce == D - 1, 0, produce + 1))
            with m.If((level == D) & ~do_read):
                m.d.sync += self.overrun.eq(1)
        with m.If(do_read):
            m.d.sync += consume.eq(Mux(consume == D - 1, 0, consume + 1))
        # level + w_en - do_read in one carry chain, the step (+1, -1, 0) in
        # its two's complement from the two strobes (enables in front of
        # the increment and the decrement put the level's compare and two
        # LUT levels on the chain's path: 5.02 ns at a 16-channel build)
        step = Signal(len(level), name="level_step")
        m.d.comb += step.eq(Cat(self.w_en ^ do_read, (do_read & ~self.w_en).replicate(len(level) - 1)))
        m.d.sync += level.eq(level + step)
        with m.If(self.w_en):
            m.d.sync += nonempty.eq(1)
        with m.Elif(do_read & (level == 1)):
            m.d.sync += nonempty.eq(0)
        return m
