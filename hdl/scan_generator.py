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

    def __init__(self):
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
        s = self.settings
        rem = Signal(32)
        up = Signal(33)
        down = Signal(34)                   # two's complement: bit 33 set when negative
        m.d.comb += [up.eq(rem + AZIMUTH_CODES), down.eq(rem - AZIMUTH_CODES)]
        with m.If(self.restart):
            m.d.sync += [code.eq(s.start), rem.eq(0)]
        with m.Elif(self.accept & (s.mode == SCAN_MODES["free"])):
            with m.If(~s.anticlockwise):
                with m.If(up >= s.period):
                    m.d.sync += [rem.eq(up - s.period), code.eq(code + 1)]
                with m.Else():
                    m.d.sync += rem.eq(up)
            with m.Else():
                with m.If(down[33]):
                    m.d.sync += [rem.eq(down + s.period), code.eq(code - 1)]
                with m.Else():
                    m.d.sync += rem.eq(down)

    def _acp(self, m, code):
        s = self.settings
        count = Signal(_COUNT_BITS)
        rem = Signal(17)
        n_use = Signal(17, init=ACP_UNLEARNED)
        q_use = Signal(_Q_BITS + 8, init=AZIMUTH_CODES // ACP_UNLEARNED)
        r_use = Signal(17)
        cand_q, cand_r, cand_ready = self._divider(m, count)
        # N, q and r in use: fixed by the settings, or learned
        fixed_n = Signal(17)
        m.d.comb += [fixed_n.eq(1 << s.acp_log2), self.per_rev.eq(Mux(s.auto, n_use, fixed_n))]
        learn = Signal()
        m.d.comb += learn.eq(self.arp & s.auto & ~self.arp_lost & (count >= ACP_MIN_LEARN) & cand_ready
                             & (count <= AZIMUTH_CODES))
        n_eff, q_eff, r_eff = Signal(17), Signal.like(q_use), Signal(17)
        with m.If(~s.auto):
            m.d.comb += [n_eff.eq(fixed_n), q_eff.eq(Const(AZIMUTH_CODES, 17) >> s.acp_log2), r_eff.eq(0)]
        with m.Elif(learn):
            m.d.comb += [n_eff.eq(count), q_eff.eq(cand_q), r_eff.eq(cand_r)]
        with m.Else():
            m.d.comb += [n_eff.eq(n_use), q_eff.eq(q_use), r_eff.eq(r_use)]
        m.d.sync += [n_use.eq(n_eff), q_use.eq(q_eff), r_use.eq(r_eff)]
        with m.If(learn):
            m.d.sync += self.learned.eq(1)
        # the ARP first, then the ACP of the same clock
        count0 = Signal.like(count)
        code0 = Signal.like(code)
        rem0 = Signal.like(rem)
        lost0 = Signal()
        m.d.comb += [count0.eq(Mux(self.arp, 0, count)), code0.eq(Mux(self.arp, 0, code)),
                     rem0.eq(Mux(self.arp, 0, rem)), lost0.eq(~self.arp & self.arp_lost)]
        step_rem = Signal(18)
        m.d.comb += step_rem.eq(rem0 + r_eff)
        with m.If(self.restart):
            m.d.sync += [count.eq(0), code.eq(0), rem.eq(0), self.arp_lost.eq(0), self.learned.eq(0),
                         n_use.eq(ACP_UNLEARNED), q_use.eq(AZIMUTH_CODES // ACP_UNLEARNED), r_use.eq(0)]
        with m.Elif(self.acp):
            m.d.sync += [count.eq(count0 + 1), self.arp_lost.eq(lost0 | (count0 == n_eff))]
            with m.If(step_rem >= n_eff):
                m.d.sync += [rem.eq(step_rem - n_eff), code.eq(code0 + q_eff + 1)]
            with m.Else():
                m.d.sync += [rem.eq(step_rem), code.eq(code0 + q_eff)]
        with m.Elif(self.arp):
            m.d.sync += [count.eq(0), code.eq(0), rem.eq(0), self.arp_lost.eq(0)]

    def _divider(self, m, count):
        """``divmod(2**16, count)`` for a count of at least ACP_MIN_LEARN
        (quotient below 2**9), restarted whenever the count changes: a
        restoring division, one quotient bit a clock. Returns (q, r, ready)."""
        seen = Signal.like(count)
        left = Signal(range(_Q_BITS + 1))
        q = Signal(_Q_BITS)
        r = Signal(17)
        divisor = Signal(_COUNT_BITS + _Q_BITS)
        trial = Signal(_COUNT_BITS + _Q_BITS + 1)
        ready = Signal()
        m.d.comb += trial.eq(r - divisor)
        with m.If(count != seen):
            m.d.sync += [seen.eq(count), left.eq(_Q_BITS), q.eq(0), r.eq(AZIMUTH_CODES), ready.eq(0),
                         divisor.eq(count << (_Q_BITS - 1))]
        with m.Elif(left != 0):
            with m.If(~trial[-1]):
                m.d.sync += [r.eq(trial), q.eq(Cat(1, q))]
            with m.Else():
                m.d.sync += q.eq(Cat(0, q))
            m.d.sync += [divisor.eq(divisor >> 1), left.eq(left - 1)]
        with m.Else():
            m.d.sync += ready.eq(1)
        return q, r, ready
