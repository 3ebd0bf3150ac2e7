"""A clock-domain crossing queue whose fast side decides from registers only.

Amaranth's ``AsyncFIFO`` reads its memory at the *next* read pointer, so its
empty compare, the reader's enable and the pointer's increment all lie in
front of the memory's read address in one clock: 9.3 ns on a 200 MHz fabric
(the SDRAM pool's answer queue, docs/bitstream.md); and its full compare
lies in front of the write pointer's increment and the memory's write
enable (6.8 ns, its command queue). Here the writer keeps room by its own
count, so a write is never gated; the reader either takes words on its
own, at most every other clock, each take decided from two flip-flops
(``reader="take"``), or takes them by a ``r_rdy``/``r_en`` handshake
(``reader="stream"``, for a slow reader); the memory is read at the
registered pointer in both.
"""

from amaranth.hdl import Cat, Module, Signal
from amaranth.lib import wiring
from amaranth.lib.cdc import FFSynchronizer
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

__all__ = ["CrossingQueue"]


def _gray_decode(gray):
    """The binary value of a Gray code: bit k the XOR of the code's bits k
    and up, each bit a reduction of its own (the chain ``b[k] = b[k+1] ^
    g[k]`` became three LUT levels at five bits, 5.3 ns at a 200 MHz
    fabric)."""
    return Cat(*(gray[k:].xor() for k in range(len(gray))))


def _next_gray(pointer):
    """The pointer plus one (wrapping at its width) and its Gray code."""
    nxt = (pointer + 1)[:len(pointer)]
    return nxt, nxt ^ (nxt >> 1)


class CrossingQueue(wiring.Component):
    """``depth`` words of ``width`` bits from ``w_domain`` into ``r_domain``.

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
        Not full. The writer keeps room by its own count (``w_level``, or a
        reservation): a write while full is an error, it sets ``overflow``
        (sticky, in ``w_domain``) and the queue's words are wrong from then on.
    w_level : Out(range(depth + 1))
        Words in the queue as the write side saw it a clock before (the
        reads it has seen through the synchroniser and a register after it;
        writes since not counted): never fewer than are in it.
    overflow : Out(1)
    r_take : Out(1), r_data : Out(width)  (``reader="take"``)
        In ``r_domain``: ``r_take`` is 1 for one clock per word, with the
        word in ``r_data`` in that clock (the memory read at the registered
        read pointer). ``r_take`` comes from two registers (a word seen
        through the synchroniser, no take in the clock before): a word is
        taken three ``r_domain`` clocks after its write's edge at the
        earliest (two synchroniser stages, that register), and takes are at
        least two clocks apart.
    r_rdy : Out(1), r_en : In(1), r_data : Out(width)  (``reader="stream"``)
        In ``r_domain``: the oldest word is in ``r_data`` while ``r_rdy``;
        ``r_en`` takes it. ``r_rdy`` is the synchronised write pointer's
        compare with the read pointer (no register: for a reader in a slow
        clock).
    """

    def __init__(self, width, depth, *, w_domain, r_domain="sync", reader="take"):
        if not isinstance(width, int) or isinstance(width, bool) or width < 1:
            raise ValueError(f"Crossing queue width must be a positive integer, not {width!r}")
        if not isinstance(depth, int) or isinstance(depth, bool) or depth < 2 or depth & (depth - 1):
            raise ValueError(f"Crossing queue depth must be a power of two of at least 2, not {depth!r}")
        for name, d in (("Write", w_domain), ("Read", r_domain)):
            if not (isinstance(d, str) and d):
                raise ValueError(f"{name} domain must be a domain name, not {d!r}")
        if reader not in ("take", "stream"):
            raise ValueError(f"Crossing queue reader must be 'take' or 'stream', not {reader!r}")
        self._width, self._depth = width, depth
        self._w_domain, self._r_domain, self._reader = w_domain, r_domain, reader
        super().__init__({
            "w_en": In(1), "w_data": In(width), "w_rdy": Out(1), "overflow": Out(1),
            "w_level": Out(range(depth + 1)),
            **({"r_take": Out(1)} if reader == "take" else {"r_rdy": Out(1), "r_en": In(1)}),
            "r_data": Out(width),
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

        # write side: never gated (the writer keeps room), so the enable goes
        # straight to the memory and the pointer; full where the pointers
        # differ in their two top Gray bits only
        full = ((produce_gry[-1] != consume_w_gry[-1]) & (produce_gry[-2] != consume_w_gry[-2])
                & (produce_gry[:-2] == consume_w_gry[:-2]))
        # the synchronised read pointer once more in a register before its
        # decode (from the synchroniser's stage, placed where the other
        # domain's logic is, through the decode was 5.5-6.0 ns at a 200 MHz
        # fabric): w_level counts the reads a clock later, never fewer words
        consume_w_gry_q, consume_w = Signal(bits), Signal(bits)
        m.d[wd] += [consume_w_gry_q.eq(consume_w_gry), consume_w.eq(_gray_decode(consume_w_gry_q)),
                    self.w_level.eq(produce - consume_w)]
        m.d.comb += [self.w_rdy.eq(~full),
                     w_port.en.eq(self.w_en), w_port.addr.eq(produce[:-1]), w_port.data.eq(self.w_data)]
        with m.If(self.w_en):
            nxt, nxt_gry = _next_gray(produce)
            m.d[wd] += [produce.eq(nxt), produce_gry.eq(nxt_gry)]
            with m.If(full):
                m.d[wd] += self.overflow.eq(1)

        m.d.comb += [r_port.addr.eq(consume[:-1]), self.r_data.eq(r_port.data)]
        if self._reader == "take":
            # a word is there when the synchronised write pointer differs
            # from the read pointer, registered; in the clock after a take
            # that register still shows the pointer before it, so no take then
            there, took = Signal(), Signal()
            m.d[rd] += [there.eq(produce_r_gry != consume_gry), took.eq(self.r_take)]
            m.d.comb += self.r_take.eq(there & ~took)
            take = self.r_take
        else:
            m.d.comb += self.r_rdy.eq(produce_r_gry != consume_gry)
            take = self.r_en & self.r_rdy
        with m.If(take):
            nxt, nxt_gry = _next_gray(consume)
            m.d[rd] += [consume.eq(nxt), consume_gry.eq(nxt_gry)]
        return m
