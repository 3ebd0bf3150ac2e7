"""Stream replay: one period of a windmill's modulation, replayed forever."""

from amaranth.hdl import Module, Signal, Cat, Mux, signed, unsigned
from amaranth.lib import wiring, data
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from .iq import IQ
from .ecp5_primitives import RegisteredRAM
from .ecp5_primitives import RegisteredMultiplier
from ..model.fixedpoint import (STREAM_WIDTH, PHASE_FRAC_BITS, INTERP_FRAC_BITS, INTERPOLATIONS,
                                FIR_PHASE_BITS, FIR_TAPS, FIR_LEAD, FIR_COEF_WIDTH, FIR_COEF_FRAC,
                                FIR_ACC_WIDTH, fir_coefficients, stream_latency, refill_samples,
                                max_phase_increment, min_stream_length)

__all__ = ["StreamReplay"]


class StreamReplay(wiring.Component):
    """Double-buffered stream RAM read by a rate accumulator.

    The phase ``idx + frac/2**32`` (words) advances by ``increment/2**32``
    per enabled sample (``increment < 2**32``: at most one word per sample)
    and wraps exactly at the active length: when ``frac + inc`` carries
    and ``idx == length - 1`` the index returns to 0. The stream word for
    the phase (``interpolation``: ``"hold"`` the word at ``idx``;
    ``"linear"`` interpolated towards ``idx + 1`` with the top 16 fraction
    bits; ``"fir"`` the two-stage interpolator of
    :mod:`rast.model.fixedpoint`) is presented ``latency`` samples later on
    ``o``.

    FIR: a serial multiplier-accumulator computes the intermediate values
    U[J] (one tap per sample) into three registers holding U[J], U[J+1]
    and U[J+2]; when J advances they shift and the MAC starts on U[J+3].
    After reset and after every bank switch the phase is held at 0 and
    ``o`` is 0 for ``refill_samples`` samples while U[0..2] are computed.

    Bank switch: ``swap_req`` marks a switch pending; it happens in the
    sample at which the active stream wraps (the period boundary).
    ``swap_force`` switches at once. A switch toggles the bank, latches
    ``length`` and ``increment`` and restarts the phase at 0.

    Parameters
    ----------
    depth : int
        Words per bank (power of two).
    interpolation : str
        ``"hold"``, ``"linear"`` or ``"fir"``.
    init : sequence of int
        Packed words of bank 0 at power-up.
    init_length, init_increment : int
        Active length and increment at power-up.

    Members
    -------
    en : In(1)
        Advance one sample.
    length : In(range(depth + 1)), increment : In(32)
        Values latched at the next bank switch (1 <= length <= depth).
    swap_req, swap_force : In(1)
    wr_en, wr_bank, wr_addr, wr_data : In
        Write port into the RAM (bank ``wr_bank``).
    o : Out(IQ(16))
    pending, bank : Out(1)
        Current state; ``pending_next``/``bank_next`` after this cycle's step.
    index, active_length : Out
        The read index and the active length (``index < active_length``).
    at_last : Out(1)
        ``index == active_length - 1`` (kept as a register: the wrap decision).
    """

    def __init__(self, depth, *, interpolation="fir", init=(), init_length=None, init_increment=0):
        if not isinstance(depth, int) or isinstance(depth, bool) or depth < 2 or depth & (depth - 1):
            raise ValueError(f"Stream depth must be a power of two of at least 2, not {depth!r}")
        if interpolation not in INTERPOLATIONS:
            raise ValueError(f"Interpolation must be one of {', '.join(INTERPOLATIONS)}, "
                             f"not {interpolation!r}")
        min_length = min_stream_length(interpolation)
        if depth < min_length:
            raise ValueError(f"Stream depth must be at least {min_length} with {interpolation} "
                             f"interpolation, not {depth!r}")
        init = [int(w) & ((1 << 2 * STREAM_WIDTH) - 1) for w in init]
        if len(init) > depth:
            raise ValueError(f"Initial stream must have at most {depth} words, not {len(init)}")
        if init_length is None:
            init_length = max(min_length, len(init))
        if not isinstance(init_length, int) or not min_length <= init_length <= depth:
            raise ValueError(f"Initial length must be an integer in [{min_length}, {depth}], "
                             f"not {init_length!r}")
        max_inc = max_phase_increment(interpolation)
        if not isinstance(init_increment, int) or not 0 <= init_increment <= max_inc:
            raise ValueError(f"Initial increment must be an integer in [0, {max_inc}], "
                             f"not {init_increment!r}")
        self._depth = depth
        self._interpolation = interpolation
        self._init = init
        self._init_length = init_length
        self._init_increment = init_increment
        aw = (depth - 1).bit_length()
        super().__init__({
            "en": In(1),
            "length": In(range(depth + 1), init=init_length),
            "increment": In(PHASE_FRAC_BITS, init=init_increment),
            "swap_req": In(1),
            "swap_force": In(1),
            "wr_en": In(1),
            "wr_bank": In(1),
            "wr_addr": In(aw),
            "wr_data": In(2 * STREAM_WIDTH),
            "o": Out(IQ(STREAM_WIDTH)),
            "pending": Out(1),
            "bank": Out(1),
            "pending_next": Out(1),
            "bank_next": Out(1),
            "index": Out(range(depth)),
            "active_length": Out(range(depth + 1), init=init_length),
            "at_last": Out(1, init=init_length == 1),
        })

    @property
    def depth(self):
        return self._depth

    @property
    def interpolation(self):
        return self._interpolation

    @property
    def latency(self):
        """Samples from the phase register to ``o`` (``stream_latency``)."""
        return stream_latency(self._interpolation)

    @property
    def refill_samples(self):
        return refill_samples(self._interpolation)

    def elaborate(self, platform):
        m = Module()
        D, F = self._depth, PHASE_FRAC_BITS
        en = self.en
        # Both banks in one RAM whose read data passes the block RAM's output
        # register (DP16KD OUTREG on ECP5); with interpolation a second copy
        # serves the second read port (both copies see every write).
        # The read address passes a register of its own next to the block RAMs
        # (``addr_reg``: one more sample of stream latency), so the phase logic
        # is not pulled towards the sixteen block RAMs it addresses (timing).
        rams = [RegisteredRAM(2 * STREAM_WIDTH, 2 * D, init=self._init, addr_reg=True)
                for _ in range(2 if self._interpolation == "linear" else 1)]
        for k, ram in enumerate(rams):
            m.submodules[f"mem{k}" if k else "mem"] = ram
            m.d.comb += [ram.w_addr.eq(Cat(self.wr_addr, self.wr_bank)), ram.w_data.eq(self.wr_data),
                         ram.w_en.eq(self.wr_en)]

        fir = self._interpolation == "fir"
        if fir:
            # The phase is held while the FIR's registers are refilled: from the
            # clock after a switch (``swapped``, a register: timing) for
            # ``refill_samples`` steps, counted by ``refill`` (``muting`` is
            # ``refill != 0`` kept as a register).
            W = self.refill_samples
            refill = Signal(range(W + 1), init=W)
            muting = Signal(init=1)
            swapped = Signal()
            refilling = Signal()
            m.d.comb += refilling.eq(muting | swapped)
            en = Signal()
            m.d.comb += en.eq(self.en & ~refilling)
        idx = self.index
        # The active length is kept as ``length - 1`` (``len_m1``), so the wrap
        # test is an equality of two registers; ``active_length`` is derived.
        len_m1 = Signal(range(D), init=self._init_length - 1)
        m.d.comb += self.active_length.eq(len_m1 + 1)
        bank, pending = self.bank, self.pending
        frac = Signal(F)
        inc = Signal(F, init=self._init_increment)

        idx_n = Signal.like(idx); frac_n = Signal.like(frac); len_n = Signal.like(len_m1)
        inc_n = Signal.like(inc); bank_n = Signal(); pend_n = Signal()
        # ``acc`` is a register holding ``frac + inc`` (its successor computed
        # from registers), so the carry that decides a step or a wrap comes
        # straight from a flip-flop rather than from the end of a carry chain.
        acc = Signal(F + 1, init=self._init_increment)
        acc_n = Signal(F + 1)
        step = Signal(F + 1)
        carry = acc[F]
        wrap = Signal()
        wrap_swap = Signal()
        # ``last`` is ``idx == len_m1`` kept as a register, its successor
        # chosen from compares of registers, so the wrap decision is an AND of
        # flip-flops. (Timing: the compare against ``length - 1`` behind the
        # carry chain of ``frac + inc`` limited the block to 87 MHz; the
        # equality itself, routed into the switch logic, to 86 MHz with FIR.)
        last = Signal(init=self._init_length == 1)
        last_n = Signal()
        m.d.comb += [acc_n.eq(acc), step.eq(acc[:F] + inc), last_n.eq(last), self.at_last.eq(last)]
        m.d.comb += [wrap.eq(carry & last),
                     wrap_swap.eq(en & pending & wrap),
                     idx_n.eq(idx), frac_n.eq(frac), len_n.eq(len_m1), inc_n.eq(inc),
                     bank_n.eq(bank), pend_n.eq(pending),
                     self.pending_next.eq(pending & ~wrap_swap),
                     self.bank_next.eq(bank ^ wrap_swap)]

        # A switch restarts the phase at 0 (and, with FIR, starts a refill).
        swapping = Signal()
        # J (the FIR's intermediate index, whole words and top fraction bits) advances.
        j_step = Signal()
        PB = FIR_PHASE_BITS

        def switch(new_bank):
            return [bank_n.eq(new_bank), len_n.eq(self.length - 1), inc_n.eq(self.increment),
                    idx_n.eq(0), frac_n.eq(0), pend_n.eq(0), acc_n.eq(self.increment),
                    last_n.eq(self.length == 1), swapping.eq(1)]

        # (At a switch this may shift the FIR's registers and count a job: the
        # refill that follows recomputes all of them.)
        m.d.comb += j_step.eq(en & (acc[F - PB:] != frac[F - PB:]))
        with m.If(en):
            with m.If(wrap_swap):
                m.d.comb += switch(~bank)
            with m.Elif(wrap):
                m.d.comb += [idx_n.eq(0), frac_n.eq(acc[:F]), acc_n.eq(step), last_n.eq(len_m1 == 0)]
            with m.Else():
                m.d.comb += [idx_n.eq(idx + carry), frac_n.eq(acc[:F]), acc_n.eq(step)]
                with m.If(carry):
                    m.d.comb += last_n.eq(idx + 1 == len_m1)
        with m.If(self.swap_force):
            m.d.comb += switch(~self.bank_next)
        with m.Elif(self.swap_req):
            m.d.comb += pend_n.eq(1)
        m.d.sync += [idx.eq(idx_n), frac.eq(frac_n), len_m1.eq(len_n), inc.eq(inc_n),
                     bank.eq(bank_n), pending.eq(pend_n), acc.eq(acc_n), last.eq(last_n)]

        if fir:
            m.d.sync += swapped.eq(swapping)
            with m.If(swapped):
                m.d.sync += [refill.eq(W - self.en), muting.eq(1)]
            with m.Elif(self.en & muting):
                m.d.sync += [refill.eq(refill - 1), muting.eq(refill != 1)]
            self._elaborate_fir(m, rams[0], bank, len_m1, frac, swapped, j_step, refilling)
            return m

        w0 = Signal(IQ(STREAM_WIDTH))
        m.d.comb += [rams[0].r_addr.eq(Cat(idx, bank)), rams[0].r_en.eq(en), w0.eq(rams[0].r_data)]
        if self._interpolation == "hold":
            m.d.comb += self.o.eq(w0)
            return m

        # Interpolation: a second read port at idx + 1 (mod length), itself a register.
        idx1 = Signal(range(D))
        m.d.sync += idx1.eq(Mux(idx_n == len_n, 0, idx_n + 1))
        w1 = Signal(IQ(STREAM_WIDTH))
        m.d.comb += [rams[1].r_addr.eq(Cat(idx1, bank)), rams[1].r_en.eq(en), w1.eq(rams[1].r_data)]
        # The fraction follows the words through the RAM's stages (one per
        # RAM latency sample), then meets the difference of the words.
        fds = [Signal(INTERP_FRAC_BITS, name=f"fd{k}") for k in range(rams[0].latency + 1)]
        fa = fds[-1]
        W = STREAM_WIDTH
        with m.If(en):
            m.d.sync += [fds[0].eq(frac[F - INTERP_FRAC_BITS:])]
            m.d.sync += [fds[k].eq(fds[k - 1]) for k in range(1, len(fds))]
        out = Signal(IQ(W))
        for part in ("re", "im"):
            diff = Signal(signed(W + 1), name=f"diff_{part}")
            s0a = Signal(signed(W), name=f"s0a_{part}")
            s0b = Signal(signed(W), name=f"s0b_{part}")
            prod = Signal(signed(W + 1 + INTERP_FRAC_BITS + 1), name=f"prod_{part}")
            with m.If(en):
                m.d.sync += [diff.eq(getattr(w1, part) - getattr(w0, part)),
                             s0a.eq(getattr(w0, part)),
                             prod.eq(diff * fa), s0b.eq(s0a),
                             getattr(out, part).eq(
                                 s0b + ((prod + (1 << (INTERP_FRAC_BITS - 1))) >> INTERP_FRAC_BITS))]
        m.d.comb += self.o.eq(out)
        return m

    def _elaborate_fir(self, m, ram, bank, len_m1, frac, swapped, j_step, refilling):
        """The FIR interpolator: serial MAC into U[J..J+2], then the linear step."""
        D, F, W, T, PB = self._depth, PHASE_FRAC_BITS, STREAM_WIDTH, FIR_TAPS, FIR_PHASE_BITS
        en = self.en
        # U[J], U[J+1], U[J+2]: index 0, 1, 2.
        u = [Signal(IQ(W), name=f"u{k}") for k in range(3)]
        # Next U to compute: word index ``tw`` and phase ``tp`` (target J = tw*2**PB + tp).
        tw = Signal(range(D))
        tp = Signal(PB)
        # ``(tw + FIR_LEAD) mod L``, kept beside ``tw`` (no adder and compare
        # at the start of a job): the word of the job's first tap.
        lead = Signal(range(D), init=FIR_LEAD)
        jobs = Signal(range(4), init=3)          # U values still to compute
        seq = Signal(range(3))                   # destination of the next job (0, 1, then 2)
        issuing = Signal()
        tap = Signal(range(T))
        raddr = Signal(range(D))
        cphase = Signal(PB)
        dest = Signal(range(3))

        start = Signal()
        m.d.comb += start.eq(en & ~issuing & (jobs != 0))
        with m.If(en):
            m.d.sync += jobs.eq(jobs + j_step - start)
            with m.If(j_step):
                m.d.sync += [u[0].eq(u[1]), u[1].eq(u[2])]
        with m.If(start):
            m.d.sync += [issuing.eq(1), tap.eq(0), cphase.eq(tp), dest.eq(seq), raddr.eq(lead),
                         tp.eq(tp + 1)]
            with m.If(seq != 2):
                m.d.sync += seq.eq(seq + 1)
            with m.If(tp == (1 << PB) - 1):
                m.d.sync += [tw.eq(Mux(tw == len_m1, 0, tw + 1)),
                             lead.eq(Mux(lead == len_m1, 0, lead + 1))]
        with m.Elif(en & issuing):
            m.d.sync += [tap.eq(tap + 1), raddr.eq(Mux(raddr == 0, len_m1, raddr - 1))]
            with m.If(tap == T - 1):
                m.d.sync += issuing.eq(0)

        # Coefficient ROM, addressed by (phase, tap); its address is delayed one
        # sample and its output registered in fabric (timing: a block RAM's
        # clock-to-out plus the route to both multipliers limited 8 channels to
        # 83 MHz), so that the coefficient meets the RAM's word (latency 3).
        coefs = fir_coefficients()
        TB = (T - 1).bit_length()
        rom_init = [0] * ((1 << PB) << TB)
        for p, row in enumerate(coefs):
            for k, c in enumerate(row):
                rom_init[(p << TB) | k] = c
        m.submodules.coef_rom = rom = Memory(shape=signed(FIR_COEF_WIDTH), depth=len(rom_init),
                                             init=rom_init)
        rom_rd = rom.read_port(domain="sync")
        ca = Signal(PB + TB, name="coef_addr")
        coef = Signal(signed(FIR_COEF_WIDTH))
        issue = Signal()
        m.d.comb += [issue.eq(issuing), ram.r_en.eq(en), ram.r_addr.eq(Cat(raddr, bank)),
                     rom_rd.en.eq(en), rom_rd.addr.eq(ca)]
        flags = data.StructLayout({"valid": 1, "first": 1, "last": 1, "dest": range(3)})
        fl = [Signal(flags, name=f"mac_flags{k}") for k in range(8)]     # fl[k]: k samples after issue
        m.d.comb += [fl[0].valid.eq(issue), fl[0].first.eq(tap == 0), fl[0].last.eq(tap == T - 1),
                     fl[0].dest.eq(dest)]
        with m.If(en):
            m.d.sync += [ca.eq(Cat(tap, cphase)), coef.eq(rom_rd.data)]
            m.d.sync += [fl[k].eq(fl[k - 1]) for k in range(1, len(fl))]
        # A switch cancels the jobs in flight and starts the refill, one clock
        # later from a register (timing: the switch decision is a compare
        # deep, and this reset fans out to the whole engine).
        with m.If(swapped):
            m.d.sync += [issuing.eq(0), jobs.eq(3), seq.eq(0), tw.eq(0), tp.eq(0), lead.eq(FIR_LEAD)]
            m.d.sync += [fl[k].valid.eq(0) for k in range(1, len(fl))]

        word = Signal(IQ(W))
        m.d.comb += word.eq(ram.r_data)
        # Timing: the word and the coefficient (a block RAM without output
        # register) enter the multiplier's input registers; the rounding and
        # the saturation each have a register stage of their own.
        for part in ("re", "im"):
            mul = RegisteredMultiplier(W, FIR_COEF_WIDTH, input_reg=True)
            m.submodules[f"fir_mul_{part}"] = mul
            m.d.comb += [mul.en.eq(en), mul.a.eq(getattr(word, part)), mul.b.eq(coef)]
            acc = Signal(signed(FIR_ACC_WIDTH), name=f"fir_acc_{part}")
            with m.If(en & fl[5].valid):
                m.d.sync += acc.eq(Mux(fl[5].first, mul.o, acc + mul.o))
            rounded = Signal(signed(FIR_ACC_WIDTH - FIR_COEF_FRAC + 1), name=f"fir_rnd_{part}")
            with m.If(en):
                m.d.sync += rounded.eq((acc + (1 << (FIR_COEF_FRAC - 1))) >> FIR_COEF_FRAC)
            lo, hi = -(1 << (W - 1)), (1 << (W - 1)) - 1
            sat = Mux(rounded > hi, hi, Mux(rounded < lo, lo, rounded))
            for k in range(3):
                with m.If(en & fl[7].valid & fl[7].last & (fl[7].dest == k)):
                    m.d.sync += getattr(u[k], part).eq(sat)

        # Linear step between U[J] and U[J+1]: difference, product, sum.
        f = Signal(INTERP_FRAC_BITS)
        m.d.comb += f.eq(frac[F - PB - INTERP_FRAC_BITS:F - PB])
        f0 = Signal(INTERP_FRAC_BITS)
        mute = [Signal(name=f"mute{k}") for k in range(2)]
        with m.If(en):
            m.d.sync += [f0.eq(f), mute[0].eq(refilling), mute[1].eq(mute[0])]
        out = Signal(IQ(W))
        for part in ("re", "im"):
            diff = Signal(signed(W + 1), name=f"lin_diff_{part}")
            a0 = Signal(signed(W), name=f"lin_a0_{part}")
            # U[J]*2**16 + 2**15: the rounding constant rides with U[J], so the
            # sum and the rounding are one adder.
            a1 = Signal(signed(W + INTERP_FRAC_BITS + 1), name=f"lin_a1_{part}")
            mul = RegisteredMultiplier(W + 1, INTERP_FRAC_BITS + 1)
            m.submodules[f"lin_mul_{part}"] = mul
            m.d.comb += [mul.en.eq(en), mul.a.eq(diff), mul.b.eq(f0)]
            with m.If(en):
                m.d.sync += [diff.eq(getattr(u[1], part) - getattr(u[0], part)),
                             a0.eq(getattr(u[0], part)),
                             a1.eq((a0 << INTERP_FRAC_BITS) + (1 << (INTERP_FRAC_BITS - 1))),
                             getattr(out, part).eq(Mux(mute[1], 0, (a1 + mul.o) >> INTERP_FRAC_BITS))]
        m.d.comb += self.o.eq(out)
