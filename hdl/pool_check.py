"""Read-back check of an SDRAM stream pool: the CRC-32 of what the SDRAM holds.

The stream check of the register file (``STREAM_CRC``) covers the words as
they arrived over the bus; this one reads them back out of the SDRAM, so that
a host can tell a word stored wrong (a bad SDRAM clock phase on a new board,
a marginal timing) from one lost on the line. ``POOL_CHECK`` (docs/registers.md)
starts it.
"""

from amaranth.hdl import Module, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from .registers import crc32_step

__all__ = ["PoolReadCheck"]


class PoolReadCheck(wiring.Component):
    """Reads ``words`` pool words from ``addr`` on through the pool's host
    read port, one at a time, and keeps the CRC-32 of them (zlib's, each word
    as four bytes, least significant first; a byte a clock).

    Parameters
    ----------
    addr_width : int
        Bits of a pool address (addresses wrap at it).
    count_width : int
        Bits of ``words``.

    Members
    -------
    start : In(1), addr : In(addr_width), words : In(count_width)
        A strobe and what to read (taken with the strobe, acted on a clock
        later); a start while busy is ignored (a read answer may still be on
        its way).
    busy : Out(1)
        From the clock after the start's until the last word's CRC is in.
    crc : Out(32)
        zlib's CRC-32 of the words read so far (of all of them once ``busy`` is 0).
    rd_valid : Out(1), rd_ready : In(1), rd_addr : Out(addr_width)
    rd_data_valid : In(1), rd_data : In(32)
        The pool's host read port (``SDRAMStreamPool``): answers in order.
    """

    def __init__(self, addr_width: int, count_width: int):
        for name, v in (("Address width", addr_width), ("Count width", count_width)):
            if not isinstance(v, int) or isinstance(v, bool) or v < 1:
                raise ValueError(f"{name} must be a positive integer, not {v!r}")
        super().__init__({
            "start": In(1), "addr": In(addr_width), "words": In(count_width),
            "busy": Out(1), "crc": Out(32),
            "rd_valid": Out(1), "rd_ready": In(1), "rd_addr": Out(addr_width),
            "rd_data_valid": In(1), "rd_data": In(32),
        })

    def elaborate(self, platform):
        m = Module()
        reg = Signal(32, init=0xFFFFFFFF)
        left = Signal.like(self.words)
        left_nz = Signal()               # left != 0, kept beside left
        word = Signal(32)
        byte = Signal(range(5))          # bytes of ``word`` still to shift in
        asked = Signal()                 # the read of this word went out
        busy = Signal()
        m.d.comb += self.crc.eq(~reg)
        # A start is taken into registers first (with its ``words != 0``),
        # and acted on a clock later; ``busy`` covers that clock. rd_valid is
        # a register: words left, this word not asked for, no byte to shift
        # in. It rises a clock after the start, and again in the clock after
        # the last byte's, each time from registers (``left != 0`` and the
        # state decoded into the pool's request were a 200 MHz SDRAM build's
        # latest path, 9.3 ns; the start's ``words != 0`` and ``left != 0``
        # into it, 7.2 ns). ``busy`` changes only there too.
        start, start_addr, start_words, start_any = (Signal(), Signal.like(self.addr),
                                                     Signal.like(self.words), Signal())
        m.d.sync += [start.eq(self.start & ~self.busy), start_addr.eq(self.addr),
                     start_words.eq(self.words), start_any.eq(self.words != 0)]
        m.d.comb += self.busy.eq(busy | start)
        # left != 0 in a register of its own, a clock after ``left``: read at
        # the word's last byte, three clocks after the word's decrement (the
        # compare in the decrement's clock was 5.6 ns at a 200 MHz fabric)
        m.d.sync += left_nz.eq(left != 0)
        with m.If(start):
            m.d.sync += [reg.eq(0xFFFFFFFF), left.eq(start_words), left_nz.eq(start_any),
                         self.rd_addr.eq(start_addr), self.rd_valid.eq(start_any), busy.eq(start_any)]
        with m.Else():
            with m.If(self.rd_valid & self.rd_ready):
                m.d.sync += [asked.eq(1), self.rd_addr.eq(self.rd_addr + 1), self.rd_valid.eq(0)]
            with m.If(asked & self.rd_data_valid):
                m.d.sync += [word.eq(self.rd_data), byte.eq(4), asked.eq(0), left.eq(left - 1)]
            with m.If(byte != 0):
                m.d.sync += [reg.eq(crc32_step(reg, word[:8])), word.eq(word >> 8), byte.eq(byte - 1)]
            with m.If(byte == 1):
                m.d.sync += [self.rd_valid.eq(left_nz), busy.eq(left_nz)]
        return m
