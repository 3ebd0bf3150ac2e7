"""A synchronous FIFO with a registered output whose every decision is taken
from flip-flops.

Amaranth's ``SyncFIFOBuffered`` keeps a binary level and decides from its
compares: ``level != 0`` and ``level != depth`` in front of the level's own
adder, behind the reader's enable. As the engine's request queue in front of
the SDRAM pool that was a latest path of the 200 MHz SDRAM builds (5.2-6.1
ns, docs/bitstream.md). Here the levels are thermometer codes: "more than k
words" is a flip-flop for every k, and each moves by one LUT of its
neighbours and the two enables.
"""
from amaranth.hdl import Const, Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

__all__ = ["RegisteredFIFO"]


def _thermometer_step(m, code, up, down):
    """``code`` (bit k: more than k) one more with ``up``, one fewer with
    ``down`` (never both), in the next clock."""
    n = len(code)
    for k in range(n):
        below = code[k - 1] if k else Const(1)
        above = code[k + 1] if k + 1 < n else Const(0)
        m.d.sync += code[k].eq(Mux(up, below, Mux(down, above, code[k])))


class RegisteredFIFO(wiring.Component):
    """``depth + 1`` words of ``width`` bits: a ring of ``depth`` and an output
    register, as ``SyncFIFOBuffered(depth=depth + 1)`` and clock for clock
    the same at its ports (the test compares them).

    Parameters
    ----------
    width : int
        Bits of a word.
    depth : int
        Words of the ring, at least 2.

    Members
    -------
    w_en : In(1), w_data : In(width), w_rdy : Out(1)
        A word is written in a clock with ``w_en`` and ``w_rdy``.
    r_rdy : Out(1), r_data : Out(width), r_en : In(1)
        The oldest word, from registers; taken in a clock with ``r_en``.
    fill : Out(depth + 1)
        The words in the FIFO as a thermometer code: bit k is 1 while it
        holds more than k, each bit a flip-flop.
    """

    def __init__(self, width: int, depth: int):
        if not isinstance(width, int) or isinstance(width, bool) or width < 1:
            raise ValueError(f"FIFO width must be a positive integer, not {width!r}")
        if not isinstance(depth, int) or isinstance(depth, bool) or depth < 2:
            raise ValueError(f"FIFO depth must be an integer of at least 2, not {depth!r}")
        self._width, self._depth = width, depth
        super().__init__({
            "w_en": In(1), "w_data": In(width), "w_rdy": Out(1),
            "r_rdy": Out(1), "r_data": Out(width), "r_en": In(1),
            "fill": Out(depth + 1),
        })

    def elaborate(self, platform):
        m = Module()
        D = self._depth
        m.submodules.ring = ring = Memory(shape=self._width, depth=D, init=[], attrs={"ram_style": "distributed"})
        w_port, r_port = ring.write_port(), ring.read_port(domain="comb")
        produce, consume = Signal(range(D)), Signal(range(D))
        in_ring = Signal(D)                      # bit k: more than k words in the ring
        do_write = self.w_en & self.w_rdy
        do_read = self.r_en & self.r_rdy
        refill = in_ring[0] & (~self.r_rdy | self.r_en)
        m.d.comb += [self.w_rdy.eq(~in_ring[D - 1]),
                     w_port.en.eq(do_write), w_port.addr.eq(produce), w_port.data.eq(self.w_data),
                     r_port.addr.eq(consume)]

        def advance(pointer):
            return pointer + 1 if D & (D - 1) == 0 else Mux(pointer == D - 1, 0, pointer + 1)

        with m.If(do_write):
            m.d.sync += produce.eq(advance(produce))
        with m.If(refill):
            m.d.sync += [self.r_data.eq(r_port.data), self.r_rdy.eq(1), consume.eq(advance(consume))]
        with m.Elif(self.r_en):
            m.d.sync += self.r_rdy.eq(0)
        _thermometer_step(m, in_ring, do_write & ~refill, refill & ~do_write)
        _thermometer_step(m, self.fill, do_write & ~do_read, do_read & ~do_write)
        return m
