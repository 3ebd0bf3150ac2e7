"""Stream replay: one period of a windmill's modulation, replayed forever."""

from amaranth.hdl import Module, Signal, Cat, Mux, signed
from amaranth.lib import wiring, data
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from .iq import IQ
from .ecp5_primitives import RegisteredRAM
from .ecp5_primitives import RegisteredMultiplier
from ..model.fixedpoint import (STREAM_WIDTH, PHASE_FRAC_BITS, INTERP_FRAC_BITS, INTERPOLATIONS,
                                FIR_PHASE_BITS, FIR_TAPS, FIR_LEAD, FIR_COEF_WIDTH, FIR_COEF_FRAC,
                                FIR_ACC_WIDTH, FIR_REFILL_SAMPLES, CACHE_WORDS, CACHE_FILL_WORDS,
                                fir_coefficients, stream_latency, refill_samples,
                                max_phase_increment, min_stream_length)

__all__ = ["StreamReplay", "FETCH_TAG"]

#: A fetch's tag: the cache position it fills and the generation (switch
#: count modulo 8) it was asked in. Eight generations: every answer arrives
#: within POOL_FETCH_LATENCY (< 8) clocks, and a switch takes at least a clock.
FETCH_TAG = data.StructLayout({"pos": (CACHE_WORDS - 1).bit_length(), "gen": 3})


class StreamReplay(wiring.Component):
    """One channel's stream, read from the stream pool through a word cache,
    stepped by a rate accumulator.

    The phase ``idx + frac/2**32`` (words) advances by ``increment/2**32``
    per enabled sample (at most one word per ``channels`` samples, see
    :func:`~rast.model.fixedpoint.max_phase_increment`) and wraps exactly at
    the active length: when ``frac + inc`` carries and ``idx == length - 1``
    the index returns to 0. The stream word for the phase (``interpolation``:
    ``"hold"`` the word at ``idx``; ``"linear"`` interpolated towards ``idx +
    1`` with the top 16 fraction bits; ``"fir"`` the two-stage interpolator of
    :mod:`rast.model.fixedpoint`) is presented ``latency`` samples later on
    ``o``.

    Word cache: CACHE_WORDS words indexed by *position* (the count of words
    fetched since the last switch, modulo CACHE_WORDS), so the stream's wrap
    at LENGTH is the fetcher's business alone. The fetcher asks for its next
    word (``fetch_want``, ``fetch_addr``, ``fetch_tag``) while fewer than
    CACHE_FILL_WORDS words from the consumer's oldest needed position on are
    fetched; the pool's answer comes back on ``fill_*`` with the tag. The
    tag's generation (a count of switches) drops answers to requests made
    before a switch.

    FIR: a serial multiplier-accumulator computes the intermediate values
    U[J] (one tap per sample, from the cache) into three registers holding
    U[J], U[J+1] and U[J+2]; when J advances they shift and the MAC starts on
    U[J+3].

    Switch: ``swap_req`` marks a switch pending; it happens in the sample at
    which the active stream wraps (the period boundary). ``swap_force``
    switches at once. A switch toggles ``bank``, latches ``base``, ``length``
    and ``increment``, restarts the phase at 0 and the fetcher at the new
    stream. After reset and after every switch the phase is held at 0 and
    ``o`` is 0 for ``refill_samples`` samples while the cache fills (and the
    FIR computes U[0..2]).

    Parameters
    ----------
    pool_words : int
        Words of the pool (its address width is the fetch address width).
    channels : int
        Channels sharing the pool's fetch scan (sets the refill time and the
        largest increment).
    interpolation : str
        ``"hold"``, ``"linear"`` or ``"fir"``.
    init_base, init_length, init_increment : int
        Active stream at power-up.

    Members
    -------
    en : In(1)
        Advance one sample.
    base : In(pool address), length : In(range(pool_words + 1)), increment : In(32)
        Values latched at the next switch (1 <= length <= pool_words).
    swap_req, swap_force : In(1)
    fetch_want : Out(1), fetch_addr : Out(pool address), fetch_tag : Out(FETCH_TAG)
    fetch_grant : In(1)
        The fetch scan takes this clock's request.
    fill_en : In(1), fill_tag : In(FETCH_TAG), fill_data : In(32)
        A pool word for this channel (tag as requested).
    o : Out(IQ(16))
    pending, bank : Out(1)
        Current state; ``pending_next``/``bank_next`` after this cycle's step.
    index, active_length, active_base : Out
        The read index and the active stream (``index < active_length``).
    fetch_index : Out
        Stream index of the next fetch (``fetch_addr`` is ``active_base +
        fetch_index``, except while ``restarting``).
    restarting : Out(1)
        The clock after a switch, in which the fetcher restarts (and asks nothing).
    at_last : Out(1)
        ``index == active_length - 1`` (kept as a register: the wrap decision).
    """

    def __init__(self, pool_words, *, channels=1, interpolation="fir", init_base=0,
                 init_length=None, init_increment=0):
        if not isinstance(pool_words, int) or isinstance(pool_words, bool) or pool_words < 16:
            raise ValueError(f"Pool words must be an integer of at least 16, not {pool_words!r}")
        if not isinstance(channels, int) or isinstance(channels, bool) or not 1 <= channels <= 64:
            raise ValueError(f"Channels must be an integer in [1, 64], not {channels!r}")
        if interpolation not in INTERPOLATIONS:
            raise ValueError(f"Interpolation must be one of {', '.join(INTERPOLATIONS)}, "
                             f"not {interpolation!r}")
        min_length = min_stream_length(interpolation)
        aw = (pool_words - 1).bit_length()
        if not isinstance(init_base, int) or not 0 <= init_base < (1 << aw):
            raise ValueError(f"Initial base must be a pool address in [0, {(1 << aw) - 1}], "
                             f"not {init_base!r}")
        if init_length is None:
            init_length = min_length
        if not isinstance(init_length, int) or not min_length <= init_length <= pool_words:
            raise ValueError(f"Initial length must be an integer in [{min_length}, {pool_words}], "
                             f"not {init_length!r}")
        max_inc = max_phase_increment(interpolation, channels)
        if not isinstance(init_increment, int) or not 0 <= init_increment <= max_inc:
            raise ValueError(f"Initial increment must be an integer in [0, {max_inc}], "
                             f"not {init_increment!r}")
        self._depth = pool_words
        self._channels = channels
        self._interpolation = interpolation
        self._init_base = init_base
        self._init_length = init_length
        self._init_increment = init_increment
        super().__init__({
            "en": In(1),
            "base": In(aw, init=init_base),
            "length": In(range(pool_words + 1), init=init_length),
            "increment": In(PHASE_FRAC_BITS, init=init_increment),
            "swap_req": In(1),
            "swap_force": In(1),
            "fetch_want": Out(1),
            "fetch_addr": Out(aw),
            "fetch_tag": Out(FETCH_TAG),
            "fetch_grant": In(1),
            "fill_en": In(1),
            "fill_tag": In(FETCH_TAG),
            "fill_data": In(2 * STREAM_WIDTH),
            "o": Out(IQ(STREAM_WIDTH)),
            "pending": Out(1),
            "bank": Out(1),
            "pending_next": Out(1),
            "bank_next": Out(1),
            "index": Out(range(pool_words)),
            "active_length": Out(range(pool_words + 1), init=init_length),
            "active_base": Out(aw, init=init_base),
            "fetch_index": Out(range(pool_words)),
            "restarting": Out(1),
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
        return refill_samples(self._interpolation, self._channels)

    def elaborate(self, platform):
        m = Module()
        D, F = self._depth, PHASE_FRAC_BITS
        interp = self._interpolation
        fir = interp == "fir"
        # The cache: CACHE_WORDS words by position, read through a registered
        # address and an output register (latency 3, as the stream RAM before
        # it); linear interpolation reads two positions, from two copies.
        caches = [RegisteredRAM(2 * STREAM_WIDTH, CACHE_WORDS, addr_reg=True, block_ram=False)
                  for _ in range(2 if interp == "linear" else 1)]
        for k, ram in enumerate(caches):
            m.submodules[f"cache{k}" if k else "cache"] = ram

        # Refill: from the clock after a switch (``swapped``, a register:
        # timing) the phase is held at 0 and the output muted for
        # ``refill_samples`` steps, counted by ``refill`` (``muting`` is
        # ``refill != 0`` kept as a register). The FIR's jobs may start once
        # the cache is full (``jobs_ok``: the last FIR_REFILL_SAMPLES steps).
        W = self.refill_samples
        refill = Signal(range(W + 1), init=W)
        muting = Signal(init=1)
        jobs_ok = Signal(init=W <= FIR_REFILL_SAMPLES)
        swapped = Signal()
        refilling = Signal()
        m.d.comb += refilling.eq(muting)
        en = Signal()
        m.d.comb += en.eq(self.en & ~refilling)
        idx = self.index
        # The active length is kept as ``length - 1`` (``len_m1``), so the wrap
        # test is an equality of two registers; ``active_length`` is derived.
        len_m1 = Signal(range(D), init=self._init_length - 1)
        m.d.comb += self.active_length.eq(len_m1 + 1)
        base = Signal.like(self.base, init=self._init_base)
        bank, pending = self.bank, self.pending
        frac = Signal(F)
        inc = Signal(F, init=self._init_increment)

        idx_n = Signal.like(idx); frac_n = Signal.like(frac); len_n = Signal.like(len_m1)
        inc_n = Signal.like(inc); bank_n = Signal(); pend_n = Signal(); base_n = Signal.like(base)
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
                     bank_n.eq(bank), pend_n.eq(pending), base_n.eq(base),
                     self.pending_next.eq(pending & ~wrap_swap),
                     self.bank_next.eq(bank ^ wrap_swap)]

        # A switch restarts the phase at 0 and, a clock later, the fetcher.
        swapping = Signal()

        def switch(new_bank):
            return [bank_n.eq(new_bank), len_n.eq(self.length - 1), inc_n.eq(self.increment),
                    base_n.eq(self.base),
                    idx_n.eq(0), frac_n.eq(0), pend_n.eq(0), acc_n.eq(self.increment),
                    last_n.eq(self.length == 1), swapping.eq(1)]

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
                     bank.eq(bank_n), pending.eq(pend_n), acc.eq(acc_n), last.eq(last_n),
                     base.eq(base_n)]

        m.d.sync += swapped.eq(swapping)
        with m.If(swapped):
            m.d.sync += [refill.eq(W - self.en), muting.eq(1), jobs_ok.eq(W - 1 <= FIR_REFILL_SAMPLES)]
        with m.Elif(self.en & muting):
            m.d.sync += [refill.eq(refill - 1), muting.eq(refill != 1),
                         jobs_ok.eq(refill <= FIR_REFILL_SAMPLES + 1)]
        # Muting starts with the switch, so that in the clock after it (``swapped``,
        # which restarts the fetcher and fans out widely) the phase is held by
        # ``muting`` alone (timing: ``swapped`` -> phase logic was the worst path).
        with m.If(swapping):
            m.d.sync += muting.eq(1)

        # The fetcher: the next word to fetch (index ``f_idx``, pool address
        # ``f_addr`` kept beside it, cache position ``f_pos``) and ``ahead``,
        # the words fetched from the consumer's oldest needed position
        # ``cpos`` on. The consumer frees ``cpos`` by ``release``.
        PW = (CACHE_WORDS - 1).bit_length()
        back = FIR_LEAD - 1 if fir else 0          # the FIR's window starts 4 words before word 0
        f_idx0 = max(self._init_length - back, 0) if back else 0
        gen = Signal(3)
        f_idx = Signal(range(D), init=f_idx0)
        # The stream index at which the fetcher restarts (FIR: 4 words before
        # word 0, wrapped), latched with the length at every switch.
        f_start = Signal(range(D), init=f_idx0)
        if back:
            with m.If(swapping):
                m.d.sync += f_start.eq(Mux(self.length > back, self.length - back, 0))
        f_addr = Signal.like(self.fetch_addr, init=(self._init_base + f_idx0) % (1 << len(self.fetch_addr)))
        f_pos = Signal(PW)
        ahead = Signal(range(CACHE_WORDS + 1))
        cpos = Signal(PW)
        release = Signal()
        grant = Signal()
        m.d.comb += [self.fetch_want.eq((ahead < CACHE_FILL_WORDS) & ~swapped),
                     grant.eq(self.fetch_grant & self.fetch_want),
                     self.fetch_addr.eq(f_addr),
                     self.fetch_tag.pos.eq(f_pos), self.fetch_tag.gen.eq(gen)]
        m.d.sync += ahead.eq(ahead + grant - release)
        m.d.comb += [self.active_base.eq(base), self.fetch_index.eq(f_idx), self.restarting.eq(swapped)]
        with m.If(grant):
            m.d.sync += [f_idx.eq(Mux(f_idx == len_m1, 0, f_idx + 1)),
                         f_addr.eq(Mux(f_idx == len_m1, base, f_addr + 1)),
                         f_pos.eq(f_pos + 1)]
        with m.If(swapped):
            # ``f_start`` was latched with the length at the switch (timing: no
            # subtract-compare in front of this adder).
            m.d.sync += [gen.eq(gen + 1), f_idx.eq(f_start), f_addr.eq(base + f_start), f_pos.eq(0),
                         ahead.eq(0), cpos.eq(0)]
        for ram in caches:
            m.d.comb += [ram.w_en.eq(self.fill_en & (self.fill_tag.gen == gen)),
                         ram.w_addr.eq(self.fill_tag.pos), ram.w_data.eq(self.fill_data),
                         ram.r_en.eq(self.en)]

        if fir:
            # J (the FIR's intermediate index, whole words and top fraction bits) advances.
            PB = FIR_PHASE_BITS
            j_step = Signal()
            m.d.comb += j_step.eq(en & (acc[F - PB:] != frac[F - PB:]))
            self._elaborate_fir(m, caches[0], cpos, release, frac, swapped, j_step, jobs_ok, refilling)
            return m

        # Hold and linear: the consumer reads the position of ``idx`` (and the
        # next); the position advances, and frees the old one, with ``idx``.
        with m.If(en & carry & ~wrap_swap):
            m.d.sync += cpos.eq(cpos + 1)
            m.d.comb += release.eq(1)
        w0 = Signal(IQ(STREAM_WIDTH))
        m.d.comb += [caches[0].r_addr.eq(cpos), w0.eq(caches[0].r_data)]
        # The output is 0 while muting: ``refilling`` follows the words through
        # the stream latency.
        SL = self.latency
        mute = [Signal(name=f"mute{k}") for k in range(SL)]
        with m.If(self.en):
            m.d.sync += [mute[0].eq(refilling)] + [mute[k].eq(mute[k - 1]) for k in range(1, SL)]
        if interp == "hold":
            m.d.comb += self.o.eq(Mux(mute[-1], 0, w0))
            return m

        # Interpolation: the second copy reads the next position.
        w1 = Signal(IQ(STREAM_WIDTH))
        m.d.comb += [caches[1].r_addr.eq(cpos + 1), w1.eq(caches[1].r_data)]
        # The fraction follows the words through the RAM's stages (one per
        # RAM latency sample), then meets the difference of the words.
        fds = [Signal(INTERP_FRAC_BITS, name=f"fd{k}") for k in range(caches[0].latency + 1)]
        fa = fds[-1]
        W = STREAM_WIDTH
        # (Every stage steps with the input, muted or not: a fixed latency.)
        with m.If(self.en):
            m.d.sync += [fds[0].eq(frac[F - INTERP_FRAC_BITS:])]
            m.d.sync += [fds[k].eq(fds[k - 1]) for k in range(1, len(fds))]
        out = Signal(IQ(W))
        for part in ("re", "im"):
            diff = Signal(signed(W + 1), name=f"diff_{part}")
            s0a = Signal(signed(W), name=f"s0a_{part}")
            s0b = Signal(signed(W), name=f"s0b_{part}")
            prod = Signal(signed(W + 1 + INTERP_FRAC_BITS + 1), name=f"prod_{part}")
            with m.If(self.en):
                m.d.sync += [diff.eq(getattr(w1, part) - getattr(w0, part)),
                             s0a.eq(getattr(w0, part)),
                             prod.eq(diff * fa), s0b.eq(s0a),
                             getattr(out, part).eq(
                                 s0b + ((prod + (1 << (INTERP_FRAC_BITS - 1))) >> INTERP_FRAC_BITS))]
        m.d.comb += self.o.eq(Mux(mute[-1], 0, out))
        return m

    def _elaborate_fir(self, m, cache, cpos, release, frac, swapped, j_step, jobs_ok, refilling):
        """The FIR interpolator: serial MAC into U[J..J+2], then the linear step.

        The cache positions from ``cpos`` on hold the words w-4 .. w+5 of the
        next job's word w (its taps read them from the top down); a job that
        finishes the last phase of its word frees ``cpos`` (``release``)."""
        F, W, T, PB = PHASE_FRAC_BITS, STREAM_WIDTH, FIR_TAPS, FIR_PHASE_BITS
        en = self.en
        # U[J], U[J+1], U[J+2]: index 0, 1, 2.
        u = [Signal(IQ(W), name=f"u{k}") for k in range(3)]
        tp = Signal(PB)                          # phase of the next job
        jobs = Signal(range(4), init=3)          # U values still to compute
        seq = Signal(range(3))                   # destination of the next job (0, 1, then 2)
        issuing = Signal()
        adv = Signal()                           # the job in flight ends its word
        tap = Signal(range(T))
        rpos = Signal.like(cpos)
        cphase = Signal(PB)
        dest = Signal(range(3))

        start = Signal()
        m.d.comb += start.eq(en & jobs_ok & ~issuing & (jobs != 0))
        with m.If(en):
            m.d.sync += jobs.eq(jobs + j_step - start)
            with m.If(j_step):
                m.d.sync += [u[0].eq(u[1]), u[1].eq(u[2])]
        with m.If(start):
            m.d.sync += [issuing.eq(1), tap.eq(0), cphase.eq(tp), dest.eq(seq),
                         rpos.eq(cpos + T - 1), tp.eq(tp + 1), adv.eq(tp == (1 << PB) - 1)]
            with m.If(seq != 2):
                m.d.sync += seq.eq(seq + 1)
        with m.Elif(en & issuing):
            m.d.sync += [tap.eq(tap + 1), rpos.eq(rpos - 1)]
            with m.If(tap == T - 1):
                m.d.sync += issuing.eq(0)
                with m.If(adv):
                    m.d.sync += cpos.eq(cpos + 1)
                    m.d.comb += release.eq(1)

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
        m.d.comb += [issue.eq(issuing), cache.r_addr.eq(rpos), rom_rd.en.eq(en), rom_rd.addr.eq(ca)]
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
            m.d.sync += [issuing.eq(0), jobs.eq(3), seq.eq(0), tp.eq(0), adv.eq(0), cpos.eq(0)]
            m.d.sync += [fl[k].valid.eq(0) for k in range(1, len(fl))]

        word = Signal(IQ(W))
        m.d.comb += word.eq(cache.r_data)
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
