"""One time-multiplexed pipeline of the replay engine: M channel slots, one per
fabric clock, sharing one stream interpolator, one complex multiplier, one
gain multiplier and one copy of the delay window; its stages are the
components of ``rast.hdl.pipeline``."""

from amaranth.hdl import Module, Signal, Mux, Cat, Fragment
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from rast.model.contract.fixedpoint import (ReplayContract, STREAM_WIDTH, INPUT_WIDTH, PHASE_FRAC_BITS,
                                            INTERP_FRAC_BITS, FIR_PHASE_BITS, WORD_CYCLES, visit_cycles)
from .arrival_check import ArrivalCheck
from .iq import IQ
from .register_chain import delayed
from .pipeline.schedule import SlotSchedule, RegisterSelect, accept_clock
from .pipeline.slot_state import SlotState, SlotInit, fetch_tag_layout, MIRROR_LAG, REQUEST_CYCLES
from .pipeline.word_cache import WordCache
from .pipeline.interpolator import LinearStep
from .pipeline.fir_mac import FirMac
from .pipeline.window_tap import WindowTap, COMMON_OUT_CYCLES
from .pipeline.product import ProductSum
from .pipeline.pattern_gain import PatternGain, BEAM_LAYOUT, PATTERN_LAYOUT, BEAM_CLOCK, GAIN_INPUT_DELAY

__all__ = ["ChannelPipeline", "SlotInit", "fetch_tag_layout", "accept_clock", "COMMON_OUT_CYCLES",
           "MIRROR_LAG", "REQUEST_CYCLES"]

# Registers that only carry data (stream words, samples, products, sums, the
# addresses of reads whose words are data) are not reset. Each is overwritten
# every clock (an accumulator restarts at a job's first tap), and an output
# sample is only valid (``out_valid``, reset) K clocks after an input accepted
# after the reset, by when every one of them holds values computed since.
# The control (slot counters, flags, the per-slot state, the mute and valid
# chains) is reset. The FPGA then routes no reset to them, and Verilator runs
# about 4 % fewer instructions per clock at M = 1 (docs/cosim_speed.md).


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

    The stages, each a component of ``rast.hdl.pipeline`` with its latency
    a property: the slot schedule and the register read (``schedule``), the
    per-slot state (``slot_state``), the word cache (``word_cache``), the
    FIR's multiplier-accumulator (``fir_mac``), the interpolator's last step
    (``interpolator``), the window (``window_tap``), the product, gain and
    slot sum (``product``). docs/tdm_engine.md's slot schedule is made from
    them (:func:`rast.hdl.pipeline.schedule_table`).

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
    pattern_site : str or None
        With the antenna scan, on ECP5: the pattern table's block-RAM site
        (:class:`PatternGain` ``site``), or ``None``.

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
    beam : In(BEAM_LAYOUT), pattern : In(PATTERN_LAYOUT), with the antenna scan
        The step's beam, from the period's clock BEAM_CLOCK for M clocks; the
        pattern's settings and table writes. Each slot's gain is then its
        GAIN times the pattern at (beam - AZIMUTH) (:class:`PatternGain`).
    """

    def __init__(self, contract, index, slot_inits, regs_layout, values_layout, *, window_sites=None,
                 pattern_site=None, win_data_lag=0):
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
        # the stages whose interfaces the pipeline's own follow (made here:
        # the top reads the window's and the state's properties before
        # elaborating)
        self._window = WindowTap(contract, sites=window_sites, win_data_lag=win_data_lag)
        self._select = RegisterSelect(contract, regs_layout, values_layout)
        self._state = SlotState(contract, slot_inits, self._select.rsel.shape())
        self._product = ProductSum(contract, GAIN_INPUT_DELAY + PatternGain.latency if contract.scan else 0)
        self._pattern = PatternGain(site=pattern_site) if contract.scan else None
        super().__init__({
            "accept": In(1),
            "regs": In(regs_layout).array(M),
            "values": In(values_layout),
            "cmd_ack": Out(1).array(M),
            "win_data": In(2 * INPUT_WIDTH),
            "offer": In(1),
            "req_valid": Out(1),
            "req_addr": Out(contract.pool_address_width),
            "req_tag": Out(fetch_tag_layout(M)),
            "fill_en": In(1),
            "fill_tag": In(fetch_tag_layout(M)),
            "fill_data": In(2 * STREAM_WIDTH),
            "pending": Out(1).array(M),
            "bank": Out(1).array(M),
            **({"beam": In(BEAM_LAYOUT), "pattern": In(PATTERN_LAYOUT)} if contract.scan else {}),
            "sum": Out(IQ(contract.sum_width)),
            "underflow": Out(1),
        })

    @property
    def sum_cycles(self) -> int:
        """Clocks from the pipeline's period start (its slot counter at 0) to the
        clock in which ``sum`` holds the period's sum over the slots: the last
        slot's register read and visit, then the product stage's
        (:attr:`ProductSum.sum_cycles`: word, product, gain, slot accumulator)."""
        M = self._c.slots
        return (M - 1) + visit_cycles(M) + self._product.sum_cycles

    window_write_cycles = staticmethod(WindowTap.window_write_cycles)
    win_data_room = staticmethod(WindowTap.win_data_room)

    @property
    def update_stage(self) -> int:
        """Clocks from a slot's visit to the clock in which its state update completes."""
        return self._state.update_stage

    @property
    def ring_states(self):
        """Every slot's state in the ring's registers (for the formal checks;
        after elaboration)."""
        return self._state.ring_states

    def elaborate(self, platform):
        m = Module()
        c = self._c
        M, interp = c.slots, c.interpolation
        fir = interp == "fir"
        F, PB = PHASE_FRAC_BITS, FIR_PHASE_BITS

        # ---- the slot schedule and the register read --------------------------
        m.submodules.schedule = sch = SlotSchedule(c)
        m.submodules.select = sel = self._select
        m.d.comb += [sch.accept.eq(self.accept), sch.offer.eq(self.offer),
                     sel.values.eq(self.values), sel.rslot.eq(sch.rslot)]
        for s in range(M):
            m.d.comb += [sel.regs[s].eq(self.regs[s]), self.cmd_ack[s].eq(sch.at_slot[s])]
        rg = sel.rsel

        # ---- the per-slot state (elaborated here: its ring is ``ring_states``) ----
        state = self._state
        m.submodules.state = Fragment.get(state, platform)
        m.d.comb += [state.rsel.eq(rg), state.length_early.eq(sel.length_early), state.step.eq(sch.step),
                     state.offer.eq(sch.offer_visit), state.vslot.eq(sch.vslot),
                     self.req_valid.eq(state.req_valid), self.req_addr.eq(state.req_addr),
                     self.req_tag.eq(state.req_tag)]
        for s in range(M):
            m.d.comb += [self.pending[s].eq(state.pending[s]), self.bank[s].eq(state.bank[s])]
        st = state.head

        # ---- the word cache, its readers, and the word at the multiplier -------
        readers = ([("mac_word", 0, 3)] if fir else
                   [("word_a", 0, 1)] + ([("word_b", 1, 1)] if interp == "linear" else []))
        m.submodules.cache = cache = WordCache(M, readers, copies=2 if interp == "linear" else 1)
        m.d.comb += [cache.fill_en.eq(self.fill_en), cache.fill_tag.eq(self.fill_tag),
                     cache.fill_data.eq(self.fill_data), cache.vslot.eq(sch.vslot)]
        m.submodules.linear = step = LinearStep(interp)
        assert step.latency == WORD_CYCLES
        if fir:
            # the FIR's U values wait beside the cache's reads of other interpolations
            m.submodules.mac = mac = FirMac(M)
            assert mac.WORD_LATENCY == cache.read_latency(0)
            m.d.comb += [cache.read_pos[0].eq(st.rpos), mac.tap.eq(st.tap), mac.cphase.eq(st.cphase),
                         mac.issuing.eq(st.issuing), mac.tap_last.eq(st.tap_last), mac.dest.eq(st.dest),
                         mac.word.eq(cache.read_word[0]), state.mac_put.eq(mac.put), state.mac_val.eq(mac.val)]
            a_op = delayed(m, st.u0, step.OPERAND_CYCLES, "word_a", data=True)
            b_op = delayed(m, st.u1, step.OPERAND_CYCLES, "word_b", data=True)
            reads_matter = [st.issuing]
            frac = st.frac[F - PB - INTERP_FRAC_BITS:F - PB]
        else:
            m.d.comb += cache.read_pos[0].eq(st.cpos)
            if interp == "linear":
                m.d.comb += cache.read_pos[1].eq(st.cpos + 1)
            assert all(cache.read_latency(k) == step.OPERAND_CYCLES for k in range(len(readers)))
            a_op = cache.read_word[0]
            b_op = cache.read_word[len(readers) - 1]
            reads_matter = [sch.step & ~state.mute] * len(readers)
            frac = st.frac[F - INTERP_FRAC_BITS:]
        m.d.comb += [step.a.eq(a_op), step.b.eq(b_op), step.frac.eq(frac), step.mute.eq(state.mute)]
        if c.pool == "sdram":
            self._arrival_check(m, cache, state, reads_matter, rg)

        # ---- the window, the product, gain and slot sum ------------------------
        m.submodules.window = win = self._window
        m.d.comb += [win.win_data.eq(self.win_data), win.write.eq(sch.step_start),
                     win.held_index.eq(sch.held_index), win.step_index.eq(sch.step_index), win.tap.eq(rg.tap)]
        m.submodules.product = prod = self._product
        geff = Signal(rg.gain.shape(), name="geff")
        m.d.comb += [geff.eq(Mux(rg.enable, rg.gain, 0)),
                     prod.a.eq(win.o), prod.b.eq(step.word), prod.b2.eq(step.word2),
                     prod.gain.eq(self._pattern_gain(m, geff, rg) if c.scan else geff),
                     prod.vslot.eq(sch.vslot), self.sum.eq(prod.sum)]
        return m

    def _pattern_gain(self, m, geff, rg):
        """The visiting slot's gain times the pattern at the step's beam less
        its AZIMUTH, GAIN_INPUT_DELAY + PatternGain.latency clocks after the
        visit (the product stage waits that long for it)."""
        V = visit_cycles(self._c.slots)
        m.submodules.pattern_gain = pg = self._pattern
        beam = delayed(m, self.beam, V + GAIN_INPUT_DELAY - BEAM_CLOCK, "beam", data=True)
        p = self.pattern
        m.d.comb += [pg.gain.eq(delayed(m, geff, GAIN_INPUT_DELAY, "pg_gain", data=True)),
                     pg.azimuth.eq(delayed(m, rg.azimuth, GAIN_INPUT_DELAY, "pg_azimuth", data=True)),
                     pg.beam.eq(beam.code), pg.scan.eq(beam.on), pg.shift.eq(p.shift), pg.floor.eq(p.floor),
                     pg.w_en.eq(p.w_en), pg.w_addr.eq(p.w_addr), pg.w_data.eq(p.w_data)]
        return pg.o

    def _arrival_check(self, m, cache, state, reads_matter, rg):
        """SDRAM pool: a read that matters (a playing channel's step, the FIR's
        MAC) of a cache position whose word has not arrived raises
        ``underflow`` (for a clock; the register file keeps it in STATUS): a
        fetch later than the contract's bound (:class:`ArrivalCheck`). The
        block-RAM pool's fixed latency needs no check."""
        M = self._c.slots
        SB = max(1, (M - 1).bit_length())
        playing = Signal(name="playing")
        m.d.comb += playing.eq(rg.enable & state.present)
        m.submodules.arrival = check = ArrivalCheck(cache.depth, len(reads_matter))
        st = state.head
        fill_addr = Cat(self.fill_tag.pos, self.fill_tag.slot[:SB]) if M > 1 else self.fill_tag.pos
        m.d.comb += [check.grant.eq(state.grant),
                     check.grant_pos.eq(Cat(st.f_pos, state.vslot[:SB]) if M > 1 else st.f_pos),
                     check.fill_en.eq(self.fill_en), check.fill_pos.eq(fill_addr),
                     self.underflow.eq(check.underflow)]
        for k, matters in enumerate(reads_matter):
            chk = Signal(name=f"read{k}_checked")
            m.d.sync += chk.eq(matters & playing)
            m.d.comb += [check.read_pos[k].eq(cache.read_addr[k]), check.read_matters[k].eq(chk)]
