"""A clock-domain crossing queue whose reader decides from registers only.

Amaranth's ``AsyncFIFO`` reads its memory at the *next* read pointer, so its
empty compare, the reader's enable and the pointer's increment all lie in
front of the memory's read address in one clock: 9.3 ns on a 200 MHz fabric
(the SDRAM pool's answer queue, docs/bitstream.md). Here the reader takes
words on its own, at most every other clock, each take decided from two
flip-flops, and the memory is read at the registered pointer.
"""

from amaranth.hdl import Module, Signal
from amaranth.lib import wiring
from amaranth.lib.cdc import FFSynchronizer
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

__all__ = ["CrossingQueue"]


def _next_gray(pointer):
    """The pointer plus one (wrapping at its width) and its Gray code."""
    nxt = (pointer + 1)[:len(pointer)]
    return nxt, nxt ^ (nxt >> 1)


class CrossingQueue(wiring.Component):
    """``depth`` words of ``width`` bits from ``w_domain`` into ``r_domain``,
    for a reader that takes every word (no back-pressure).

    Pointers cross in Gray code through two-flip-flop synchronisers, as in
    ``AsyncFIFO``. Both domains must come out of reset with the queue empty
    (the board's domains are held in reset until the PLL locks; nothing is
    written before). With ``w_domain == r_domain`` it is a plain queue with
    the same timing.

    Members
    -------
    w_en : In(1), w_data : In(width)
        A word is written in every clock of ``w_domain`` with ``w_en``.
    w_rdy : Out(1)
        Not full. The writer keeps room by its own count; a write while full
        is lost and sets ``overflow`` (sticky, in ``w_domain``).
    overflow : Out(1)
    r_take : Out(1), r_data : Out(width)
        In ``r_domain``: ``r_take`` is 1 for one clock per word, with the
        word in ``r_data`` in that clock (the memory read at the registered
        read pointer). ``r_take`` comes from two registers (a word seen
        through the synchroniser, no take in the clock before): a word is
        taken three ``r_domain`` clocks after its write's edge at the
        earliest (two synchroniser stages, that register), and takes are at
        least two clocks apart.
    """

    def __init__(self, width, depth, *, w_domain, r_domain="sync"):
        if not isinstance(width, int) or isinstance(width, bool) or width < 1:
            raise ValueError(f"Crossing queue width must be a positive integer, not {width!r}")
        if not isinstance(depth, int) or isinstance(depth, bool) or depth < 2 or depth & (depth - 1):
            raise ValueError(f"Crossing queue depth must be a power of two of at least 2, not {depth!r}")
        for name, d in (("Write", w_domain), ("Read", r_domain)):
            if not (isinstance(d, str) and d):
                raise ValueError(f"{name} domain must be a domain name, not {d!r}")
        self._width, self._depth = width, depth
        self._w_domain, self._r_domain = w_domain, r_domain
        super().__init__({
            "w_en": In(1), "w_data": In(width), "w_rdy": Out(1), "overflow": Out(1),
            "r_take": Out(1), "r_data": Out(width),
        })

    def elaborate(self, platform):
        m = Module()
        wd, rd, D = self._w_domain, self._r_domain, self._depth
        bits = D.bit_length()                   # pointers one bit wider than an address
        m.submodules.storage = storage = Memory(shape=self._width, depth=D, init=[],
                                                attrs={"ram_style": "distributed"})
        w_port = storage.write_port(domain=wd)
        r_port = storage.read_port(domain="comb")

        produce, produce_gry = Signal(bits), Signal(bits)        # write side
        consume, consume_gry = Signal(bits), Signal(bits)        # read side
        consume_w_gry, produce_r_gry = Signal(bits), Signal(bits)
        m.submodules.consume_sync = FFSynchronizer(consume_gry, consume_w_gry, o_domain=wd)
        m.submodules.produce_sync = FFSynchronizer(produce_gry, produce_r_gry, o_domain=rd)

        # write side: full where the pointers differ in their two top Gray bits only
        full = ((produce_gry[-1] != consume_w_gry[-1]) & (produce_gry[-2] != consume_w_gry[-2])
                & (produce_gry[:-2] == consume_w_gry[:-2]))
        m.d.comb += [self.w_rdy.eq(~full),
                     w_port.en.eq(self.w_en & ~full), w_port.addr.eq(produce[:-1]),
                     w_port.data.eq(self.w_data)]
        with m.If(self.w_en):
            with m.If(full):
                m.d[wd] += self.overflow.eq(1)
            with m.Else():
                nxt, nxt_gry = _next_gray(produce)
                m.d[wd] += [produce.eq(nxt), produce_gry.eq(nxt_gry)]

        # read side: a word is there when the synchronised write pointer
        # differs from the read pointer, registered; in the clock after a
        # take that register still shows the pointer before it, so no take then
        there, took = Signal(), Signal()
        m.d[rd] += [there.eq(produce_r_gry != consume_gry), took.eq(self.r_take)]
        m.d.comb += [self.r_take.eq(there & ~took),
                     r_port.addr.eq(consume[:-1]), self.r_data.eq(r_port.data)]
        with m.If(self.r_take):
            nxt, nxt_gry = _next_gray(consume)
            m.d[rd] += [consume.eq(nxt), consume_gry.eq(nxt_gry)]
        return m
