"""One time-multiplexed pipeline of the replay engine: M channel slots, one per
fabric clock, sharing one stream interpolator, one complex multiplier, one
gain multiplier and one copy of the delay window."""

from amaranth.hdl import Module, Signal, Mux, Cat, Const, Array, signed, unsigned
from amaranth.lib import wiring, data
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from .iq import IQ
from .cmult import ComplexMultiplier
from .ecp5_primitives import RegisteredMultiplier, kept_register, kept_lut
from .delay_line import DelayLine
from .arrival_check import ArrivalCheck
from .register_chain import delayed
from rast.model.contract.fixedpoint import (ReplayContract, STREAM_WIDTH, INPUT_WIDTH, PHASE_FRAC_BITS,
                                            INTERP_FRAC_BITS, FIR_PHASE_BITS, FIR_TAPS, FIR_LEAD,
                                            FIR_COEF_WIDTH, FIR_COEF_FRAC, FIR_ACC_WIDTH,
                                            FIR_REFILL_SAMPLES, CACHE_WORDS, CACHE_FILL_WORDS,
                                            PRODUCT_SHIFT, GAIN_SHIFT, SCALED_WIDTH, WINDOW_LAG,
                                            WORD_CYCLES, GAIN_CYCLES, CMULT_CYCLES, MAC_RESULT_CYCLES,
                                            fir_coefficients, mac_merge_cycles, visit_cycles)
from rast.model.contract.powerup import ChannelInit

__all__ = ["ChannelPipeline", "SlotInit", "fetch_tag_layout", "accept_clock", "COMMON_OUT_CYCLES",
           "MIRROR_LAG", "REQUEST_CYCLES"]

#: Clocks from the period start to the common line's c[n] on ``win_data``
#: (the top asks the line's read for step n in the clock before the period
#: start and registers the line's word once, beside its block RAMs, for all
#: pipelines).
COMMON_OUT_CYCLES = 4
#: Clocks from a slot's completed update to its pending/bank mirrors.
MIRROR_LAG = 1
#: Clocks from a grant (in the visit's stage A) to the pipeline's fetch request
#: on ``req_valid``, ``req_addr`` and ``req_tag``.
REQUEST_CYCLES = 2

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


# Registers that only carry data (stream words, samples, products, sums, the
# addresses of reads whose words are data) are not reset. Each is overwritten
# every clock (an accumulator restarts at a job's first tap), and an output
# sample is only valid (``out_valid``, reset) K clocks after an input accepted
# after the reset, by when every one of them holds values computed since.
# The control (slot counters, flags, the per-slot state, the mute and valid
# chains) is reset. The FPGA then routes no reset to them, and Verilator runs
# about 4 % fewer instructions per clock at M = 1 (docs/cosim_speed.md).


#: Address bits of the FIR coefficient ROM's second level (2**k first-level
#: ROMs): 16 ROMs of 32 entries, a 5-input function per bit (one LUT and the
#: slice's multiplexer). Eight of 64 entries were synthesised as three LUTs
#: in series, the latest path of a 16-channel build (6.1 ns).
COEF_ROM_SPLIT_BITS = 4

#: The word cache in up to 2**k banks, by the slot's upper bits.
CACHE_BANK_BITS = 3

#: Bits of the FIR accumulator's lower half (its sum a clock before the upper's).
ACC_LOW_BITS = 19


#: Shortest delay kept in distributed RAM rather than in a chain of registers.
RAM_DELAY_MIN = 3


def _ring_delay(m, sig, n, inits, name, *, input_reg=False, clear=None):
    """``sig`` delayed by ``n`` clocks, as a chain of ``n`` registers whose
    power-up values are ``inits`` (the first register's first) would delay it.

    From RAM_DELAY_MIN clocks on the chain is a distributed RAM (written every
    clock at a running address, read ``n - 1`` clocks later) and one output
    register: the engine's state rings hold hundreds of bits per slot, and
    the flip-flops of the chain were most of a 64-channel build's.
    ``input_reg``: the chain's first register stays a register before the
    RAM, so that the logic computing ``sig`` ends at flip-flops the placer
    puts beside it rather than at the RAMs' write ports.
    ``clear``: where 1, the output is 0 in the next clock instead (the last
    register's synchronous reset), so that logic reading the output needs
    no multiplexer after its own arithmetic.

    Returns ``(output, registers)``: the registers of a short chain (all of
    them but the input and output registers are in the RAM otherwise)."""
    layout = sig.shape()
    if n < RAM_DELAY_MIN:
        regs = []
        for k in range(n):
            nxt = Signal(layout, init=inits[k], name=f"{name}{k}")
            m.d.sync += nxt.eq(_cleared(sig, clear if k == n - 1 else None))
            sig = nxt
            regs.append(nxt)
        return sig, regs
    if input_reg:
        first = Signal(layout, init=inits[0], name=f"{name}_in")
        m.d.sync += first.eq(sig)
        out, regs = _ring_delay(m, first, n - 1, inits[1:], name, clear=clear)
        return out, [first, *regs]
    depth = 1 << (n - 1).bit_length()
    const = (lambda v: layout.const(v)) if isinstance(layout, data.Layout) else (lambda v: v)
    # the word read in clock k (k = 1 .. n-1 after reset) is what the chain's
    # end would show then: the power-up value of register n - k
    init = [const(inits[0]) for _ in range(depth)]
    for k in range(1, n):
        init[(k - n) % depth] = const(inits[n - k - 1])
    mem = Memory(shape=layout, depth=depth, init=init, attrs={"ram_style": "distributed"})
    m.submodules[name] = mem
    wp = mem.write_port()
    rp = mem.read_port(domain="comb")
    # the write and the read address, each a counter of its own (a register
    # into the RAMs' address pins, no subtraction on the way)
    ptr = Signal(range(depth), name=f"{name}_wptr")
    rptr = Signal(range(depth), init=(1 - n) % depth, name=f"{name}_rptr")
    m.d.sync += [ptr.eq(ptr + 1), rptr.eq(rptr + 1)]
    out = Signal(layout, init=inits[n - 1], name=f"{name}_out")
    m.d.comb += [wp.en.eq(1), wp.addr.eq(ptr), wp.data.eq(sig), rp.addr.eq(rptr)]
    m.d.sync += out.eq(_cleared(rp.data, clear))
    return out, [out]


def _cleared(value, clear):
    """``value``, or 0 where ``clear`` (no clear: ``value``)."""
    return value if clear is None else Mux(clear, 0, value)


def _select_registered(m, words, sel, name):
    """``words[sel]`` one clock later, no register gathering more than four
    words: groups of four selected into registers of their own (a 4:1
    multiplexer is one slice per bit), and the returned selection among the
    (at most four) groups, for the caller's register. An 8:1 selection in one
    clock was the FIR's latest path at 64 channels (6.1 ns)."""
    assert len(words) <= 16
    if len(words) <= 4:
        return delayed(m, Array(words)[sel] if len(words) > 1 else words[0], 1, name, data=True)
    groups = [delayed(m, Array(words[g:g + 4])[sel[:2]], 1, f"{name}_group{g // 4}", data=True)
              for g in range(0, len(words), 4)]
    return Array(groups)[delayed(m, sel[2:], 1, f"{name}_gsel", data=True)]


def accept_clock(slots: int) -> int:
    """The clock of a pipeline's period in which its ``accept`` comes: the
    first (0) at M <= 2; the second (1) from M = 3, where the step flag is
    first needed at the visit, two clocks after the period start. The top
    then sends the accept strobe from its register beside the input's pins
    to the pipelines through two levels of registered copies (one copy for
    seven pipelines spread over the device was the 64-channel build's worst
    path, 8.3 ns, 6.8 of it one route)."""
    return 0 if visit_cycles(slots) < 2 else 1


class ChannelPipeline(wiring.Component):
    """M channel slots (M = ``contract.slots``) in one pipeline.

    Time is cut into periods of M clocks; a period starts in the clock in
    which the pipeline's slot counter is 0 (``accept`` is high in its clock
    ``accept_clock(M)`` when the period carries an input sample, a *step*). In slot s of a period the
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
    (``rast.model.contract.fixedpoint``) and the bit-exact model's
    (``rast.model.contract.datapath.ReplayModel``).

    Parameters
    ----------
    contract : ReplayContract
    index : int
        The pipeline's number p (its fetch tags say it; channel p*M + s is in slot s).
    slot_inits : list of SlotInit
        Per slot (M of them) the power-up stream.
    regs_layout, values_layout : data.StructLayout
        Of ``regs`` and ``values`` (``rast.hdl.registers.channel_regs_layout``,
        ``slot_values_layout``).
    window_sites : sequence of str or None
        On ECP5: the block-RAM sites of the window's block RAMs
        (:class:`DelayLine` ``sites``), or ``None`` to leave them to the placer.

    Members
    -------
    accept : In(1)
        The period carries an input sample (only in the period's clock
        ``accept_clock(M)``).
    regs : In(regs_layout).array(M)
        Per slot: the registers kept in flip-flops.
    values : In(values_layout)
        The register file's RAM part of the registers read in the clock
        before (slot ``rslot`` then: the register file counts the slots in
        step, from M - 1 at reset), registered.
    cmd_ack : Out(1).array(M)
        Slot s's registers are read in this clock (its command is consumed).
    win_data : In(32)
        The common delay line's output c[n] of the period's step, 3 clocks
        after the period starts.
    offer : In(1)
        The fetch scan offers this pipeline's slots a fetch in this period
        (stable from the period's third clock for M clocks).
    req_valid : Out(1), req_addr : Out(pool address), req_tag : Out(fetch_tag_layout)
        A fetch request, REQUEST_CYCLES after its grant.
    fill_en : In(1), fill_tag : In(fetch_tag_layout), fill_data : In(32)
        A pool word for one of this pipeline's slots.
    pending, bank : Out(1).array(M)
        Per slot, the state's pending switch and bank (mirrors for read-back),
        ``MIRROR_LAG`` clocks after the update that sets them completes.
    sum : Out(IQ(sum width))
        The slot accumulator: the period's sum after the last slot.
    underflow : Out(1)
        SDRAM pool only (0 otherwise): a read that matters found its cache
        word not yet arrived, ``ArrivalCheck.LATENCY`` clocks after the read's
        address register.
    """

    def __init__(self, contract, index, slot_inits, regs_layout, values_layout, *, window_sites=None,
                 win_data_lag=0):
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
        room = self.win_data_room(M)
        if not isinstance(win_data_lag, int) or isinstance(win_data_lag, bool) or not 0 <= win_data_lag <= room:
            raise ValueError(f"Window data lag must be an integer in [0, {room}] at {M} slots, "
                             f"not {win_data_lag!r}")
        self._win_data_lag = win_data_lag
        self._index = index
        self._inits = slot_inits
        self._window_sites = window_sites
        aw = contract.pool_address_width
        self._sum_width = contract.sum_width
        super().__init__({
            "accept": In(1),
            "regs": In(regs_layout).array(M),
            "values": In(values_layout),
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
            "underflow": Out(1),
        })

    @property
    def sum_cycles(self) -> int:
        """Clocks from the pipeline's period start (its slot counter at 0) to the
        clock in which ``sum`` holds the period's sum over the slots (the last
        slot's register read and visit, word, product, gain, slot accumulator)."""
        c = self._c
        return ((c.slots - 1) + visit_cycles(c.slots) + WORD_CYCLES + CMULT_CYCLES[c.cmult_form]
                + GAIN_CYCLES + 1)

    @staticmethod
    def window_write_cycles(slots: int) -> int:
        """Clocks from the period start to the window's write at its RAM: after
        the visit and the tap's read at the RAM (WORD_CYCLES - the latency of
        a line without address copies - 1 after it); from M = 4 up to two
        clocks later, well before step n + 1 reads c[n] at tap 0
        (test_every_delay_echo_position fails with the write M clocks later),
        so that c[n] passes more registers on its way from the common line."""
        read_at = WORD_CYCLES - DelayLine.LATENCY - 1
        return visit_cycles(slots) + read_at + 1 + min(2, max(0, slots - 3))

    @classmethod
    def win_data_room(cls, slots: int) -> int:
        """Registers c[n] passes between ``win_data`` (COMMON_OUT_CYCLES after
        the period start) and the window's write registers: the top may
        take up to this many of them (``win_data_lag``)."""
        return cls.window_write_cycles(slots) - 1 - COMMON_OUT_CYCLES

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

    def _init_state(self, si: SlotInit):
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
        c = self._c
        M = c.slots
        F, PB, T = PHASE_FRAC_BITS, FIR_PHASE_BITS, FIR_TAPS
        interp = c.interpolation
        fir = interp == "fir"
        R = c.refill_samples
        back = FIR_LEAD - 1 if fir else 0
        SB = max(1, (M - 1).bit_length())                 # slot bits

        V = visit_cycles(M)
        # ---- the slot schedule: rslot (register read), vslot (visit) --------
        # The period starts (rslot 0) ACCEPT_LAG clocks after the top's
        # accepting clock, first in the clock after reset.
        rslot = Signal(range(max(2, M)), init=M - 1, name="rslot")
        if M > 1:
            m.d.sync += rslot.eq(Mux(rslot == M - 1, 0, rslot + 1))
        vslot = delayed(m, rslot, V, "vslot")
        # rslot == s, one-hot in registers of their own: a slot's command
        # acknowledge and the step flag's load (from the compare, each was a
        # latest path of the 64-channel build, into the register file's
        # command flags and the step count's enable, 6.8-7.2 ns)
        at_slot = Signal(M, init=1 << (M - 1), name="rslot_onehot")
        m.d.sync += at_slot.eq(at_slot.rotate_left(1))
        # The period's step flag and step number, loaded in its clock A
        # (accept_clock, where ``accept`` comes) and held for the period's M
        # visits (V clocks after the period start, V - 1 - A delays later).
        W = c.window_depth
        count = Signal(range(W))
        A = accept_clock(M)
        astart = at_slot[A]
        step_h = Signal()
        nidx_h = Signal(range(W))
        with m.If(astart):
            m.d.sync += [step_h.eq(self.accept), nidx_h.eq(count)]
            with m.If(self.accept):
                m.d.sync += count.eq(count + 1)
        step_v = delayed(m, step_h, V - 1 - A, "step_v")
        nidx_v = delayed(m, nidx_h, V - 1 - A, "nidx_v")
        offer = delayed(m, self.offer, V - 1, "offer")

        # ---- register read: slot rslot's registers, registered ---------------
        # The flip-flop part: V = 1, one multiplexer; V = 2, groups of 4 slots
        # by the low bits, registered, then the group (the select fans out to
        # every bit). The RAM part comes registered; V - 1 registers more.
        rl = self.regs[0].shape()
        vl = self.values.shape()
        # The command's decisions come in flip-flops of their own
        # (channel_regs_layout), so that each selected bit is a multiplexer
        # of register outputs.
        rsel = Signal(data.StructLayout({**dict(rl.members), **dict(vl.members)}), name="rsel")
        flags = Signal(rl, name="rsel_flags")
        m.d.comb += rsel.as_value().eq(Cat(flags, delayed(m, self.values, V - 1, "rsel_values")))
        if M == 1:
            m.d.sync += flags.eq(self.regs[0])
        elif V == 1:
            m.d.sync += flags.eq(Array(self.regs)[rslot])
        else:
            groups = []
            for g in range(0, M, 4):
                part = Signal(rl, name=f"rsel_g{g // 4}")
                members = list(self.regs)[g:g + 4]
                m.d.sync += part.eq(Array(members)[rslot[:2]] if len(members) > 1 else members[0])
                groups.append(part)
            if len(groups) > 1:
                m.d.sync += flags.eq(Array(groups)[delayed(m, rslot[2:], 1, "rslot_hi")])
            else:
                m.d.sync += flags.eq(groups[0])
        for s in range(M):
            m.d.comb += self.cmd_ack[s].eq(at_slot[s])

        # ---- the state ring --------------------------------------------------
        SL = self._state_layout()
        inits = [self._init_state(si) for si in self._inits]
        # Slot 0 visits V clocks after the first period start (clock 1): at
        # clock k the head holds slot (k - 1 - V) mod M, ring position j (the
        # head 0, the update's second stage 1, ...) slot (k - 1 - V - j).
        def init_at(j):
            return inits[(-1 - V - j) % M]
        head = Signal(SL, name="st_head")          # the ring's last register, below
        present = Const(sum(int(si.present) << k for k, si in enumerate(self._inits)), M)

        # Stage A: decisions and candidates from the head's registers.
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
        ML = data.StructLayout(mid_fields)
        if M == 1:
            mid = Signal(ML, name="st_mid")
        else:
            # at power-up the slot in stage B restarts its fetcher (the only
            # sum it takes then): its restart address beside its state
            i1 = init_at(1)
            f_addr0 = (i1["base"] + i1["f_start"]) % (1 << c.pool_address_width)
            mid = Signal(ML, init={**i1, "f_addr0": f_addr0}, name="st_mid")
        st = head
        rg = rsel
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
        carry_left = Signal(name="carry_left")
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
        length_early = delayed(m, self.values, V - 2, "rsel_early").length if V >= 2 else None
        for k, fn in new_stream.items():
            if V >= 2:
                a[k] = Signal(ML.members[k], name=f"rsel_{k}")
                m.d.sync += a[k].eq(fn(length_early))
            else:
                a[k] = fn(rg.length)
        a["n_inc"] = rg.increment
        a["n_base"] = rg.base
        present_v = Signal()
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
            a["release"] = en & carry & ~wrap_sw
        mid_next = Signal(ML, name="mid_next")
        m.d.comb += mid_next.eq(st)            # the state fields pass through
        for k, v in a.items():
            m.d.comb += getattr(mid_next, k).eq(v)
        if M == 1:
            m.d.comb += mid.eq(mid_next)
        else:
            m.d.sync += mid.eq(mid_next)

        # The FIR's U values, merged in stage B (from the MAC pipeline below):
        # ``mac_put`` one-hot of the U value a finished job writes.
        mac_put = Signal(3, name="mac_put")
        mac_val = Signal(IQ(STREAM_WIDTH), name="mac_val")

        # Stage B: select the next state from the decisions.
        x = mid
        nxt = Signal(SL, name="st_next")
        m.d.comb += nxt.eq(x.as_value()[:SL.size])
        with m.If(x.switch):
            m.d.comb += [nxt.len_m1.eq(x.n_len_m1), nxt.inc.eq(x.n_inc), nxt.base.eq(x.n_base),
                         nxt.left.eq(x.n_len_m1), nxt.frac.eq(0), nxt.acc.eq(x.n_inc), nxt.last.eq(x.n_last),
                         nxt.pending.eq(0), nxt.bank.eq(~x.bank), nxt.restart.eq(1),
                         nxt.muting.eq(1), nxt.f_start.eq(x.n_fstart)]
            # (the refill count below)
            if fir:
                # (the job's fields below, from the switch's copy)
                m.d.comb += [nxt.jne.eq(x.n_jne), nxt.inc_hnz.eq(x.n_jne)]
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
                m.d.comb += [nxt.issuing.eq(0), nxt.jobs.eq(3), nxt.seq.eq(0), nxt.tp.eq(0), nxt.adv.eq(0)]
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

        # The ring: head -> [A] -> mid -> [B] -> ... -> head: from the update's
        # end back to the head M - 1 clocks (one at M = 1; the head is the last).
        ring_len = max(1, M - 1)
        ring_inits = [init_at((j + 2) % M) for j in range(ring_len - 1)] + [init_at(0)]
        # (input_reg: the update's end into its RAM was 9.3 ns at 64 channels)
        last, regs = _ring_delay(m, nxt, ring_len, ring_inits, "st_ring", input_reg=True)
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

        # ---- fetch requests ---------------------------------------------------
        # In two registers (REQUEST_CYCLES), the first beside stage A, the
        # valid's a kept one: as a plain register Yosys merged it with stage
        # B's grant (the same input), one flip-flop for the pool's request
        # tree and the state update, far from both (into the fetcher's next
        # address, 5.8-6.0 ns); kept, it was one route from the grant's
        # logic to the requests' OR (6.1 ns).
        req_addr, req_tag = Signal.like(self.req_addr), Signal.like(self.req_tag)
        m.d.sync += [req_addr.eq(st.f_addr), req_tag.pos.eq(st.f_pos), req_tag.slot.eq(vslot),
                     self.req_valid.eq(kept_register(m, platform, a["grant"], "req_valid_q", reset=True)),
                     self.req_addr.eq(req_addr), self.req_tag.eq(req_tag)]
        assert REQUEST_CYCLES == 2

        # ---- the word cache: M x CACHE_WORDS words, by (slot, position) ----------
        # In banks by the slot's upper bits (up to 2**CACHE_BANK_BITS of them):
        # a read can then select its bank a clock after the banks' own reads.
        depth = CACHE_WORDS << (SB if M > 1 else 0)
        bank_bits = min(CACHE_BANK_BITS, SB if M > 1 else 0)
        in_bank = (depth >> bank_bits).bit_length() - 1          # address bits inside a bank
        fill_addr = Cat(self.fill_tag.pos, self.fill_tag.slot[:SB]) if M > 1 else self.fill_tag.pos
        copies = 2 if interp == "linear" else 1
        caches = []
        for k in range(copies):
            ports = []
            for bank in range(1 << bank_bits):
                # distributed RAM: a few words per slot, read and written every clock
                # (Yosys would otherwise take the registered read into a block RAM)
                mem = Memory(shape=unsigned(2 * STREAM_WIDTH), depth=depth >> bank_bits, init=[],
                             attrs={"ram_style": "distributed"})
                m.submodules[f"cache{k}_{bank}"] = mem
                wp = mem.write_port()
                m.d.comb += [wp.en.eq(self.fill_en & (fill_addr[in_bank:] == bank)),
                             wp.data.eq(self.fill_data), wp.addr.eq(fill_addr[:in_bank])]
                ports.append(mem.read_port(domain="comb"))
            caches.append(ports)

        # ---- arrival check (SDRAM pool): a read that matters (a playing
        # channel's step, the FIR's MAC) of a cache position whose word has
        # not arrived raises ``underflow`` (for a clock; the register file
        # keeps it in STATUS): a fetch later than the contract's bound
        # (ArrivalCheck, made below once every read is known). The block-RAM
        # pool's fixed latency needs no check.
        arrival = c.pool == "sdram"
        checks = []
        if arrival:
            playing = Signal(name="playing")
            m.d.comb += playing.eq(rg.enable & present_v)

        def cache_read(ports, pos, name, matters=None, clocks=1):
            """The cache word at ``pos`` of the visiting slot, the address
            registered in the visit, the word ``clocks`` clocks later in a
            register: with 2, each bank's word is registered first and the
            bank selected in the second clock (a selection among 16 LUT RAMs
            in one clock was n10_20_200's worst path, 7.2 ns); with 3, the
            banks are selected in two registered levels
            (``_select_registered``). ``matters``: the read is checked for an
            arrived word."""
            assert clocks in (1, 2, 3)
            # keep: else synthesis merges the register into the distributed
            # RAM's read port and moves it after the RAM, the address logic
            # and the RAM then in one clock (7.7 ns)
            full = Cat(pos[:POS_BITS], vslot[:SB]) if M > 1 else pos[:POS_BITS]
            addr = Signal(in_bank + bank_bits, name=f"{name}_addr", attrs={"keep": 1}, reset_less=True)
            m.d.sync += addr.eq(full)
            word = Signal(IQ(STREAM_WIDTH), name=name, reset_less=True)
            if len(ports) > 1:
                # each bank's LUT RAMs from a copy of their own (kept apart, as
                # the keep above does for one): one register reaching all four
                # banks' (128 at M = 10) was 6.2 ns in a two-pipeline build
                m.d.comb += [port.addr.eq(kept_register(m, platform, full[:in_bank], f"{name}_addr{b}"))
                             for b, port in enumerate(ports)]
            else:
                m.d.comb += ports[0].addr.eq(addr[:in_bank])
            words = [port.data for port in ports]
            bank = addr[in_bank:]
            if clocks >= 2:
                words = [delayed(m, w, 1, f"{name}_bank{k}", data=True) for k, w in enumerate(words)]
                if len(words) > 1:
                    bank = delayed(m, bank, 1, f"{name}_bank", data=True)
            if clocks == 3:
                m.d.sync += word.eq(_select_registered(m, words, bank, f"{name}_sel"))
            else:
                m.d.sync += word.eq(Array(words)[bank] if len(words) > 1 else words[0])
            if arrival and matters is not None:
                chk = Signal(name=f"{name}_checked")
                m.d.sync += chk.eq(matters & playing)
                checks.append((addr, chk))
            return word

        # ---- the word: a + round((b - a) * f, 16) -------------------------------
        # The operands two clocks after the visit: the cache's registered
        # address and word (hold, linear), or the FIR's U values waiting beside.
        f_op = st.frac[F - PB - INTERP_FRAC_BITS:F - PB] if fir else st.frac[F - INTERP_FRAC_BITS:]
        if fir:
            a2 = delayed(m, st.u0, 2, "word_a", data=True)
            b2 = delayed(m, st.u1, 2, "word_b", data=True)
        else:
            step_read = step_v & ~mute_out
            a2 = cache_read(caches[0], st.cpos, "word_a", step_read)
            b2 = cache_read(caches[1], st.cpos + 1, "word_b", step_read) if interp == "linear" else a2
        f2 = delayed(m, f_op, 2, "word_f", data=True)
        # A muted word is 0: the registers its last stage adds cleared (their
        # synchronous resets), so that the sum goes straight into the
        # operand copies (a multiplexer after it was among a 16-channel
        # build's late paths, 6.2 ns).
        # (the product's: its fraction operand, three clocks earlier)
        mute_early = delayed(m, mute_out, WORD_CYCLES - 5, "word_mute_early")
        mute = delayed(m, mute_early, 3, "word_mute")        # a clock before the word's last registers

        def last_register(value, name):
            reg = Signal.like(value, name=name, reset_less=True)
            m.d.sync += reg.eq(_cleared(value, mute))
            return reg
        # the word's last stage ends in the complex multiplier's operand
        # registers (a copy beside each multiplier), so ``word`` is the value
        # they take, a clock before the word is in its registers; ``word2``
        # the same value for the other two multipliers (``second_b``), from
        # an adder and registers of its own
        word = Signal(IQ(STREAM_WIDTH), name="word")
        word2 = Signal(IQ(STREAM_WIDTH), name="word2")
        if interp == "hold":
            # the word itself, as late as the interpolated one would be
            m.d.comb += word.eq(last_register(delayed(m, a2, WORD_CYCLES - 4, "word_hold", data=True), "word_hold"))
            m.d.comb += word2.eq(word)
        else:
            # the fraction operand, 0 for a muted word: its product is then
            # 0 with no multiplexer after the multiplier (the multiplier's
            # output through one into its register was a 16-channel build's
            # late path, 5.3 ns); a kept copy per multiplier (one register
            # into both multipliers' input registers was a 16-channel build's
            # late route, 4.7 ns: the two DSPs are not side by side)
            for part in ("re", "im"):
                f3 = kept_register(m, platform, _cleared(f2, mute_early), f"word_f3_{part}")
                diff = Signal(signed(STREAM_WIDTH + 1), name=f"word_diff_{part}", reset_less=True)
                m.d.sync += diff.eq(getattr(b2, part) - getattr(a2, part))
                mul = RegisteredMultiplier(STREAM_WIDTH + 1, INTERP_FRAC_BITS + 1, input_reg=True)
                m.submodules[f"lin_mul_{part}"] = mul
                m.d.comb += [mul.en.eq(1), mul.a.eq(diff), mul.b.eq(f3)]
                # the product again in fabric, next to the adder (0 already
                # for a muted word)
                prod = delayed(m, mul.o, 1, f"word_prod_{part}", data=True)
                # (a*2**16 + 2**15 + p) >> 16 = a + (p >> 16) + p[15]: the sum
                # and the rounding one adder of a's width, p[15] its carry-in
                # (a low bit beside a, 1 on the other side, shifted out); the
                # whole 33-bit sum was the carry chain into the operand copies,
                # 6.2 ns at 16 channels. A muted word: (0 + 1) >> 1 = 0.
                a5 = delayed(m, getattr(a2, part), WORD_CYCLES - 4, f"word_a6_{part}", data=True)
                a6 = last_register(a5, f"word_a6_{part}")
                # word2's: the product and a again, kept apart from word's
                # (equal registers would be one to Yosys, and so the adders)
                prod2 = kept_register(m, platform, mul.o, f"word2_prod_{part}")
                a6_2 = kept_register(m, platform, _cleared(a5, mute), f"word2_a6_{part}")
                for target, p_, a_ in ((word, prod, a6), (word2, prod2, a6_2)):
                    rounded_hi = Cat(Const(1, 1), p_[INTERP_FRAC_BITS:]).as_signed()
                    m.d.comb += getattr(target, part).eq(
                        (Cat(p_[INTERP_FRAC_BITS - 1], a_).as_signed() + rounded_hi) >> 1)
            # operands (address, word), difference, multiplier in and out, product, sum
            assert 2 + 1 + 2 + 1 + 1 == WORD_CYCLES

        # ---- the FIR's serial MAC: one tap per visit of a slot -------------------
        if fir:
            self._elaborate_mac(m, platform, st, caches[0], cache_read, mac_put, mac_val)
        if checks:
            m.submodules.arrival = check = ArrivalCheck(depth, len(checks))
            m.d.comb += [check.grant.eq(a["grant"]),
                         check.grant_pos.eq(Cat(st.f_pos, vslot[:SB]) if M > 1 else st.f_pos),
                         check.fill_en.eq(self.fill_en), check.fill_pos.eq(fill_addr),
                         self.underflow.eq(check.underflow)]
            for k, (addr, chk) in enumerate(checks):
                m.d.comb += [check.read_pos[k].eq(addr), check.read_matters[k].eq(chk)]

        # ---- the window: written once per step, read at each slot's tap ---------
        # A slot's tap is read WORD_CYCLES - latency - 1 clocks after its visit
        # and its sample registered in fabric (the complex multiplier's operand
        # registers), so that it is out with the word: the RAM's output
        # register went straight into the multipliers' input
        # registers, the latest path of a two-pipeline build (7.9 ns, 6.9 of
        # it routing, docs/bitstream.md). c[n] comes from the common line
        # COMMON_OUT_CYCLES after the period start and reaches the RAM just
        # after the last read of the step before (a write for step n + 1 never
        # meets a read for step n at the RAM: tests/formal/replay_formal.py's
        # rule).
        # Each of the window's block RAMs has its write and read-address
        # registers of its own (the line's groups), so the write is handed to
        # the line a clock before it reaches the RAM. The read address is
        # registered once, then copied for each block RAM (its adder straight
        # into the four copies was late in 16- and 64-channel builds,
        # 5.3 ns), so the read is handed to the line a clock earlier and
        # reaches the RAM in the same clock as without the copies.
        win_bits = DelayLine.slice_bits(2 * INPUT_WIDTH, c.max_tap, WINDOW_LAG)
        m.submodules.window = win = DelayLine(
            2 * INPUT_WIDTH, c.max_tap, WINDOW_LAG, group_bits=win_bits, sites=self._window_sites,
            address_copies=-(-2 * INPUT_WIDTH // win_bits))
        assert win.depth == W and win.latency == DelayLine.LATENCY + 1
        read_at = WORD_CYCLES - win.latency - 1
        write_at = self.window_write_cycles(M)
        wen = delayed(m, astart & self.accept, write_at - 1 - A, "win_wen")
        # c[n] through registers of the pipeline's own (kept): every pipeline
        # delays the same common-line word, so plain registers were one chain
        # to Yosys, feeding all the windows' write registers across the device
        # (6.2-6.7 ns at 64 channels); win_data_lag of them are the top's
        wdata = self.win_data
        for k in range(self.win_data_room(M) - self._win_data_lag):
            wdata = kept_register(m, platform, wdata, f"win_wdata_d{k + 1}")
        windex = delayed(m, nidx_h, write_at - 2 - A, "win_windex", data=True)
        m.d.comb += [win.w_en.eq(wen), win.w_index.eq(windex), win.w_data.eq(wdata),
                     win.r_index.eq(delayed(m, nidx_v, read_at, "win_rindex", data=True)),
                     win.r_delay.eq(delayed(m, rg.tap, read_at, "win_rdelay", data=True))]

        # ---- complex product, gain, slot accumulator -----------------------------
        # The tap's sample and the word into the multiplier's operand
        # registers, a copy for each of its multipliers (``operand_registers``).
        m.submodules.cmult = cm = ComplexMultiplier(INPUT_WIDTH, STREAM_WIDTH, PRODUCT_SHIFT, c.cmult_form,
                                                    operand_registers=True, second_b=True)
        m.d.comb += [cm.en.eq(1), cm.a.eq(win.o), cm.b.eq(word), cm.b2.eq(word2)]
        geff = Signal(rg.gain.shape(), name="geff")
        m.d.comb += geff.eq(Mux(rg.enable, rg.gain, 0))
        # (its last two registers the copies below)
        g = delayed(m, geff, WORD_CYCLES - 2 + cm.latency, "gain", data=True)
        q = Signal(IQ(SCALED_WIDTH), name="q", reset_less=True)
        q_sum = {}          # a kept copy of q for the period sum's adder (below)
        for part in ("re", "im"):
            mul = RegisteredMultiplier(cm.o_width, len(geff) + 1, input_reg=True)
            m.submodules[f"gain_mul_{part}"] = mul
            # the product again in a register before the multiplier (the
            # rounding's register sits with its adder, and from there into the
            # multiplier was the latest path of a 16-channel build, 6.9 ns,
            # 6.3 of it one route); the gain's last two registers a copy for
            # each multiplier (kept: with one, the route from its copy into
            # the multiplier was a 16-channel build's latest path, 5.02 ns,
            # 4.41 of it that route)
            gain_near = kept_register(m, platform, kept_register(m, platform, g, f"gain_far_{part}"),
                                      f"gain_{part}")
            m.d.comb += [mul.en.eq(1), mul.a.eq(delayed(m, getattr(cm.o, part), 1, f"gain_a_{part}", data=True)),
                         mul.b.eq(gain_near)]
            prod = delayed(m, mul.o, 1, f"gain_prod_{part}", data=True)      # in fabric, next to the adder
            rounded = Signal(signed(SCALED_WIDTH), name=f"q_next_{part}")
            m.d.comb += rounded.eq((prod + (1 << (GAIN_SHIFT - 1))) >> GAIN_SHIFT)
            m.d.sync += getattr(q, part).eq(rounded)
            q_sum[part] = kept_register(m, platform, rounded, f"q_sum_{part}").as_signed()
        assert 1 + 2 + 1 + 1 == GAIN_CYCLES
        # The period's sum: the slots' q added into an accumulator that is
        # cleared (its registers' reset) where the next clock's q is a
        # period's first, the finished sum taken into ``sum`` then. An adder
        # straight into its registers: a multiplexer after it (the first
        # slot's q or the sum) was among the 64-channel build's late paths
        # (5.9 ns). ``sum`` holds a period's sum in the clock of the next
        # period's first q and M - 1 clocks after.
        q_slot_ahead = delayed(m, vslot, WORD_CYCLES - 1 + cm.latency + GAIN_CYCLES - 2, "qslot")
        period_ends = Signal(name="period_ends")
        m.d.sync += period_ends.eq(q_slot_ahead == 0)
        # The period's sum from an adder of its own, beside ``sum``'s registers
        # (with q's kept copy: Yosys would merge two adders of the same
        # inputs): one adder into both the accumulator and ``sum`` had two
        # registers per bit to place by one carry chain, and the
        # accumulator's, put away from it, was a route of 1.7 ns back into
        # the chain (5.03-5.28 ns, the latest path at two of three seeds of
        # 16-channel builds).
        for part in ("re", "im"):
            s_ = getattr(self.sum, part)
            acc = Signal.like(s_, name=f"slot_acc_{part}", reset_less=True)
            m.d.sync += acc.eq(_cleared(acc + getattr(q, part), period_ends))
            with m.If(period_ends):
                m.d.sync += s_.eq(acc + q_sum[part])
        return m

    def _elaborate_mac(self, m, platform, st, cache, cache_read, mac_put, mac_val):
        """The FIR's multiplier-accumulator: a visiting slot with a job in issue
        reads its tap's word (cache) and coefficient (ROM), both through
        registered addresses; the product (again in fabric) is accumulated in
        a ring of M accumulators (one per slot), rounded and saturated at the
        job's last tap, and merged into the slot's state ``mac_merge_cycles``
        clocks after the visit (``mac_put``, ``mac_val``)."""
        c = self._c
        M = c.slots
        T, PB, W = FIR_TAPS, FIR_PHASE_BITS, STREAM_WIDTH
        TB = (T - 1).bit_length()
        coefs = fir_coefficients()
        rom_init = [0] * ((1 << PB) << TB)
        for p, row in enumerate(coefs):
            for k, v in enumerate(row):
                rom_init[(p << TB) | k] = v
        # In logic, not a block RAM (the block RAMs are the pool's and the
        # delays'), and in three registered levels: ROMs of the address's low
        # bits (a 5-input function per bit), then a multiplexer of their
        # outputs by the high bits in two (``_select_registered``). The whole
        # 9-input ROM in one clock was the pipeline's worst path (7.9 ns);
        # 7-input ROMs, four LUTs in series, were still among the 200 MHz
        # build's late endpoints (6.9 ns).
        addr_bits = TB + PB
        low_bits = addr_bits - COEF_ROM_SPLIT_BITS
        full = Cat(st.tap, st.cphase)
        rom_high = delayed(m, full[low_bits:], 2, "mac_rom_high", data=True)   # beside the ROMs' words
        parts = []
        for k in range(1 << COEF_ROM_SPLIT_BITS):
            rom = Memory(shape=signed(FIR_COEF_WIDTH), depth=1 << low_bits,
                         init=rom_init[k << low_bits:(k + 1) << low_bits], attrs={"rom_style": "logic"})
            m.submodules[f"coef_rom{k}"] = rom
            rd = rom.read_port(domain="comb")
            part = Signal(signed(FIR_COEF_WIDTH), name=f"mac_coef{k}", reset_less=True)
            # Each ROM its own address register, 0 where the high bits do not
            # select it (its word is not taken then): copies that differ, so
            # synthesis keeps them apart. One register for the four ROMs was
            # n10_20_200's worst path (its fan-out, 6.9 ns).
            rom_addr = Signal(low_bits, name=f"mac_rom_addr{k}", reset_less=True)
            m.d.sync += rom_addr.eq(Mux(full[low_bits:] == k, full[:low_bits], 0))
            m.d.comb += rd.addr.eq(rom_addr)
            m.d.sync += part.eq(rd.data)
            parts.append(part)
        # the ROMs' words selected in two registered levels, then the
        # coefficient in a register for each multiplier (kept)
        coef = _select_registered(m, parts, rom_high, "mac_coef_sel")
        word = cache_read(cache, st.rpos, "mac_word", st.issuing, clocks=3)   # beside the ROM's three levels
        flags = data.StructLayout({"valid": 1, "first": 1, "last": 1, "dest": range(3)})
        f0 = Signal(flags, name="mac_f0")
        m.d.comb += [f0.valid.eq(st.issuing), f0.first.eq(st.tap == 0), f0.last.eq(st.tap_last),
                     f0.dest.eq(st.dest)]
        fmul = delayed(m, f0, 7, "mac_f")                     # with the multiplier's output, again
        fprod = delayed(m, fmul, 1, "mac_fp")                 # with the product in fabric
        fhigh = delayed(m, fprod, 1, "mac_fh")               # with the upper half's sum
        # with the result: the U value a finished job writes, one-hot, from
        # registers (a job's last tap's destination decoded into stage B's
        # merge was late at 16 channels)
        put0 = Signal(3, name="mac_put0")
        m.d.sync += put0.eq(Cat(*[fhigh.valid & fhigh.last & (fhigh.dest == k) for k in range(3)]))
        res = Signal(IQ(W), name="mac_res", reset_less=True)
        for part in ("re", "im"):
            mul = RegisteredMultiplier(W, FIR_COEF_WIDTH, input_reg=True)
            m.submodules[f"fir_mul_{part}"] = mul
            m.d.comb += [mul.en.eq(1), mul.a.eq(getattr(word, part)),
                         mul.b.eq(kept_register(m, platform, coef, f"mac_coef_{part}").as_signed())]
            # The multiplier's output in a register beside it, then the
            # product, 0 where no tap is issued (its register's reset), beside
            # the accumulator. The multiplier's output straight into that
            # register was the 16-channel build's worst path: one route of
            # 5.1 ns from a multiplier placed 74 tiles away.
            mul_out = delayed(m, mul.o, 1, f"fir_mul_out_{part}", data=True)
            prod = Signal(signed(FIR_ACC_WIDTH), name=f"fir_prod_{part}", reset_less=True)
            m.d.sync += prod.eq(_cleared(mul_out, ~fmul.valid))
            # One accumulator per slot: this slot's, updated, then round the
            # ring (M clocks) back to its next tap. In two halves, the upper a
            # clock after the lower with its carry (the 38-bit sum in one clock
            # was a latest path of a two-pipeline build, 6.1 ns); each half
            # goes round a ring of its own. Each half is the sum of the
            # previous value, 0 at a job's first tap (the ring's output
            # cleared), and the product, 0 without a tap: an adder straight
            # into the register (a multiplexer after the adder was in the
            # 64-channel build's late paths, 5.7 ns).
            acc_lo = Signal(ACC_LOW_BITS, name=f"fir_acc_lo_{part}", reset_less=True)
            acc_hi = Signal(FIR_ACC_WIDTH - ACC_LOW_BITS, name=f"fir_acc_hi_{part}", reset_less=True)
            if M > 1:
                prev_lo, _ = _ring_delay(m, acc_lo, M - 1, [0] * (M - 1), f"fir_accs_lo_{part}",
                                         clear=fmul.valid & fmul.first)
                prev_hi, _ = _ring_delay(m, acc_hi, M - 1, [0] * (M - 1), f"fir_accs_hi_{part}",
                                         clear=fprod.valid & fprod.first)
            else:
                prev_lo = _cleared(acc_lo, fprod.valid & fprod.first)
                prev_hi = _cleared(acc_hi, fhigh.valid & fhigh.first)
            sum_lo = Signal(ACC_LOW_BITS + 1, name=f"fir_sum_lo_{part}")
            carry = Signal(name=f"fir_carry_{part}", reset_less=True)
            m.d.comb += sum_lo.eq(prev_lo + prod[:ACC_LOW_BITS])
            m.d.sync += [acc_lo.eq(sum_lo), carry.eq(sum_lo[-1])]
            prod_hi = delayed(m, prod[ACC_LOW_BITS:], 1, f"fir_prod_hi_{part}", data=True)
            m.d.sync += acc_hi.eq(prev_hi + prod_hi + carry)
            acc = Signal(signed(FIR_ACC_WIDTH), name=f"fir_acc_{part}")
            m.d.comb += acc.eq(Cat(delayed(m, acc_lo, 1, f"fir_acc_lo_{part}", data=True), acc_hi))
            rounded = Signal(signed(FIR_ACC_WIDTH - FIR_COEF_FRAC + 1), name=f"fir_rnd_{part}", reset_less=True)
            half = 1 << (FIR_COEF_FRAC - 1)
            m.d.sync += rounded.eq((acc + half) >> FIR_COEF_FRAC)
            lo, hi = -(1 << (W - 1)), (1 << (W - 1)) - 1
            # rounded > hi and rounded < lo, decided on the accumulator beside
            # the rounding (floor((a + half) / 2**F) > hi <=> a >= (hi + 1) * 2**F
            # - half, < lo <=> a < lo * 2**F - half): the compares after the
            # rounding, then the clip, were 7.5 ns in a two-pipeline build).
            # Each compare in two parts: the lower half's a clock earlier,
            # beside it, then 2 a_hi + (a_lo >= k_lo) >= 2 k_hi + 1, which is
            # a >= k, on the upper half's width (the whole accumulator's
            # compare was among a 16-channel build's late paths, 4.8-4.9 ns).
            over = Signal(name=f"fir_over_{part}", reset_less=True)
            under = Signal(name=f"fir_under_{part}", reset_less=True)
            for flag, bound, below in ((over, ((hi + 1) << FIR_COEF_FRAC) - half, False),
                                       (under, (lo << FIR_COEF_FRAC) - half, True)):
                lo_ge = Signal(name=f"{flag.name}_lo", reset_less=True)
                m.d.sync += lo_ge.eq(acc_lo >= (bound & ((1 << ACC_LOW_BITS) - 1)))
                ge = Cat(lo_ge, acc_hi).as_signed() >= 2 * (bound >> ACC_LOW_BITS) + 1
                m.d.sync += flag.eq(~ge if below else ge)
            m.d.sync += getattr(res, part).eq(Mux(over, hi, Mux(under, lo, rounded)))
        # addresses, ROM levels (the word beside), multiplier in and out, its
        # output again, product, the accumulator's two halves, round, saturate
        assert 1 + 3 + 2 + 1 + 1 + 1 + 1 + 1 + 1 == MAC_RESULT_CYCLES
        pad = mac_merge_cycles(M) - MAC_RESULT_CYCLES
        res_d = delayed(m, res, pad, "mac_res", data=True)
        m.d.comb += [mac_put.eq(delayed(m, put0, 2 + pad, "mac_put")), mac_val.eq(res_d)]
