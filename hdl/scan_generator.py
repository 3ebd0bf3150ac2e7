"""The beam's azimuth: free running, or following the radar's ACP and ARP
(the contract's rule, ``rast.model.contract.scan``; docs/antenna_scan.md)."""

from amaranth.hdl import Module, Signal, Mux, Const, Cat
from amaranth.lib import data, wiring
from amaranth.lib.wiring import In, Out

from rast.model.contract.scan import AZIMUTH_BITS, AZIMUTH_CODES, ACP_MIN_LEARN, ACP_UNLEARNED

__all__ = ["ScanGenerator", "SCAN_SETTINGS", "SCAN_MODES", "ACP_MIN_CLOCKS"]

#: ``mode`` of the settings.
SCAN_MODES = {"stare": 0, "free": 1, "acp": 2}
#: The settings the register file holds for the generator: ``period`` P
#: (samples a revolution, free), ``start`` (the code a restart loads),
#: ``acp_log2`` (N = 2**acp_log2 ACPs a revolution unless ``auto``).
SCAN_SETTINGS = data.StructLayout({
    "mode": 2, "anticlockwise": 1, "auto": 1, "acp_log2": 5, "period": 32, "start": AZIMUTH_BITS,
})
#: Fewest clocks between two ACPs the generator follows exactly: the
#: candidate count's division (below) takes 10.
ACP_MIN_CLOCKS = 16

_COUNT_BITS = 18            # ACPs since the ARP: past N when an ARP is missed
_Q_BITS = (AZIMUTH_CODES // ACP_MIN_LEARN).bit_length()   # 2**16 // N for N >= ACP_MIN_LEARN


class ScanGenerator(wiring.Component):
    """The beam's code for each step.

    ``beam`` is the code of the step accepted in this clock (``accept``); in
    free mode the generator then advances by one sample: the remainder grows
    (shrinks) by 2**16 and carries into the code modulo ``period``. In acp
    mode each ``acp`` strobe counts and advances the code by
    ``q = 2**16 // N`` and a carry of the remainder ``r = 2**16 mod N``
    (exactly ``floor(k·2**16/N)`` after k ACPs); ``arp`` clears the count, the
    code and ``arp_lost``, and with ``auto`` takes the count as N when it is
    at least ACP_MIN_LEARN and no ARP was missed. The division for a new N is
    done beforehand, on the live count whenever it changes (10 clocks), so
    that an ARP takes it at once. An ACP while the count is N sets
    ``arp_lost``. ``restart`` loads ``start`` (free) or clears the count and
    what was learned (acp). Stare: ``beam`` is 0.

    Parameters
    ----------
    step_clocks : int
        The fewest clocks between two ``accept`` strobes (the engine's M);
        at 2 or more the free beam's next remainder is worked out ahead.

    Members
    -------
    settings : In(SCAN_SETTINGS)
    restart, accept, acp, arp : In(1)
        Strobes; ``acp`` and ``arp`` from :class:`~rast.hdl.acp_input.AcpInput`.
    beam : Out(AZIMUTH_BITS)
    arp_lost, learned : Out(1)
    per_rev : Out(17)
        N in use.
    """

    def __init__(self, *, step_clocks=1):
        if not isinstance(step_clocks, int) or step_clocks < 1:
            raise ValueError(f"step_clocks must be a positive integer (the fewest clocks between two "
                             f"accepted steps), not {step_clocks!r}")
        self._step_clocks = step_clocks
        super().__init__({
            "settings": In(SCAN_SETTINGS), "restart": In(1), "accept": In(1), "acp": In(1), "arp": In(1),
            "beam": Out(AZIMUTH_BITS), "arp_lost": Out(1), "learned": Out(1), "per_rev": Out(17),
        })

    def elaborate(self, platform):
        m = Module()
        s = self.settings
        free_code, acp_code = Signal(AZIMUTH_BITS), Signal(AZIMUTH_BITS)
        m.d.comb += self.beam.eq(Mux(s.mode == SCAN_MODES["free"], free_code,
                                     Mux(s.mode == SCAN_MODES["acp"], acp_code, 0)))
        self._free(m, free_code)
        self._acp(m, acp_code)
        return m

    def _free(self, m, code):
        """The free beam: a step adds 2**16 to the remainder, or, when that
        reaches ``period``, subtracts ``period - 2**16`` and carries into the
        code (anticlockwise: the mirror). ``period - 2**16`` is kept in a
        register. With a step every clock (``step_clocks`` 1) a step is one
        comparison and one adder beside it; with two clocks or more, each
        direction's comparison and both next remainders are registers worked
        out in the clock after each change (a restart sets them for a
        remainder of 0, whichever direction it starts), and a step only
        chooses between them (the 32-bit comparison and adder
        in the step's clock were the scan build's latest path, 7.0 ns)."""
        s = self.settings
        rem = Signal(32)
        gap = Signal(32)                    # period - 2**16 (period >= 2**16: SCAN_PERIOD's clamp)
        m.d.sync += gap.eq(s.period - AZIMUTH_CODES)
        # per direction: whether the step wraps, the remainder if it does, and if not
        turns = {"cw": (rem >= gap, rem - gap, rem + AZIMUTH_CODES),
                 "acw": (rem[AZIMUTH_BITS:] == 0, rem + gap, rem - AZIMUTH_CODES)}
        # (from the period itself: a restart may come in the clock the period is written)
        from_zero = {"cw": (s.period == AZIMUTH_CODES, AZIMUTH_CODES - s.period, AZIMUTH_CODES),
                     "acw": (1, s.period - AZIMUTH_CODES, -AZIMUTH_CODES)}
        if self._step_clocks > 1:
            for way, (wraps, wrapped, stepped) in turns.items():
                ahead = (Signal(name=f"{way}_wraps"), Signal(32, name=f"{way}_wrapped"),
                         Signal(32, name=f"{way}_stepped"))
                with m.If(self.restart):
                    m.d.sync += [a.eq(v) for a, v in zip(ahead, from_zero[way])]
                with m.Else():
                    m.d.sync += [a.eq(v) for a, v in zip(ahead, turns[way])]
                turns[way] = ahead
        cw, acw = turns["cw"], turns["acw"]
        wraps = Mux(s.anticlockwise, acw[0], cw[0])
        with m.If(self.restart):
            m.d.sync += [code.eq(s.start), rem.eq(0)]
        with m.Elif(self.accept & (s.mode == SCAN_MODES["free"])):
            m.d.sync += rem.eq(Mux(s.anticlockwise, Mux(acw[0], acw[1], acw[2]), Mux(cw[0], cw[1], cw[2])))
            with m.If(wraps):
                m.d.sync += code.eq(Mux(s.anticlockwise, code - 1, code + 1))

    def _acp(self, m, code):
        """Following the radar. An event's update takes only values held in
        registers: the ACP's next code and remainder are worked out ahead
        (two clocks after the state last changed, :data:`ACP_MIN_CLOCKS`
        before the next ACP), and an ARP's learned q and r come from the
        division done on the count long before. An ACP within two clocks of
        an ARP takes the values the ARP left for it (an ARP and an ACP a
        clock or two apart after their synchronisers: the radar's pair)."""
        s = self.settings
        count = Signal(_COUNT_BITS)
        rem = Signal(17)
        n_use = Signal(17, init=ACP_UNLEARNED)
        q_use = Signal(_Q_BITS + 8, init=AZIMUTH_CODES // ACP_UNLEARNED)
        r_use = Signal(17)
        # the count is written on every restart, ARP and ACP (a count written
        # with its old value is 0 or 1, which no ARP learns)
        count_written = Signal()
        m.d.sync += count_written.eq(self.restart | self.arp | self.acp)
        cand_q, cand_r, cand_ready = self._divider(m, count, count_written)
        m.d.comb += self.per_rev.eq(Mux(s.auto, n_use, Const(1, 17) << s.acp_log2))
        # N, q and r in use: the settings' unless auto, else what was learned
        with m.If(~s.auto):
            m.d.sync += [n_use.eq(Const(1, 17) << s.acp_log2), q_use.eq(Const(AZIMUTH_CODES, 17) >> s.acp_log2),
                         r_use.eq(0)]
        learn = Signal()
        m.d.comb += learn.eq(self.arp & s.auto & ~self.arp_lost & cand_ready)
        # the next ACP's code and remainder, worked out from the registers in two clocks
        fresh = Signal(range(3))            # clocks since the state changed, up to 2
        s_rem, s_code = Signal(18), Signal(AZIMUTH_BITS)
        nx_rem, nx_code = Signal(17), Signal(AZIMUTH_BITS)
        at_n = Signal()                     # count == N: an ACP now means an ARP was missed
        m.d.sync += [s_rem.eq(rem + r_use), s_code.eq(code + q_use), at_n.eq(count == n_use),
                     fresh.eq(Mux(fresh == 2, 2, fresh + 1))]
        with m.If(s_rem >= n_use):
            m.d.sync += [nx_rem.eq(s_rem - n_use), nx_code.eq(s_code + 1)]
        with m.Else():
            m.d.sync += [nx_rem.eq(s_rem), nx_code.eq(s_code)]
        # what the last ARP left for an ACP within two clocks after it
        last_arp = Signal()
        after_arp_q, after_arp_r = Signal.like(q_use), Signal(17)
        new_q, new_r = Signal.like(q_use), Signal(17)
        m.d.comb += [new_q.eq(Mux(learn, cand_q, q_use)), new_r.eq(Mux(learn, cand_r, r_use))]
        with m.If(self.restart):
            m.d.sync += [count.eq(0), code.eq(0), rem.eq(0), self.arp_lost.eq(0), self.learned.eq(0),
                         n_use.eq(ACP_UNLEARNED), q_use.eq(AZIMUTH_CODES // ACP_UNLEARNED), r_use.eq(0),
                         fresh.eq(0), last_arp.eq(0)]
        with m.Elif(self.arp | self.acp):
            m.d.sync += fresh.eq(0)
            with m.If(self.arp):
                m.d.sync += [self.arp_lost.eq(0), last_arp.eq(1), after_arp_q.eq(new_q), after_arp_r.eq(new_r)]
                with m.If(learn):
                    m.d.sync += [n_use.eq(count), q_use.eq(cand_q), r_use.eq(cand_r), self.learned.eq(1)]
                with m.If(self.acp):        # the ARP first: the revolution's first ACP
                    m.d.sync += [count.eq(1), code.eq(new_q), rem.eq(new_r)]
                with m.Else():
                    m.d.sync += [count.eq(0), code.eq(0), rem.eq(0)]
            with m.Else():
                m.d.sync += [count.eq(count + 1), last_arp.eq(0)]
                with m.If(last_arp & (fresh != 2)):
                    m.d.sync += [code.eq(after_arp_q), rem.eq(after_arp_r)]
                with m.Else():
                    m.d.sync += [code.eq(nx_code), rem.eq(nx_rem), self.arp_lost.eq(self.arp_lost | at_n)]

    def _divider(self, m, count, count_written):
        """``divmod(2**16, count)`` for a count of at least ACP_MIN_LEARN
        (quotient below 2**9), restarted in the clock after the count is
        written (``count_written``): a restoring division, one quotient bit
        a clock. Returns (q, r, ready), ``ready`` only for a count an ARP
        may learn (ACP_MIN_LEARN to 2**16). (Restarted where the count
        differed from the one divided, the 18-bit comparison into the
        enables of the divider's registers was the scan build's latest path
        at seed 1 of ``e2dd592``, 6.2 ns.)"""
        left = Signal(range(_Q_BITS + 1))
        q = Signal(_Q_BITS)
        r = Signal(17)
        divisor = Signal(_COUNT_BITS + _Q_BITS)
        trial = Signal(_COUNT_BITS + _Q_BITS + 1)
        ready = Signal()
        m.d.comb += trial.eq(r - divisor)
        learnable = Signal()
        with m.If(count_written):
            m.d.sync += [left.eq(_Q_BITS), q.eq(0), r.eq(AZIMUTH_CODES), ready.eq(0),
                         divisor.eq(count << (_Q_BITS - 1)),
                         learnable.eq((count >= ACP_MIN_LEARN) & (count <= AZIMUTH_CODES))]
        with m.Elif(left != 0):
            with m.If(~trial[-1]):
                m.d.sync += [r.eq(trial), q.eq(Cat(1, q))]
            with m.Else():
                m.d.sync += q.eq(Cat(0, q))
            m.d.sync += [divisor.eq(divisor >> 1), left.eq(left - 1)]
        with m.Else():
            m.d.sync += ready.eq(learnable)
        return q, r, ready
