"""One time-multiplexed pipeline of the replay engine: M channel slots, one per
fabric clock, sharing one stream interpolator, one complex multiplier, one
gain multiplier and one copy of the delay window."""

from amaranth.hdl import Module, Signal, Mux, Cat, Const, Array, signed, unsigned
from amaranth.lib import wiring, data
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from .iq import IQ
from .cmult import ComplexMultiplier
from .ecp5_primitives import RegisteredMultiplier
from .delay_line import DelayLine
from ..model.fixedpoint import (ReplayContract, STREAM_WIDTH, INPUT_WIDTH, PHASE_FRAC_BITS,
                                INTERP_FRAC_BITS, FIR_PHASE_BITS, FIR_TAPS, FIR_LEAD, FIR_COEF_WIDTH,
                                FIR_COEF_FRAC, FIR_ACC_WIDTH, FIR_REFILL_SAMPLES, CACHE_WORDS,
                                CACHE_FILL_WORDS, PRODUCT_SHIFT, GAIN_SHIFT, SCALED_WIDTH,
                                WINDOW_LAG, VISIT_CYCLES, WORD_CYCLES, GAIN_CYCLES,
                                MAC_RESULT_CYCLES, fir_coefficients, mac_merge_cycles)
from ..model.powerup import ChannelInit

__all__ = ["ChannelPipeline", "SlotInit", "fetch_tag_layout"]

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


def _delay(m, sig, n, name):
    """``sig`` delayed by ``n`` clocks (a chain of registers)."""
    for k in range(n):
        nxt = Signal.like(sig, name=f"{name}_d{k + 1}")
        m.d.sync += nxt.eq(sig)
        sig = nxt
    return sig


class ChannelPipeline(wiring.Component):
    """M channel slots (M = ``contract.slots``) in one pipeline.

    Time is cut into periods of M clocks; a period starts in the clock in
    which the pipeline's slot counter is 0 (``accept`` is high there when the
    period carries an input sample, a *step*). In slot s of a period the
    pipeline reads slot s's registers (``regs[s]``, registered), and one clock
    later slot s's state is at the head of a ring of M state registers: its
    stream word for this step is computed from it, the state is updated (in
    one stage at M = 1, two stages at M >= 2, the second M - 2 plain
    registers behind) and goes round again. Everything after the word (the
    complex product with the slot's tap of the window, the gain, the sum over
    the slots) is a fixed pipeline; ``sum`` holds the period's sum over the
    slots ``sum_cycles`` clocks after the period starts.

    The per-slot state machine is the channel's stream replay: a phase
    accumulator wrapping at the active length, a switch at the period
    boundary (or at once, forced), a muted refill after a switch, a fetcher
    asking the pool for its next words into the slot's part of the word
    cache, and (FIR) the jobs of the serial multiplier-accumulator that
    computes the intermediate values U[J..J+2]. Its rules are the contract's
    (``rast.model.fixedpoint``) and the bit-exact model's
    (``rast.model.datapath.ReplayModel``).

    Parameters
    ----------
    contract : ReplayContract
    index : int
        The pipeline's number p (its fetch tags say it; channel p*M + s is in slot s).
    slot_inits : list of SlotInit
        Per slot (M of them) the power-up stream.
    regs_layout : data.StructLayout
        Of ``regs`` (``rast.hdl.registers.channel_regs_layout``).

    Members
    -------
    accept : In(1)
        An input sample is accepted in this clock (only in a period's first clock).
    regs : In(regs_layout).array(M)
    cmd_ack : Out(1).array(M)
        Slot s's registers are read in this clock (its command is consumed).
    win_data : In(32)
        The common delay line's output c[n] of the period's step, 3 clocks
        after the period starts.
    offer : In(1)
        The fetch scan offers this pipeline's slots a fetch in this period
        (stable from the period's second clock for M clocks).
    req_valid : Out(1), req_addr : Out(pool address), req_tag : Out(fetch_tag_layout)
        A fetch request (registered).
    fill_en : In(1), fill_tag : In(fetch_tag_layout), fill_data : In(32)
        A pool word for one of this pipeline's slots.
    pending, bank : Out(1).array(M)
        Per slot, the state's pending switch and bank (mirrors for read-back).
    sum : Out(IQ(sum width))
        The slot accumulator: the period's sum after the last slot.
    """

    def __init__(self, contract, index, slot_inits, regs_layout):
        if not isinstance(contract, ReplayContract):
            raise TypeError(f"Contract must be a ReplayContract, not {contract!r}")
        M = contract.slots
        if not isinstance(index, int) or isinstance(index, bool) or not 0 <= index < contract.pipelines:
            raise ValueError(f"Pipeline index must be an integer in [0, {contract.pipelines - 1}], "
                             f"not {index!r}")
        slot_inits = list(slot_inits)
        if len(slot_inits) != M or not all(isinstance(s, SlotInit) for s in slot_inits):
            raise ValueError(f"Slot inits must be {M} SlotInit, not {slot_inits!r}")
        self._c = contract
        self._index = index
        self._inits = slot_inits
        aw = contract.pool_address_width
        self._sum_width = contract.sum_width
        super().__init__({
            "accept": In(1),
            "regs": In(regs_layout).array(M),
            "cmd_ack": Out(1).array(M),
            "win_data": In(2 * INPUT_WIDTH),
            "offer": In(1),
            "req_valid": Out(1),
            "req_addr": Out(aw),
            "req_tag": Out(fetch_tag_layout(M)),
            "fill_en": In(1),
            "fill_tag": In(fetch_tag_layout(M)),
            "fill_data": In(2 * STREAM_WIDTH),
            "pending": Out(1).array(M),
            "bank": Out(1).array(M),
            "sum": Out(IQ(self._sum_width)),
        })

    @property
    def sum_cycles(self) -> int:
        """Clocks from the clock that starts a period to the clock in which
        ``sum`` holds its sum over the slots (the last slot's visit, word,
        product, gain, slot accumulator)."""
        c = self._c
        return (c.slots - 1) + VISIT_CYCLES + WORD_CYCLES + c_cmult(c) + GAIN_CYCLES + 1

    @property
    def update_stage(self) -> int:
        """Clocks from a slot's visit to the clock in which its state update
        completes (its second stage at M >= 2)."""
        return 0 if self._c.slots == 1 else 1

    def _state_layout(self):
        c = self._c
        D = c.pool_words
        R = c.refill_samples
        aw = c.pool_address_width
        return data.StructLayout({
            # phase: index, fraction; acc = frac + inc (its carry decides the
            # step), last = (idx == len_m1), both kept so the decisions come
            # from flip-flops
            "idx": range(D), "frac": PHASE_FRAC_BITS, "acc": PHASE_FRAC_BITS + 1, "last": 1,
            # the active stream (length - 1, increment, pool base)
            "len_m1": range(D), "inc": PHASE_FRAC_BITS, "base": aw,
            "pending": 1, "bank": 1,
            # after a switch: restart the fetcher at the next visit; muted
            # refill steps left; the FIR's jobs may start
            "restart": 1, "muting": 1, "refill": range(R + 1), "jobs_ok": 1,
            # fetcher: next stream index and pool address, cache position,
            # words fetched ahead of the consumer, restart index
            "f_idx": range(D), "f_addr": aw, "f_pos": POS_BITS, "ahead": range(CACHE_WORDS + 1),
            "f_start": range(D),
            # consumer: oldest needed cache position
            "cpos": POS_BITS,
            # FIR: U[J], U[J+1], U[J+2]; the MAC's job state
            "u0": IQ(STREAM_WIDTH), "u1": IQ(STREAM_WIDTH), "u2": IQ(STREAM_WIDTH),
            "tp": FIR_PHASE_BITS, "jobs": range(4), "seq": range(3), "issuing": 1, "adv": 1,
            "tap": range(FIR_TAPS), "rpos": POS_BITS, "cphase": FIR_PHASE_BITS, "dest": range(3),
        })

    def _init_state(self, si: SlotInit):
        c = self._c
        R = c.refill_samples
        back = FIR_LEAD - 1 if c.interpolation == "fir" else 0
        length = si.length
        return {"idx": 0, "frac": 0, "acc": si.increment, "last": int(length == 1),
                "len_m1": length - 1, "inc": si.increment, "base": si.base,
                "pending": 0, "bank": 0, "restart": 1, "muting": 1, "refill": R,
                "jobs_ok": int(R <= FIR_REFILL_SAMPLES),
                "f_idx": 0, "f_addr": si.base, "f_pos": 0, "ahead": 0,
                "f_start": length - back if back and length > back else 0, "cpos": 0,
                "tp": 0, "jobs": 3, "seq": 0, "issuing": 0, "adv": 0, "tap": 0, "rpos": 0,
                "cphase": 0, "dest": 0}

    def elaborate(self, platform):
        m = Module()
        c = self._c
        M = c.slots
        F, PB, T = PHASE_FRAC_BITS, FIR_PHASE_BITS, FIR_TAPS
        interp = c.interpolation
        fir = interp == "fir"
        R = c.refill_samples
        back = FIR_LEAD - 1 if fir else 0
        SB = max(1, (M - 1).bit_length())                 # slot bits

        # ---- the slot schedule: rslot (register read), vslot (visit) --------
        rslot = Signal(range(max(2, M)), name="rslot")   # 0 in a period's first clock
        if M > 1:
            m.d.sync += rslot.eq(Mux(rslot == M - 1, 0, rslot + 1))
        start = Signal()
        m.d.comb += start.eq(rslot == 0)
        vslot = _delay(m, rslot, VISIT_CYCLES, "vslot")
        # The period's step flag and step number, held for its M visits.
        W = c.window_depth
        count = Signal(range(W))
        step_v = Signal()
        nidx_v = Signal(range(W))
        with m.If(start):
            m.d.sync += [step_v.eq(self.accept), nidx_v.eq(count)]
            with m.If(self.accept):
                m.d.sync += count.eq(count + 1)

        # ---- register read: slot rslot's registers, registered ---------------
        rl = self.regs[0].shape()
        rsel = Signal(rl, name="rsel")
        m.d.sync += rsel.eq(Array(self.regs)[rslot] if M > 1 else self.regs[0])
        for s in range(M):
            m.d.comb += self.cmd_ack[s].eq(rslot == s)

        # ---- the state ring --------------------------------------------------
        SL = self._state_layout()
        inits = [self._init_state(si) for si in self._inits]
        # Ring position j holds at reset the slot that visits j + 1 clocks
        # later (the head visits slot 0 one clock after reset... see below):
        # at clock k the head holds slot (k - VISIT_CYCLES) mod M.
        def init_at(j):
            return inits[(-VISIT_CYCLES - j) % M]
        head = Signal(SL, init=init_at(0), name="st_head")
        present = Const(sum(int(si.present) << k for k, si in enumerate(self._inits)), M)

        # Stage A: decisions and candidates from the head's registers.
        mid_fields = dict(SL.members)
        mid_fields.update({
            "v": 1, "en": 1, "switch": 1, "force": 1, "wrap": 1, "carry": 1, "pend": 1,
            "step": PHASE_FRAC_BITS + 1, "idx1_eq": 1, "idx1": range(c.pool_words), "len0": 1,
            "n_len_m1": range(c.pool_words), "n_inc": PHASE_FRAC_BITS, "n_base": c.pool_address_width,
            "n_last": 1, "n_fstart": range(c.pool_words),
            "grant": 1, "fwrap": 1, "f_idx1": range(c.pool_words), "f_addr1": c.pool_address_width,
            "start": 1, "issue": 1, "last_tap": 1, "release": 1, "jstep": 1,
            "refill1": range(R + 1), "refill_more": 1, "refill_jobs": 1,
        })
        ML = data.StructLayout(mid_fields)
        mid = Signal(ML, name="st_mid") if M == 1 else Signal(ML, init={**init_at(1)}, name="st_mid")
        st = head
        rg = rsel
        force = Signal(); req = Signal(); pend = Signal(); en = Signal(); carry = Signal()
        wrap = Signal(); wrap_sw = Signal(); switch = Signal(); mute_out = Signal()
        m.d.comb += [
            force.eq(rg.cmd_valid & ~rg.cmd_enable & (rg.cmd_swap | st.pending)),
            req.eq(rg.cmd_valid & rg.cmd_swap & ~force),
            pend.eq(st.pending | req),
            mute_out.eq(st.muting | force),
            en.eq(step_v & ~mute_out),
            carry.eq(st.acc[F]),
            wrap.eq(carry & st.last),
            wrap_sw.eq(en & pend & wrap),
            switch.eq(force | wrap_sw),
        ]
        a = {}
        a["v"] = step_v
        a["en"] = en
        a["switch"] = switch
        a["force"] = force
        a["wrap"] = wrap
        a["carry"] = carry
        a["pend"] = pend
        a["step"] = st.acc[:F] + st.inc
        a["idx1"] = st.idx + 1
        a["idx1_eq"] = (st.idx + 1) == st.len_m1
        a["len0"] = st.len_m1 == 0
        a["n_len_m1"] = rg.length - 1
        a["n_inc"] = rg.increment
        a["n_base"] = rg.base
        a["n_last"] = rg.length == 1
        a["n_fstart"] = Mux(rg.length > back, rg.length - back, 0) if back else 0
        present_v = Signal()
        m.d.comb += present_v.eq(present.bit_select(vslot, 1) if M > 1 else present[0])
        want = (st.ahead < CACHE_FILL_WORDS) & ~st.restart & present_v
        a["grant"] = self.offer & want
        a["fwrap"] = st.f_idx == st.len_m1
        a["f_idx1"] = st.f_idx + 1
        a["f_addr1"] = st.f_addr + 1
        a["refill1"] = st.refill - 1
        a["refill_more"] = st.refill != 1
        a["refill_jobs"] = st.refill <= FIR_REFILL_SAMPLES + 1
        if fir:
            a["start"] = st.jobs_ok & ~st.issuing & (st.jobs != 0)
            a["issue"] = st.issuing
            a["last_tap"] = st.tap == T - 1
            a["release"] = st.issuing & (st.tap == T - 1) & st.adv
            a["jstep"] = en & (st.acc[F - PB:] != st.frac[F - PB:])
        else:
            a["release"] = en & carry & ~wrap_sw
        mid_next = Signal(ML, name="mid_next")
        m.d.comb += mid_next.eq(st)            # the state fields pass through
        for k, v in a.items():
            m.d.comb += getattr(mid_next, k).eq(v)
        if M == 1:
            m.d.comb += mid.eq(mid_next)
        else:
            m.d.sync += mid.eq(mid_next)

        # The FIR's U values, merged in stage B (from the MAC pipeline below).
        mac_wr = Signal(name="mac_wr")
        mac_dest = Signal(range(3), name="mac_dest")
        mac_val = Signal(IQ(STREAM_WIDTH), name="mac_val")

        # Stage B: select the next state from the decisions.
        x = mid
        nxt = Signal(SL, name="st_next")
        m.d.comb += nxt.eq(x.as_value()[:SL.size])
        with m.If(x.switch):
            m.d.comb += [nxt.len_m1.eq(x.n_len_m1), nxt.inc.eq(x.n_inc), nxt.base.eq(x.n_base),
                         nxt.idx.eq(0), nxt.frac.eq(0), nxt.acc.eq(x.n_inc), nxt.last.eq(x.n_last),
                         nxt.pending.eq(0), nxt.bank.eq(~x.bank), nxt.restart.eq(1),
                         nxt.muting.eq(1), nxt.f_start.eq(x.n_fstart)]
            # a forced switch in a step mutes that step: one refill step spent
            with m.If(x.force & x.v):
                m.d.comb += [nxt.refill.eq(R - 1), nxt.jobs_ok.eq(R - 1 <= FIR_REFILL_SAMPLES)]
            with m.Else():
                m.d.comb += [nxt.refill.eq(R), nxt.jobs_ok.eq(R <= FIR_REFILL_SAMPLES)]
            if fir:
                m.d.comb += [nxt.issuing.eq(0), nxt.jobs.eq(3), nxt.seq.eq(0), nxt.tp.eq(0),
                             nxt.adv.eq(0)]
        with m.Else():
            m.d.comb += [nxt.pending.eq(x.pend), nxt.restart.eq(0)]
            with m.If(x.en):
                with m.If(x.wrap):
                    m.d.comb += [nxt.idx.eq(0), nxt.frac.eq(x.acc[:F]), nxt.acc.eq(x.step),
                                 nxt.last.eq(x.len0)]
                with m.Else():
                    m.d.comb += [nxt.idx.eq(Mux(x.carry, x.idx1, x.idx)), nxt.frac.eq(x.acc[:F]),
                                 nxt.acc.eq(x.step)]
                    with m.If(x.carry):
                        m.d.comb += nxt.last.eq(x.idx1_eq)
            with m.Elif(x.v & x.muting):
                m.d.comb += [nxt.refill.eq(x.refill1), nxt.muting.eq(x.refill_more),
                             nxt.jobs_ok.eq(x.refill_jobs)]
            # the fetcher: restart (the visit after a switch), or one fetch
            with m.If(x.restart):
                m.d.comb += [nxt.f_idx.eq(x.f_start), nxt.f_addr.eq(x.base + x.f_start),
                             nxt.f_pos.eq(0), nxt.ahead.eq(0), nxt.cpos.eq(0)]
            with m.Else():
                with m.If(x.grant):
                    m.d.comb += [nxt.f_idx.eq(Mux(x.fwrap, 0, x.f_idx1)),
                                 nxt.f_addr.eq(Mux(x.fwrap, x.base, x.f_addr1)),
                                 nxt.f_pos.eq(x.f_pos + 1)]
                m.d.comb += [nxt.ahead.eq(x.ahead + x.grant - x.release),
                             nxt.cpos.eq(x.cpos + x.release)]
            if fir:
                with m.If(x.start):
                    m.d.comb += [nxt.issuing.eq(1), nxt.tap.eq(0), nxt.cphase.eq(x.tp),
                                 nxt.dest.eq(x.seq), nxt.rpos.eq(x.cpos + T - 1), nxt.tp.eq(x.tp + 1),
                                 nxt.adv.eq(x.tp == (1 << PB) - 1),
                                 nxt.seq.eq(Mux(x.seq == 2, 2, x.seq + 1))]
                with m.Elif(x.issue):
                    m.d.comb += [nxt.tap.eq(x.tap + 1), nxt.rpos.eq(x.rpos - 1)]
                    with m.If(x.last_tap):
                        m.d.comb += nxt.issuing.eq(0)
                m.d.comb += nxt.jobs.eq(x.jobs + x.jstep - x.start)
                with m.If(x.jstep):
                    m.d.comb += [nxt.u0.eq(x.u1), nxt.u1.eq(x.u2)]
        if fir:
            # a finished job's U value (never in the same visit as a J step:
            # the increment limit, FIR_MIN_SAMPLES_PER_STEP)
            with m.If(mac_wr):
                with m.Switch(mac_dest):
                    for k in range(3):
                        with m.Case(k):
                            m.d.comb += getattr(nxt, f"u{k}").eq(mac_val)

        # The ring: head -> [A] -> mid -> [B] -> ... -> head.
        ring = [Signal(SL, init=init_at(j), name=f"st_ring{j}") for j in range(2, M)]
        if ring:
            m.d.sync += ring[0].eq(nxt)
            for j in range(1, len(ring)):
                m.d.sync += ring[j].eq(ring[j - 1])
            m.d.sync += head.eq(ring[-1])
        else:
            m.d.sync += head.eq(nxt)
        #: Every slot's state in the ring (for the formal checks): the head, the
        #: state part of the update's second stage (M >= 2), the rest.
        self.ring_states = [head] + ([SL(mid.as_value()[:SL.size])] if M > 1 else []) + ring

        # Mirrors of pending and bank, per slot, from the completed update.
        bslot = _delay(m, vslot, self.update_stage, "bslot")
        for s in range(M):
            with m.If(bslot == s):
                m.d.sync += [self.pending[s].eq(nxt.pending), self.bank[s].eq(nxt.bank)]

        # ---- fetch requests ---------------------------------------------------
        with m.If(1):
            m.d.sync += [self.req_valid.eq(a["grant"]), self.req_addr.eq(st.f_addr),
                         self.req_tag.pos.eq(st.f_pos), self.req_tag.slot.eq(vslot)]

        # ---- the word cache: M x CACHE_WORDS words, by (slot, position) ----------
        depth = CACHE_WORDS << (SB if M > 1 else 0)
        copies = 2 if interp == "linear" else 1
        caches = []
        for k in range(copies):
            # distributed RAM: a few words per slot, read and written every clock
            # (Yosys would otherwise take the registered read into a block RAM)
            mem = Memory(shape=unsigned(2 * STREAM_WIDTH), depth=depth, init=[],
                         attrs={"ram_style": "distributed"})
            m.submodules[f"cache{k}"] = mem
            wp = mem.write_port()
            m.d.comb += [wp.en.eq(self.fill_en), wp.data.eq(self.fill_data),
                         wp.addr.eq(Cat(self.fill_tag.pos, self.fill_tag.slot[:SB]) if M > 1
                                    else self.fill_tag.pos)]
            caches.append(mem.read_port(domain="comb"))

        def cache_addr(pos):
            pos = pos[:POS_BITS]
            return Cat(pos, vslot[:SB]) if M > 1 else pos

        # ---- the word: a + round((b - a) * f, 16) -------------------------------
        wa = Signal(IQ(STREAM_WIDTH), name="word_a")
        wb = Signal(IQ(STREAM_WIDTH), name="word_b")
        wf = Signal(INTERP_FRAC_BITS, name="word_f")
        if fir:
            m.d.comb += [wa.eq(st.u0), wb.eq(st.u1),
                         wf.eq(st.frac[F - PB - INTERP_FRAC_BITS:F - PB])]
        else:
            m.d.comb += [caches[0].addr.eq(cache_addr(st.cpos)), wa.eq(caches[0].data)]
            if interp == "linear":
                m.d.comb += [caches[1].addr.eq(cache_addr(st.cpos + 1)), wb.eq(caches[1].data),
                             wf.eq(st.frac[F - INTERP_FRAC_BITS:])]
            else:
                m.d.comb += [wb.eq(caches[0].data), wf.eq(0)]
        a1 = Signal.like(wa, name="word_a1"); b1 = Signal.like(wb, name="word_b1")
        f1 = Signal.like(wf, name="word_f1"); mute1 = Signal(name="word_mute1")
        m.d.sync += [a1.eq(wa), b1.eq(wb), f1.eq(wf), mute1.eq(mute_out)]
        word = Signal(IQ(STREAM_WIDTH), name="word")
        mute = _delay(m, mute1, 3, "word_mute")
        if interp == "hold":
            # the word itself, as late as the interpolated one would be
            a4 = _delay(m, a1, 3, "word_hold")
            m.d.sync += word.eq(Mux(mute, 0, a4))
        else:
            f2 = _delay(m, f1, 1, "word_f")
            for part in ("re", "im"):
                diff = Signal(signed(STREAM_WIDTH + 1), name=f"word_diff_{part}")
                a2 = Signal(signed(STREAM_WIDTH), name=f"word_a2_{part}")
                m.d.sync += [diff.eq(getattr(b1, part) - getattr(a1, part)), a2.eq(getattr(a1, part))]
                mul = RegisteredMultiplier(STREAM_WIDTH + 1, INTERP_FRAC_BITS + 1, input_reg=True)
                m.submodules[f"lin_mul_{part}"] = mul
                m.d.comb += [mul.en.eq(1), mul.a.eq(diff), mul.b.eq(f2)]
                # a*2**16 + 2**15: the rounding constant rides with a (in its
                # zero low bits), so the sum and the rounding are one adder
                a4 = _delay(m, a2, 2, f"word_a4_{part}")
                a4r = Cat(Const(1 << (INTERP_FRAC_BITS - 1), INTERP_FRAC_BITS), a4).as_signed()
                m.d.sync += getattr(word, part).eq(Mux(mute, 0, (a4r + mul.o) >> INTERP_FRAC_BITS))

        # ---- the FIR's serial MAC: one tap per visit of a slot -------------------
        if fir:
            self._elaborate_mac(m, st, vslot, caches[0], cache_addr, mac_wr, mac_dest, mac_val)

        # ---- the window: written once per step, read at each slot's tap ---------
        m.submodules.window = win = DelayLine(2 * INPUT_WIDTH, c.max_tap, WINDOW_LAG)
        assert win.depth == W
        wdata = Signal(2 * INPUT_WIDTH, name="win_wdata")
        wen = Signal(name="win_wen")
        windex = Signal(range(W), name="win_windex")
        # c[n] arrives 3 clocks into the period: registered here, written a clock later.
        m.d.sync += [wdata.eq(self.win_data), wen.eq(_delay(m, start & self.accept, 3, "win_en")),
                     windex.eq(_delay(m, nidx_v, 2, "win_index"))]
        m.d.comb += [win.w_en.eq(wen), win.w_index.eq(windex), win.w_data.eq(wdata)]
        # The slot's tap, read two clocks after its visit: its sample is out
        # with the word.
        m.d.comb += [win.r_index.eq(_delay(m, nidx_v, 2, "win_rindex")),
                     win.r_delay.eq(_delay(m, rg.tap, 2, "win_rdelay"))]
        assert 2 + win.latency == WORD_CYCLES

        # ---- complex product, gain, slot accumulator -----------------------------
        m.submodules.cmult = cm = ComplexMultiplier(INPUT_WIDTH, STREAM_WIDTH, PRODUCT_SHIFT, c.cmult_form)
        tdata = Signal(IQ(INPUT_WIDTH), name="tap_sample")
        m.d.comb += [tdata.eq(win.o), cm.en.eq(1), cm.a.eq(tdata), cm.b.eq(word)]
        geff = Signal(rg.gain.shape(), name="geff")
        m.d.comb += geff.eq(Mux(rg.enable, rg.gain, 0))
        g = _delay(m, geff, WORD_CYCLES + cm.latency, "gain")
        q = Signal(IQ(SCALED_WIDTH), name="q")
        for part in ("re", "im"):
            mul = RegisteredMultiplier(cm.o_width, len(geff) + 1, input_reg=True)
            m.submodules[f"gain_mul_{part}"] = mul
            m.d.comb += [mul.en.eq(1), mul.a.eq(getattr(cm.o, part)), mul.b.eq(g)]
            m.d.sync += getattr(q, part).eq((mul.o + (1 << (GAIN_SHIFT - 1))) >> GAIN_SHIFT)
        assert 2 + 1 == GAIN_CYCLES
        qslot = _delay(m, vslot, WORD_CYCLES + cm.latency + GAIN_CYCLES, "qslot")
        first = qslot == 0
        for part in ("re", "im"):
            s_ = getattr(self.sum, part)
            m.d.sync += s_.eq(Mux(first, getattr(q, part), s_ + getattr(q, part)))
        return m

    def _elaborate_mac(self, m, st, vslot, cache, cache_addr, mac_wr, mac_dest, mac_val):
        """The FIR's multiplier-accumulator: a visiting slot with a job in issue
        reads its tap's word (cache) and coefficient (ROM); the product is
        accumulated in a ring of M accumulators (one per slot), rounded and
        saturated at the job's last tap, and merged into the slot's state
        ``mac_merge_cycles`` clocks after the visit (``mac_wr`` and friends)."""
        c = self._c
        M = c.slots
        T, PB, W = FIR_TAPS, FIR_PHASE_BITS, STREAM_WIDTH
        TB = (T - 1).bit_length()
        coefs = fir_coefficients()
        rom_init = [0] * ((1 << PB) << TB)
        for p, row in enumerate(coefs):
            for k, v in enumerate(row):
                rom_init[(p << TB) | k] = v
        # in logic, not a block RAM: the block RAMs are the pool's and the delays'
        m.submodules.coef_rom = rom = Memory(shape=signed(FIR_COEF_WIDTH), depth=len(rom_init),
                                             init=rom_init, attrs={"rom_style": "logic"})
        rd = rom.read_port(domain="comb")
        m.d.comb += [rd.addr.eq(Cat(st.tap, st.cphase)), cache.addr.eq(cache_addr(st.rpos))]
        flags = data.StructLayout({"valid": 1, "first": 1, "last": 1, "dest": range(3)})
        f0 = Signal(flags, name="mac_f0")
        m.d.comb += [f0.valid.eq(st.issuing), f0.first.eq(st.tap == 0), f0.last.eq(st.tap == T - 1),
                     f0.dest.eq(st.dest)]
        word = Signal(IQ(W), name="mac_word")
        coef = Signal(signed(FIR_COEF_WIDTH), name="mac_coef")
        m.d.sync += [word.eq(cache.data), coef.eq(rd.data)]
        f3 = _delay(m, f0, 3, "mac_f")                      # with the product
        f4 = _delay(m, f3, 1, "mac_f4")
        f5 = _delay(m, f4, 1, "mac_f5")
        res = Signal(IQ(W), name="mac_res")
        resf = Signal(flags, name="mac_resf")
        m.d.sync += resf.eq(f5)
        for part in ("re", "im"):
            mul = RegisteredMultiplier(W, FIR_COEF_WIDTH, input_reg=True)
            m.submodules[f"fir_mul_{part}"] = mul
            m.d.comb += [mul.en.eq(1), mul.a.eq(getattr(word, part)), mul.b.eq(coef)]
            ring = [Signal(signed(FIR_ACC_WIDTH), name=f"fir_acc{j}_{part}") for j in range(M)]
            new = Mux(f3.valid, Mux(f3.first, mul.o, ring[-1] + mul.o), ring[-1])
            m.d.sync += ring[0].eq(new)
            for j in range(1, M):
                m.d.sync += ring[j].eq(ring[j - 1])
            rounded = Signal(signed(FIR_ACC_WIDTH - FIR_COEF_FRAC + 1), name=f"fir_rnd_{part}")
            m.d.sync += rounded.eq((ring[0] + (1 << (FIR_COEF_FRAC - 1))) >> FIR_COEF_FRAC)
            lo, hi = -(1 << (W - 1)), (1 << (W - 1)) - 1
            m.d.sync += getattr(res, part).eq(Mux(rounded > hi, hi, Mux(rounded < lo, lo, rounded)))
        assert 1 + 2 + 1 + 1 + 1 == MAC_RESULT_CYCLES
        pad = mac_merge_cycles(M) - MAC_RESULT_CYCLES
        res_d = _delay(m, res, pad, "mac_res")
        resf_d = _delay(m, resf, pad, "mac_resf")
        m.d.comb += [mac_wr.eq(resf_d.valid & resf_d.last), mac_dest.eq(resf_d.dest), mac_val.eq(res_d)]


def c_cmult(c):
    from ..model.fixedpoint import CMULT_CYCLES
    return CMULT_CYCLES[c.cmult_form]
