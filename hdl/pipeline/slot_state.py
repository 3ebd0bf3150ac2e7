"""The per-slot state of a pipeline: the stream replay's state machine,
one update per visit, kept round a ring of M positions.

A slot's state (phase index and fraction, the active stream, the pending
switch and bank, the refill after a switch, the fetcher's index, address and
cache position, the consumer's cache position, the FIR's U values and its
job) is at the ring's head at the slot's visit. Stage A makes the decisions
and every sum the update may take, into registers (``st_mid``); stage B
selects the next state from them; the rest of the ring is distributed RAM.
At M = 1 both stages are one clock. The rules are the contract's
(``rast.model.contract.fixedpoint``) and the bit-exact model's."""

from amaranth.hdl import Module, Signal, Mux, Cat, Const
from amaranth.lib import wiring, data
from amaranth.lib.wiring import In, Out

from rast.model.contract.fixedpoint import (ReplayContract, STREAM_WIDTH, PHASE_FRAC_BITS, FIR_PHASE_BITS,
                                            FIR_TAPS, FIR_LEAD, FIR_REFILL_SAMPLES, CACHE_WORDS,
                                            CACHE_FILL_WORDS, visit_cycles)
from ..ecp5_primitives import kept_register, kept_lut
from ..iq import IQ
from ..register_chain import delayed, ring_delay, RAM_DELAY_MIN

__all__ = ["SlotState", "SlotInit", "fetch_tag_layout", "POS_BITS", "MIRROR_LAG", "REQUEST_CYCLES"]

#: Clocks from a slot's completed update to its pending/bank mirrors.
MIRROR_LAG = 1
#: Clocks from a grant (in the visit's stage A) to the pipeline's fetch request
#: on ``req_valid``, ``req_addr`` and ``req_tag``.
REQUEST_CYCLES = 2
#: Bits of a cache position.
POS_BITS = (CACHE_WORDS - 1).bit_length()


def fetch_tag_layout(slots: int) -> data.StructLayout:
    """A fetch's tag inside a pipeline: the cache position it fills and the slot."""
    return data.StructLayout({"pos": POS_BITS, "slot": range(max(2, slots))})


class SlotInit:
    """Power-up stream of one slot: the values the register file resets to
    (``length``, ``increment``, ``base`` as clamped there) and whether a
    channel sits in the slot at all."""

    def __init__(self, present=False, length=1, increment=0, base=0):
        self.present, self.length, self.increment, self.base = present, length, increment, base


class SlotState(wiring.Component):
    """The M slots' states of one pipeline, updated one slot a clock.

    Parameters
    ----------
    contract : ReplayContract
    slot_inits : list of SlotInit
        Per slot the power-up stream.
    rsel_layout : data.StructLayout
        Of ``rsel`` (:class:`~rast.hdl.pipeline.schedule.RegisterSelect`).

    Members
    -------
    rsel : In(rsel_layout)
        The visiting slot's registers.
    length_early : In
        Its LENGTH a clock before the visit (used from M = 3).
    step, offer, vslot : In
        The visit's step flag, fetch offer and slot.
    mac_put : In(3), mac_val : In(IQ(16))
        A finished FIR job's U value for the slot in stage B (one-hot: which).
    head : Out(layout)
        The visiting slot's state (the ring's head).
    mute : Out(1)
        The visiting slot plays nothing this visit (muted, or switched by force).
    grant : Out(1)
        The visiting slot takes the fetch offered.
    present : Out(1)
        A channel sits in the visiting slot.
    pending, bank : Out(1).array(M)
        Per slot, the mirrors of its pending switch and bank, MIRROR_LAG
        clocks after the update that sets them completes.
    req_valid, req_addr, req_tag : Out
        The fetch request, REQUEST_CYCLES after its grant.

    ``ring_states`` (after elaboration): every slot's state in the ring's
    registers, for the formal checks.
    """

    def __init__(self, contract, slot_inits, rsel_layout):
        if not isinstance(contract, ReplayContract):
            raise TypeError(f"Contract must be a ReplayContract, not {contract!r}")
        self._c = contract
        self._inits = list(slot_inits)
        M = contract.slots
        super().__init__({
            "rsel": In(rsel_layout), "length_early": In(rsel_layout.members["length"]),
            "step": In(1), "offer": In(1), "vslot": In(range(max(2, M))),
            "mac_put": In(3), "mac_val": In(IQ(STREAM_WIDTH)),
            "head": Out(self.layout), "mute": Out(1), "grant": Out(1), "present": Out(1),
            "pending": Out(1).array(M), "bank": Out(1).array(M),
            "req_valid": Out(1), "req_addr": Out(contract.pool_address_width),
            "req_tag": Out(fetch_tag_layout(M)),
        })

    @property
    def update_stage(self) -> int:
        """Clocks from a slot's visit to the clock in which its state update
        completes (its second stage at M >= 2)."""
        return 0 if self._c.slots == 1 else 1

    @property
    def layout(self) -> data.StructLayout:
        """The state of one slot."""
        c = self._c
        D = c.pool_words
        R = c.refill_samples
        aw = c.pool_address_width
        return data.StructLayout({
            # phase: index, counted as the steps left to the wrap (len_m1 -
            # index: the compare ahead of the wrap is then with a constant,
            # not an adder's sum, 7.3 ns at two pipelines), fraction; acc =
            # frac + inc (its carry decides the step), last = (left == 0),
            # both kept so the decisions come from flip-flops
            "left": range(D), "frac": PHASE_FRAC_BITS, "acc": PHASE_FRAC_BITS + 1, "last": 1,
            # the active stream (length - 1, increment, pool base)
            "len_m1": range(D), "inc": PHASE_FRAC_BITS, "base": aw,
            "pending": 1, "bank": 1,
            # after a switch: restart the fetcher at the next visit; muted
            # refill steps left; the FIR's jobs may start
            "restart": 1, "muting": 1, "refill": range(R + 1), "jobs_ok": 1,
            # fetcher: words to the stream's end from the next index
            # (len_m1 - index: its wrap is a zero test, not a compare of two
            # fields, a latest path at 64 channels, 5.7 ns), next pool
            # address, cache position, words fetched ahead of the consumer,
            # restart index
            "f_rem": range(D), "f_addr": aw, "f_pos": POS_BITS, "ahead": range(CACHE_WORDS + 1),
            "f_start": range(D),
            # ahead < CACHE_FILL_WORDS, kept beside it: the compare (a carry
            # chain) in front of the fetch grant was the latest path of the
            # 64-channel build (6.3 ns)
            "room": 1,
            # consumer: oldest needed cache position
            "cpos": POS_BITS,
            # FIR: U[J], U[J+1], U[J+2]; the MAC's job state
            "u0": IQ(STREAM_WIDTH), "u1": IQ(STREAM_WIDTH), "u2": IQ(STREAM_WIDTH),
            "tp": FIR_PHASE_BITS, "jobs": range(4), "seq": range(3), "issuing": 1, "adv": 1,
            "tap": range(FIR_TAPS), "rpos": POS_BITS, "cphase": FIR_PHASE_BITS, "dest": range(3),
            # tap == FIR_TAPS - 1, kept beside it: the compare, shared by
            # stage A's release and the MAC's last-tap flag, was a latest
            # path of the 16-channel build (5.5 ns)
            "tap_last": 1,
            # the FIR's J step flags: the phase's bits from F - PB differ
            # between acc and frac (the slot's next step is a J step), and the
            # increment has bits there (every step then is one). Stage A's
            # compare of the two fields, behind the enable, was a 16-channel
            # build's late path (5.4 ns).
            "jne": 1, "inc_hnz": 1,
        })

    def init_state(self, si: SlotInit) -> dict:
        """The power-up state of a slot holding ``si``."""
        c = self._c
        R = c.refill_samples
        back = FIR_LEAD - 1 if c.interpolation == "fir" else 0
        length = si.length
        inc_hnz = int(si.increment >> (PHASE_FRAC_BITS - FIR_PHASE_BITS) != 0)   # frac is 0: jne too
        return {"left": length - 1, "frac": 0, "acc": si.increment, "last": int(length == 1),
                "len_m1": length - 1, "inc": si.increment, "base": si.base,
                "pending": 0, "bank": 0, "restart": 1, "muting": 1, "refill": R,
                "jobs_ok": int(R <= FIR_REFILL_SAMPLES),
                "f_rem": length - 1, "f_addr": si.base, "f_pos": 0, "ahead": 0, "room": 1,
                "f_start": length - back if back and length > back else 0, "cpos": 0,
                "tp": 0, "jobs": 3, "seq": 0, "issuing": 0, "adv": 0, "tap": 0, "rpos": 0,
                "cphase": 0, "dest": 0, "tap_last": int(FIR_TAPS == 1), "jne": inc_hnz, "inc_hnz": inc_hnz}

    def elaborate(self, platform):
        m = Module()
        M = self._c.slots
        V = visit_cycles(M)
        inits = [self.init_state(si) for si in self._inits]

        # Slot 0 visits V clocks after the first period start (clock 1): at
        # clock k the head holds slot (k - 1 - V) mod M, ring position j (the
        # head 0, the update's second stage 1, ...) slot (k - 1 - V - j).
        def init_at(j):
            return inits[(-1 - V - j) % M]
        head = self.head                      # the ring's last register, below
        mid = self._mid_register(init_at)
        d = self._decisions(m, platform, head)
        a = self._candidates(m, platform, head, mid, d)
        nxt = self._select(m, platform, head, mid, d, a)
        self._close_ring(m, platform, nxt, mid, d, init_at)
        self._mirrors(m, nxt)
        # ---- fetch requests ---------------------------------------------------
        # In two registers (REQUEST_CYCLES), the first beside stage A, the
        # valid's a kept one: as a plain register Yosys merged it with stage
        # B's grant (the same input), one flip-flop for the pool's request
        # tree and the state update, far from both (into the fetcher's next
        # address, 5.8-6.0 ns); kept, it was one route from the grant's
        # logic to the requests' OR (6.1 ns).
        req_addr, req_tag = Signal.like(self.req_addr), Signal.like(self.req_tag)
        m.d.sync += [req_addr.eq(head.f_addr), req_tag.pos.eq(head.f_pos), req_tag.slot.eq(self.vslot),
                     self.req_valid.eq(kept_register(m, platform, a["grant"], "req_valid_q", reset=True)),
                     self.req_addr.eq(req_addr), self.req_tag.eq(req_tag)]
        assert REQUEST_CYCLES == 2
        m.d.comb += [self.mute.eq(d["mute_out"]), self.grant.eq(a["grant"])]
        return m

    def _mid_layout(self):
        """Stage A's register: the state and every decision and sum stage B
        selects from (its adders in stage B were most of its paths, 7.0 ns
        at two pipelines)."""
        c, SL = self._c, self.layout
        R = c.refill_samples
        mid_fields = dict(SL.members)
        mid_fields.update({
            "en": 1, "switch": 1, "wrap": 1, "carry": 1, "pend": 1,
            "step": PHASE_FRAC_BITS + 1, "left_one": 1, "left_step": range(c.pool_words), "len0": 1,
            "n_len_m1": range(c.pool_words), "n_inc": PHASE_FRAC_BITS, "n_base": c.pool_address_width,
            "n_last": 1, "n_fstart": range(c.pool_words),
            "grant": 1, "fwrap": 1, "f_rem1": range(c.pool_words), "f_addr1": c.pool_address_width,
            "start": 1, "issue": 1, "last_tap": 1, "release": 1, "jstep": 1,
            "refill1": range(R + 1), "refill_more": 1, "refill_jobs": 1,
            # the sums stage B selects from (its adders were most of its
            # paths, 7.0 ns at two pipelines)
            "f_addr0": SL.members["f_addr"], "f_pos1": SL.members["f_pos"],
            "ahead_up": SL.members["ahead"], "ahead_dn": SL.members["ahead"], "room_up": 1, "room_dn": 1,
            "cpos1": SL.members["cpos"], "rpos0": SL.members["rpos"], "rpos1": SL.members["rpos"],
            "tap1": SL.members["tap"], "tap1_last": 1, "jne_step": 1, "n_jne": 1,
            "tp1": SL.members["tp"], "tp_last": 1,
            "seq1": SL.members["seq"], "jobs_up": SL.members["jobs"], "jobs_dn": SL.members["jobs"],
        })
        if c.start_frac:
            # the new stream's start: START, START + increment, the increment's high bits
            mid_fields.update({"n_frac": PHASE_FRAC_BITS, "n_acc": PHASE_FRAC_BITS + 1, "n_hnz": 1})
        return data.StructLayout(mid_fields)

    def _mid_register(self, init_at):
        c, ML = self._c, self._mid_layout()
        if c.slots == 1:
            return Signal(ML, name="st_mid")
        # at power-up the slot in stage B restarts its fetcher (the only
        # sum it takes then): its restart address beside its state
        i1 = init_at(1)
        f_addr0 = (i1["base"] + i1["f_start"]) % (1 << c.pool_address_width)
        return Signal(ML, init={**i1, "f_addr0": f_addr0}, name="st_mid")

    def _decisions(self, m, platform, st):
        """Stage A's decisions from the head's registers and the slot's
        registers: the forced switch, the switch, the mute."""
        flags, step_v = self.rsel, self.step
        F = PHASE_FRAC_BITS
        force = Signal(); req = Signal(); pend = Signal(); en = Signal(); carry = Signal()
        wrap = Signal(); wrap_sw = Signal(); switch = Signal(); mute_out = Signal()
        m.d.comb += [
            force.eq(flags.force_swap | (flags.force_pending & st.pending)),
            req.eq(flags.swap_req & ~force),
            pend.eq(st.pending | req),
            mute_out.eq(st.muting | force),
            en.eq(step_v & ~mute_out),
            carry.eq(st.acc[F]),
            wrap.eq(carry & st.last),
            wrap_sw.eq(en & pend & wrap),
        ]
        # force | wrap_sw, in two LUT levels: where force is 1 the rest does
        # not matter, so its terms leave the enable and the request (from the
        # enable's and the request's levels the switch and its copies were
        # the 16-channel build's latest paths, 5.4-5.7 ns). The step's half,
        # an unmuted step that wraps, is a LUT of its own: synthesis shared
        # ``carry & last`` with ``wrap`` and put a third LUT on the path
        # (the switch's copy ``mute_sel``, 5.3 ns at 16 channels).
        wrap_step = kept_lut(m, platform, [step_v, st.muting, carry, st.last],
                             lambda s, mu, c, la: s & ~mu & c & la, "wrap_step")
        m.d.comb += switch.eq(force | (wrap_step & (st.pending | flags.swap_req)))
        return dict(force=force, switch=switch, mute_out=mute_out, en=en, wrap=wrap, wrap_sw=wrap_sw,
                    carry=carry, pend=pend)

    def _candidates(self, m, platform, st, mid, d):
        """Every sum and flag stage B may take, into stage A's register."""
        c = self._c
        M, V = c.slots, visit_cycles(c.slots)
        F, PB, T = PHASE_FRAC_BITS, FIR_PHASE_BITS, FIR_TAPS
        fir = c.interpolation == "fir"
        back = FIR_LEAD - 1 if fir else 0
        rg, flags, step_v, offer, vslot = self.rsel, self.rsel, self.step, self.offer, self.vslot
        ML = mid.shape()
        en, switch, wrap, carry, pend = d["en"], d["switch"], d["wrap"], d["carry"], d["pend"]
        present = Const(sum(int(si.present) << k for k, si in enumerate(self._inits)), M)
        a = {}
        a["en"] = en
        a["switch"] = switch
        a["wrap"] = wrap
        a["carry"] = carry
        a["pend"] = pend
        a["step"] = st.acc[:F] + st.inc
        # the words left after an enabled step, chosen here beside the
        # subtraction (the wrap and the carry selecting in stage B, behind the
        # switch and the enable, were late at 16 channels, 5.4 ns): ``left -
        # carry`` in one carry chain before a LUT of three inputs (the
        # decrement's chain, then a multiplexer of five, was among the
        # 16-channel build's paths at 4.8-5.0 ns), as (2 left + 1 - (2 carry
        # + 1)) / 2, so that ``carry`` enters the chain at one bit (as
        # ``left`` plus all ones where carry it entered at every bit, and its
        # register, placed 1.9-2.4 ns from the chain, was late at two seeds
        # of 16-channel builds, 5.2-5.3 ns). Where the ring is registers, the
        # carry comes from a copy of its own (below, at the ring: the head's
        # carry, which fans out to the step's decisions, was 2.0 ns of route
        # from the chain, a 16-channel build's latest path, 5.06 ns).
        carry_left = d["carry_left"] = Signal(name="carry_left")
        left_dec = (Cat(Const(1, 1), st.left) - Cat(Const(1, 1), carry_left))[1:len(st.left) + 1]
        a["left_step"] = Mux(wrap, st.len_m1, left_dec)
        a["left_one"] = st.left == 1
        a["len0"] = st.len_m1 == 0
        # the new stream's length - 1, length == 1 and the fetcher's restart
        # index, from the register values a clock before the visit where the
        # slot multiplexer leaves one (rsel.length -> n_fstart was 6.9 ns)
        def restart_index(n):
            """n - back: the LENGTH clamp keeps every length above ``back``
            (FIR_MIN_LENGTH), so no select is needed. ``max(n - back, 0)``
            made Yosys drive the register's synchronous reset from the
            compare (the 16-channel build's latest path, 5.7 ns)."""
            return (n - back)[:len(n)]
        assert not back or c.min_stream_length > back, "a FIR build's shortest stream must exceed FIR_LEAD - 1"
        new_stream = {"n_len_m1": lambda n: n - 1, "n_last": lambda n: n == 1,
                      "n_fstart": restart_index if back else (lambda n: 0)}
        length_early = self.length_early
        for k, fn in new_stream.items():
            if V >= 2:
                a[k] = Signal(ML.members[k], name=f"rsel_{k}")
                m.d.sync += a[k].eq(fn(length_early))
            else:
                a[k] = fn(rg.length)
        a["n_inc"] = rg.increment
        a["n_base"] = rg.base
        if c.start_frac:
            a["n_frac"] = rg.start
            a["n_acc"] = rg.start + rg.increment
        present_v = self.present
        m.d.comb += present_v.eq(present.bit_select(vslot, 1) if M > 1 else present[0])
        want = st.room & ~st.restart & present_v
        a["grant"] = offer & want
        # f_rem - 1 and its borrow, f_rem == 0, from one carry chain (the
        # compare as LUTs was three levels, late at two of three seeds of a
        # 16-channel build, 5.0-5.2 ns)
        rem_dec = st.f_rem - 1
        a["fwrap"] = rem_dec[-1]
        a["f_rem1"] = rem_dec[:-1]
        a["f_addr1"] = st.f_addr + 1
        a["refill1"] = st.refill - 1
        a["refill_more"] = st.refill != 1
        a["refill_jobs"] = st.refill <= FIR_REFILL_SAMPLES + 1
        a["f_addr0"] = st.base + st.f_start
        a["f_pos1"] = st.f_pos + 1
        a["ahead_up"] = st.ahead + 1
        a["ahead_dn"] = st.ahead - 1
        # room after the step, as ahead_up/ahead_dn < CACHE_FILL_WORDS (their
        # field's wrap included, so that room follows ahead in every state)
        a["room_up"] = (st.ahead < CACHE_FILL_WORDS - 1) | (st.ahead == (1 << len(st.ahead)) - 1)
        a["room_dn"] = (st.ahead < CACHE_FILL_WORDS + 1) & (st.ahead != 0)
        a["cpos1"] = st.cpos + 1
        if fir:
            a["start"] = st.jobs_ok & ~st.issuing & (st.jobs != 0)
            a["issue"] = st.issuing
            a["last_tap"] = st.tap_last
            a["release"] = st.issuing & st.tap_last & st.adv
            # en & jne in two LUT levels, the unforced part a LUT of its own
            # (synthesis made three of its seven inputs: 4.9 ns at 16 channels)
            a["jstep"] = kept_lut(m, platform, [step_v, st.jne, st.muting, flags.force_swap],
                                  lambda s, j, mu, fs: s & j & ~mu & ~fs, "jstep_unforced") \
                & ~(flags.force_pending & st.pending)
            # after a step acc's bits from F - PB are frac's plus the
            # increment's plus the low part's carry: they differ where the
            # increment has bits there or the low part carries
            # (inc_hnz | carry as the carry out of one chain two bits longer:
            # inc_hnz + 1 + carry at the top carries exactly when either is
            # set; the OR as a LUT after the 27-bit chain was 5.0 ns at 16
            # channels)
            a["jne_step"] = (Cat(st.acc[:F - PB], st.inc_hnz) + Cat(st.inc[:F - PB], Const(1, 1)))[F - PB + 1]
            if c.start_frac:
                # the first step's J step flag from START + increment against START
                a["n_jne"] = (rg.start + rg.increment)[F - PB:] != rg.start[F - PB:]
                a["n_hnz"] = rg.increment[F - PB:] != 0
            else:
                a["n_jne"] = rg.increment[F - PB:] != 0
            a["rpos0"] = st.cpos + T - 1
            a["rpos1"] = st.rpos - 1
            a["tap1"] = st.tap + 1
            a["tap1_last"] = st.tap == T - 2
            a["tp1"] = st.tp + 1
            a["tp_last"] = st.tp == (1 << PB) - 1
            a["seq1"] = Mux(st.seq == 2, 2, st.seq + 1)
            a["jobs_up"] = st.jobs + 1
            a["jobs_dn"] = st.jobs - 1
        else:
            a["release"] = en & carry & ~d["wrap_sw"]
        mid_next = Signal(ML, name="mid_next")
        m.d.comb += mid_next.eq(st)            # the state fields pass through
        for k, v in a.items():
            m.d.comb += getattr(mid_next, k).eq(v)
        if M == 1:
            m.d.comb += mid.eq(mid_next)
        else:
            m.d.sync += mid.eq(mid_next)
        return a

    def _select(self, m, platform, st, x, d, a):
        """Stage B: the next state, selected from stage A's register ``x``."""
        c = self._c
        M, SL, R = c.slots, self.layout, c.refill_samples
        F, T = PHASE_FRAC_BITS, FIR_TAPS
        fir = c.interpolation == "fir"
        back = FIR_LEAD - 1 if fir else 0
        switch, force, step_v = d["switch"], d["force"], self.step
        mac_put, mac_val = self.mac_put, self.mac_val
        nxt = Signal(SL, name="st_next")
        m.d.comb += nxt.eq(x.as_value()[:SL.size])
        with m.If(x.switch):
            start, start_acc = (x.n_frac, x.n_acc) if c.start_frac else (0, x.n_inc)
            m.d.comb += [nxt.len_m1.eq(x.n_len_m1), nxt.inc.eq(x.n_inc), nxt.base.eq(x.n_base),
                         nxt.left.eq(x.n_len_m1), nxt.frac.eq(start), nxt.acc.eq(start_acc), nxt.last.eq(x.n_last),
                         nxt.pending.eq(0), nxt.bank.eq(~x.bank), nxt.restart.eq(1),
                         nxt.muting.eq(1), nxt.f_start.eq(x.n_fstart)]
            # (the refill count below)
            if fir:
                # (the job's fields below, from the switch's copy)
                m.d.comb += [nxt.jne.eq(x.n_jne), nxt.inc_hnz.eq(x.n_hnz if c.start_frac else x.n_jne)]
        with m.Else():
            m.d.comb += [nxt.pending.eq(x.pend), nxt.restart.eq(0)]
            with m.If(x.en):
                m.d.comb += [nxt.left.eq(x.left_step), nxt.frac.eq(x.acc[:F]), nxt.acc.eq(x.step)]
                if fir:
                    m.d.comb += nxt.jne.eq(x.jne_step)
                with m.If(x.wrap):
                    m.d.comb += nxt.last.eq(x.len0)
                with m.Elif(x.carry):
                    m.d.comb += nxt.last.eq(x.left_one)
            # the fetcher: restart (the visit after a switch), or one fetch
            # (its index, address and position below)
            with m.If(x.restart):
                m.d.comb += [nxt.ahead.eq(0), nxt.room.eq(1), nxt.cpos.eq(0)]
            with m.Else():
                m.d.comb += [nxt.ahead.eq(Mux(x.grant == x.release, x.ahead,
                                              Mux(x.grant, x.ahead_up, x.ahead_dn))),
                             nxt.room.eq(Mux(x.grant == x.release, x.room,
                                             Mux(x.grant, x.room_up, x.room_dn))),
                             nxt.cpos.eq(Mux(x.release, x.cpos1, x.cpos))]
            if fir:
                with m.If(x.jstep):
                    m.d.comb += [nxt.u0.eq(x.u1), nxt.u1.eq(x.u2)]
        # The fetcher's index, address and position, each field selected by a
        # copy of its own of the selects (kept): one register of each select
        # for all ~50 bits sat far from most of them (the fetch address was
        # among the 16- and 64-channel builds' late endpoints, 5.6-6.2 ns).
        # A switch does not hold them: its visit sets ``restart``, so the next
        # visit grants nothing and restarts them, and what they hold in
        # between is never read. (The switch's three levels of logic into
        # the copies were the 16-channel build's latest path, 6.5 ns.)
        sel = Cat(st.restart, a["grant"])
        for field, restart_value, fetch_value in (
                # (a restart's index is f_start: len_m1 - f_start words left)
                ("f_rem", back - 1 if back else x.len_m1, Mux(x.fwrap, x.len_m1, x.f_rem1)),
                ("f_addr", x.f_addr0, Mux(x.fwrap, x.base, x.f_addr1)),
                ("f_pos", 0, x.f_pos1)):
            if M == 1:
                f_restart, f_grant = sel
            else:
                # at power-up the slot in stage B restarts its fetcher (mid's init)
                f_restart, f_grant = kept_register(m, platform, sel, f"{field}_sel", init=0b01, reset=True)
            with m.If(f_restart):
                m.d.comb += getattr(nxt, field).eq(restart_value)
            with m.Elif(f_grant):
                m.d.comb += getattr(nxt, field).eq(fetch_value)
        # The refill count, the muting flag and the jobs' go-ahead the same
        # way, from copies of the switch, a forced switch in a step and a
        # muted step: from mid's switch and enable (~80 sinks each) the
        # count was the 16-channel build's latest path at seed 3 (5.7 ns).
        # A step is muted only while muting (the enable is off then).
        mute_sel = Cat(switch, force & step_v, step_v & st.muting)
        if M == 1:
            m_switch, m_forced_step, m_muted_step = mute_sel
        else:
            # (0 at power-up and reset, as mid's switch and valid)
            m_switch, m_forced_step, m_muted_step = kept_register(m, platform, mute_sel, "mute_sel", reset=True)
        with m.If(m_switch):
            # a forced switch in a step mutes that step: one refill step spent
            with m.If(m_forced_step):
                m.d.comb += [nxt.refill.eq(R - 1), nxt.jobs_ok.eq(R - 1 <= FIR_REFILL_SAMPLES)]
            with m.Else():
                m.d.comb += [nxt.refill.eq(R), nxt.jobs_ok.eq(R <= FIR_REFILL_SAMPLES)]
        with m.Elif(m_muted_step):
            m.d.comb += [nxt.refill.eq(x.refill1), nxt.muting.eq(x.refill_more),
                         nxt.jobs_ok.eq(x.refill_jobs)]
        if fir:
            # The job's control from the switch's copy too: with mid's switch
            # their clear shared one synchronous reset with ``frac``'s, a net
            # from the step's adder to the FIR's registers (the switch -> the
            # phase ``tp`` through it, 5.12 ns at seed 2 of a 16-channel build).
            with m.If(m_switch):
                # (the first job's phase: START's FIR phase, 0 without it)
                first_tp = x.n_frac[F - FIR_PHASE_BITS:] if c.start_frac else 0
                m.d.comb += [nxt.issuing.eq(0), nxt.jobs.eq(3), nxt.seq.eq(0), nxt.tp.eq(first_tp),
                             nxt.adv.eq(0)]
            with m.Else():
                with m.If(x.start):
                    m.d.comb += [nxt.issuing.eq(1), nxt.tp.eq(x.tp1),
                                 nxt.adv.eq(x.tp_last), nxt.seq.eq(x.seq1)]
                with m.Elif(x.issue):
                    with m.If(x.last_tap):
                        m.d.comb += nxt.issuing.eq(0)
                m.d.comb += nxt.jobs.eq(Mux(x.jstep == x.start, x.jobs,
                                            Mux(x.jstep, x.jobs_up, x.jobs_dn)))
            # The FIR job's read position, tap, phase and destination the same
            # way, from copies of the job's start and issue selects: the
            # switch, their priority and the choice in one clock were late in
            # 16-channel builds (the position in all three seeds, 5.4-5.7 ns;
            # then the tap and phase, 5.4-5.6). A switch does not hold them:
            # it clears ``issuing``, and only a start (which sets them) sets it
            # again, so what they hold in between is never read (a tap's
            # flags go down the MAC with ``issuing`` as their valid).
            job_sel = Cat(a["start"], a["issue"])
            if M == 1:
                r_start, r_issue = job_sel
            else:
                # (0 at power-up and reset, as mid's start and issue)
                r_start, r_issue = kept_register(m, platform, job_sel, "job_sel", reset=True)
            with m.If(r_start):
                m.d.comb += [nxt.rpos.eq(x.rpos0), nxt.tap.eq(0), nxt.tap_last.eq(T == 1),
                             nxt.cphase.eq(x.tp), nxt.dest.eq(x.seq)]
            with m.Elif(r_issue):
                m.d.comb += [nxt.rpos.eq(x.rpos1), nxt.tap.eq(x.tap1), nxt.tap_last.eq(x.tap1_last)]
            # a finished job's U value (never in the same visit as a J step:
            # the increment limit, FIR_MIN_SAMPLES_PER_STEP)
            for k in range(3):
                with m.If(mac_put[k]):
                    m.d.comb += getattr(nxt, f"u{k}").eq(mac_val)
        return nxt

    def _close_ring(self, m, platform, nxt, mid, d, init_at):
        """The ring: head -> [A] -> mid -> [B] -> ... -> head."""
        M, SL, F = self._c.slots, self.layout, PHASE_FRAC_BITS
        head, carry_left, carry = self.head, d["carry_left"], d["carry"]
        # From the update's end back to the head M - 1 clocks (one at M = 1;
        # the head is the last).
        ring_len = max(1, M - 1)
        ring_inits = [init_at((j + 2) % M) for j in range(ring_len - 1)] + [init_at(0)]
        # (input_reg: the update's end into its RAM was 9.3 ns at 64 channels)
        last, regs = ring_delay(m, nxt, ring_len, ring_inits, "st_ring", input_reg=True,
                                 platform=platform)
        m.d.comb += head.eq(last)
        if ring_len < RAM_DELAY_MIN:
            # the copy of the head's carry for ``left - carry`` (above): the
            # same input as the head's register, the same value at power-up and reset
            head_in = regs[-2] if ring_len > 1 else nxt
            m.d.comb += carry_left.eq(kept_register(m, platform, head_in.acc[F], "carry_left_q", reset=True,
                                                    init=(ring_inits[-1]["acc"] >> F) & 1))
        else:
            m.d.comb += carry_left.eq(carry)
        #: Every slot's state in the ring's registers (for the formal checks):
        #: the head and the others of a short ring, and the state part of the
        #: update's second stage (M >= 2).
        self.ring_states = regs + ([SL(mid.as_value()[:SL.size])] if M > 1 else [])

    def _mirrors(self, m, nxt):
        """Mirrors of pending and bank, per slot, from the completed update."""
        M, vslot = self._c.slots, self.vslot
        # Mirrors of pending and bank, per slot, from the completed update, a
        # clock after it (MIRROR_LAG: from the update's logic into every
        # slot's mirror was 6.3-6.4 ns at 64 channels).
        done = Signal(2, name="mirror_update")
        m.d.comb += done.eq(Cat(nxt.pending, nxt.bank))
        done = delayed(m, done, MIRROR_LAG, "mirror_update")
        bslot = delayed(m, vslot, self.update_stage + MIRROR_LAG, "bslot")
        for s in range(M):
            with m.If(bslot == s):
                m.d.sync += [self.pending[s].eq(done[0]), self.bank[s].eq(done[1])]
