"""The SDRAM pipeline's arrival check: which word-cache reads found their
word not yet there.

A pipeline's word cache is filled by answers from the SDRAM, whose latency
is not fixed. Each cache position has a bit, cleared when a fetch into the
position is granted and set when the fetch's word is written; a read that
matters (a playing channel's step, the FIR's MAC) of a position whose bit is
clear is late, and ``underflow`` says so.

The check must see what the read saw. A read whose address register takes
the address at clock edge ``r`` reads the cache in the clock after it, so it
holds every word written at edges up to ``r`` (fills whose ``fill_en`` was
high in the clock before) and none written later; the position's fetch was
granted in the read's visit (``grant`` high in the clock before edge ``r``)
or earlier. The check takes both in the same order: a grant's clear and a
fill's set each reach the bits three edges after the event's own edge (the
grant's and the fill's registered, decoded into two one-hot registers,
then the bit), and the bits are sampled two clocks after the read, so a
read is judged by exactly the grants and fills its own edge ends. (A fill
one clock earlier than a grant's clear, as this check's first version had
it, counted a word written at the read's own edge as arrived, although the
read had missed it.)
"""

from amaranth.hdl import Module, Signal, Mux, Cat, Const
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from .register_chain import delayed

__all__ = ["ArrivalCheck"]


class ArrivalCheck(wiring.Component):
    """Arrival bits for ``positions`` cache positions and ``reads`` checked reads.

    Ports
    -----
    grant : In(1), grant_pos : In(position)
        A fetch into ``grant_pos`` is granted (in the read's visit or earlier).
    fill_en : In(1), fill_pos : In(position)
        The cache's write port writes ``fill_pos`` at the end of this clock.
    read_pos : In(position).array(reads), read_matters : In(1).array(reads)
        Each read's address register (the clock the cache is read) and whether
        the read is checked, registered beside it.
    underflow : Out(1)
        A checked read was late, ``LATENCY`` clocks after its ``read_pos``.

    The bits are selected for each read in registered levels of two address
    bits each, a 4:1 multiplexer a bit (one slice), lowest bits first (the
    whole selection in one clock was 8.8 ns at M = 10 in an SDRAM build; in
    two levels of 16:1, 5.2-5.5 ns); each read's result is registered, then
    their OR.
    """

    def __init__(self, positions, reads):
        for name, v in (("positions", positions), ("reads", reads)):
            if not isinstance(v, int) or isinstance(v, bool) or v < 1:
                raise ValueError(f"Arrival check {name} must be a positive integer, not {v!r}")
        self.positions, self.reads = positions, reads
        self.pos_bits = max(1, (positions - 1).bit_length())
        self.levels = 0
        n = positions
        while n > 1:
            n, self.levels = -(-n // 4), self.levels + 1
        #: Clocks from a read's ``read_pos`` to its verdict on ``underflow``:
        #: the bits two clocks later, the levels, the read's result and the OR.
        self.LATENCY = 2 + self.levels + 2
        super().__init__({
            "grant": In(1), "grant_pos": In(self.pos_bits),
            "fill_en": In(1), "fill_pos": In(self.pos_bits),
            "read_pos": In(self.pos_bits).array(reads), "read_matters": In(1).array(reads),
            "underflow": Out(1),
        })

    def elaborate(self, platform):
        m = Module()
        abits = self.pos_bits
        lo_bits = (abits + 1) // 2

        def one_hot(valid, pos, name):
            """``pos`` decoded a clock later into its lower and upper bits' one-hot
            registers (the upper's 0 unless ``valid``), so that a bit's update is
            one LUT of five registers: the grant's logic into the bits' decode was
            6.4 ns in a 200 MHz SDRAM build, the decode of 256 bits in one clock
            6.9 ns at M = 10."""
            lo = Signal(1 << lo_bits, name=f"{name}_lo", reset_less=True)
            hi = Signal(1 << (abits - lo_bits), name=f"{name}_hi")
            m.d.sync += [lo.eq(1 << pos[:lo_bits]), hi.eq(Mux(valid, 1 << pos[lo_bits:abits], 0))]
            return lo, hi

        # the grant and the fill each registered once, so that both reach the
        # bits three edges after their own (module docstring)
        grant_q, grant_pos = Signal(name="grant_q"), Signal(abits, name="grant_pos_q", reset_less=True)
        fill_q, fill_pos = Signal(name="fill_q"), Signal(abits, name="fill_pos_q", reset_less=True)
        m.d.sync += [grant_q.eq(self.grant), grant_pos.eq(self.grant_pos),
                     fill_q.eq(self.fill_en), fill_pos.eq(self.fill_pos)]
        clear_lo, clear_hi = one_hot(grant_q, grant_pos, "clear")
        set_lo, set_hi = one_hot(fill_q, fill_pos, "set")
        arrived = Signal(self.positions, name="arrived")
        for k in range(self.positions):
            lo, hi = k & ((1 << lo_bits) - 1), k >> lo_bits
            m.d.sync += arrived[k].eq((set_hi[hi] & set_lo[lo]) | (arrived[k] & ~(clear_hi[hi] & clear_lo[lo])))

        late = []
        for k in range(self.reads):
            at = delayed(m, self.read_pos[k], 2, f"read{k}_pos", data=True)
            bits = arrived
            for level in range(self.levels):
                sel = delayed(m, at[2 * level:min(2 * level + 2, abits)], level, f"read{k}_sel{level}", data=True)
                left = Signal(-(-len(bits) // 4), name=f"read{k}_level{level}", reset_less=True)
                for g in range(len(left)):
                    four = bits[4 * g:4 * g + 4]
                    m.d.sync += left[g].eq(Cat(four, Const(0, 4 - len(four))).bit_select(sel, 1))
                bits = left
            matters = Signal(name=f"read{k}_matters")
            m.d.sync += matters.eq(self.read_matters[k])
            matters = delayed(m, matters, 1 + self.levels, f"read{k}_matters")
            bit = Signal(name=f"late{k}")
            m.d.sync += bit.eq(matters & ~bits[0])
            late.append(bit)
        m.d.sync += self.underflow.eq(Cat(*late).any())
        return m
