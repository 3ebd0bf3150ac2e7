"""The wind-farm replay block of seed Fig. 2.2 as a time-multiplexed engine."""

import operator
from types import SimpleNamespace
from functools import reduce

from amaranth.hdl import Module, Signal, Mux, Cat, Const, signed
from amaranth.lib import wiring, stream, data
from amaranth.lib.wiring import In, Out

from .iq import IQ
from .channel_pipeline import (ChannelPipeline, SlotInit, fetch_tag_layout, accept_clock, COMMON_OUT_CYCLES,
                               REQUEST_CYCLES, MIRROR_LAG)
from .delay_line import DelayLine
from .stream_pool import StreamPool
from .output_fifo import OutputFIFO
from .ecp5_primitives import kept_register, block_ram_rows, dp16kd_mode, delay_line_floorplan
from .pool_check import PoolReadCheck
from .registered_fifo import RegisteredFIFO
from .sdram_pool import SDRAMStreamPool, native_port_signature, WORD_WIDTH
from .registers import BusSignature, RegisterFile, channel_regs_layout, slot_values_layout
from .acp_input import AcpInput
from .scan_generator import ScanGenerator, SCAN_MODES
from .pipeline.pattern_gain import BEAM_LAYOUT, PATTERN_LAYOUT
from .follow.assigner import BeamAssigner
from .follow.loader import FollowLoader
from .follow.table import TurbineTable
from rast.model.contract.fixedpoint import (ReplayContract, INPUT_WIDTH, OUTPUT_WIDTH, COMMON_LAG,
                                            ACCEPT_LAG, POOL_FETCH_CYCLES, SDRAM_QUEUE_DEPTH,
                                            SDRAM_REQUEST_FIFO, SDRAM_MAX_POOL_WORDS, REGISTER_STAGING,
                                            WRITE_STAGING, take_interval, tree_cycles,
                                            tree_operand_registers, visit_cycles, reset_slot)
from rast.model.contract.regmap import register_map, FOLLOW_SWITCH_STEP_BITS
from rast.model.contract.follow import FOLLOW_STEP_BITS
from rast.model.contract.powerup import ChannelInit, pool_contents

__all__ = ["WindFarmReplay", "SDRAM_ADDRESS_WIDTH", "SATURATION_CYCLES"]

#: Clocks from the adder tree's sum to output n in its register: the
#: saturation flags, then the clip.
SATURATION_CYCLES = 2
#: Pipelines whose fetch requests are ORed into one register; more are ORed
#: in two registered levels.
REQUEST_GROUP = 4
#: Word address bits of the SDRAM pool's native port: the whole 32 MB.
SDRAM_ADDRESS_WIDTH = (SDRAM_MAX_POOL_WORDS - 1).bit_length()


class WindFarmReplay(wiring.Component):
    """Replay block: a common delay line, then per channel a tap of the delay
    window, stream x gain; the sum, saturated. The streams sit in one pool,
    fetched into per-channel caches by a scan.

    Time-multiplexed: the fabric clock runs ``slots`` = M clocks per sample;
    ``pipelines`` = ceil(N / M) pipelines (:class:`ChannelPipeline`) serve M
    channels each, one per clock. An input sample is accepted only in a
    period's first clock (``i.ready`` is high there when the output FIFO has
    room); a period without one is a bubble. Each accepted input sample gives
    exactly one output sample, computed from that step alone (``latency`` L,
    the delay lines' lags, plus COMMON_DELAY and the channel's DELAY, in
    samples), whatever the gaps in ``i.valid`` or ``o.ready``: the output
    leaves through a FIFO ``output_cycles`` + 1 clocks after its input.
    Register accesses are taken (``bus.ready``) once in
    ``take_interval(M)`` clocks, whole periods, so that a write lands
    between two steps for every channel (``WRITE_STAGING`` clocks after it
    was taken, in an accepting clock).
    Bit-exact model: :class:`rast.model.contract.datapath.ReplayModel`.

    Parameters
    ----------
    channels : int
        N, 1 to ReplayContract.MAX_CHANNELS.
    slots, pool_words, max_delay, max_tap, interpolation, cmult_form, sample_rate_hz, pool, scan, start_frac, follow_rows :
        See :class:`rast.model.contract.fixedpoint.ReplayContract`. With ``pool="sdram"``
        the streams are fetched through :class:`~rast.hdl.sdram_pool.SDRAMStreamPool`
        whose native port is ``native`` in the clock domain ``sdram`` (the
        parent defines it and connects a LiteDRAM core); there are no
        power-up streams, and bus accesses wait while a stream word is on
        its way into the pool, so that it is queued before anything a later
        access starts (a switch's first fetch).
    init : list of ChannelInit, optional
        Power-up streams (in the pool at their bases) and register values.
    init_common_delay : int
        Power-up COMMON_DELAY.
    sdram_preloaded : bool
        With ``pool="sdram"`` and ``init``: the SDRAM holds ``init``'s
        streams before the engine leaves reset (a simulation's SDRAM model
        loaded at the start, :class:`rast.sim.sdram_top.SDRAMEngineTop`); a
        board's SDRAM powers up empty, and without this ``init``'s streams
        are refused there.

    Members
    -------
    i : In(stream.Signature(IQ(16)))
    o : Out(stream.Signature(IQ(16)))
    bus : In(BusSignature(addr_width))
        Register access (map: ``rast.model.contract.regmap``, ``docs/registers.md``).
    overflow : Out(1)
        Sticky saturation flag (cleared by reading STATUS).
    slot : Out(range(slots))
        The slot counter: 0 in a period's first clock, the one that accepts
        input (the board's converter clocks are made from it);
        ``reset_slot(slots)`` in the clock of reset.
    native : Out(native_port_signature(SDRAM_ADDRESS_WIDTH, 32)), SDRAM pool only
        LiteDRAM's native user port (the whole SDRAM's word address; the
        pool is its first ``pool_words``), in domain ``sdram``.
    pool_error : Out(1), SDRAM pool only
        Sticky: a fetch request or a stream word found no room, or the pool
        lost an answer (cannot happen; the cosimulation asserts it stays 0).
    underflow : Out(1), SDRAM pool only
        STATUS.underflow: a channel read a stream word before it arrived (a
        fetch later than the contract's bound), sticky until STATUS is read.
    acp, arp : In(1), with the antenna scan (``scan``)
        The radar's azimuth change and reference pulses, asynchronous
        (:class:`AcpInput`: synchronised, glitch-filtered). A rising edge on
        a pin counts for the steps accepted ``acp_lead`` clocks or more after
        the clock it is first seen in.
    """

    def __init__(self, channels=4, *, slots=1, pool_words=ReplayContract.pool_words,
                 max_delay=ReplayContract.max_delay, max_tap=ReplayContract.max_tap,
                 interpolation="fir", cmult_form="4mult", sample_rate_hz=0, pool="bram", scan=False,
                 start_frac=False, follow_rows=0, init=None, init_common_delay=0, acp_filter_clocks=16, sdram_preloaded=False):
        self._contract = ReplayContract(channels=channels, slots=slots, pool_words=pool_words,
                                        max_delay=max_delay, max_tap=max_tap,
                                        interpolation=interpolation, cmult_form=cmult_form,
                                        sample_rate_hz=sample_rate_hz, pool=pool, scan=scan,
                                        start_frac=start_frac, follow_rows=follow_rows)
        self._acp_inputs = (AcpInput(acp_filter_clocks), AcpInput(acp_filter_clocks)) if scan else None
        init = list(init or [])
        if len(init) > channels:
            raise ValueError(f"Initial contents must be given for at most {channels} channels, "
                             f"not {len(init)}")
        for k, ini in enumerate(init):
            if not isinstance(ini, ChannelInit):
                raise TypeError(f"Initial contents of channel {k} must be a ChannelInit, not {ini!r}")
        self._init = init + [ChannelInit()] * (channels - len(init))
        self._pool_init = pool_contents(init, pool_words) if any(ini.words for ini in init) else []
        if not isinstance(sdram_preloaded, bool):
            raise TypeError(f"SDRAM preloaded must be a bool, not {sdram_preloaded!r}")
        if self._pool_init and pool == "sdram" and not sdram_preloaded:
            raise ValueError("Initial streams need a block-RAM pool: an SDRAM pool powers up empty "
                             "(load the streams through the bus)")
        if not isinstance(init_common_delay, int) or not 0 <= init_common_delay <= max_delay:
            raise ValueError(f"Initial common delay must be an integer in [0, {max_delay}], "
                             f"not {init_common_delay!r}")
        self._rmap = register_map(self._contract, self._init, init_common_delay)
        super().__init__({
            "i": In(stream.Signature(IQ(INPUT_WIDTH))),
            "o": Out(stream.Signature(IQ(OUTPUT_WIDTH))),
            "bus": In(BusSignature(self._rmap.addr_width)),
            "overflow": Out(1),
            "slot": Out(range(max(2, slots)), init=reset_slot(slots)),
            **({"native": Out(native_port_signature(SDRAM_ADDRESS_WIDTH, WORD_WIDTH)),
                "pool_error": Out(1), "underflow": Out(1)} if pool == "sdram" else {}),
            **({"acp": In(1), "arp": In(1)} if scan else {}),
        })

    @property
    def contract(self) -> ReplayContract:
        return self._contract

    @property
    def init_common_delay(self) -> int:
        """Power-up COMMON_DELAY."""
        return self._rmap.reg("COMMON_DELAY").field("delay").reset

    @property
    def register_map(self):
        return self._rmap

    @property
    def channels(self):
        return self._contract.channels

    @property
    def latency(self):
        """Fixed latency L in samples (``ReplayContract.latency``)."""
        return self._contract.latency

    @property
    def acp_filter_clocks(self) -> int:
        """With the scan: the clocks an ACP or ARP pin must hold a new level."""
        return self._acp_inputs[0].filter_clocks

    @property
    def acp_lead(self) -> int:
        """With the scan: an ACP or ARP pin that rises in clock c (first high
        there) counts for the steps whose input is accepted in clock
        c + acp_lead or later: the input's synchroniser and filter, the
        generator's register, less the clocks from the accept to the
        generator taking the step."""
        return self._acp_inputs[0].latency + 1 - ACCEPT_LAG

    @property
    def fifo_depth(self) -> int:
        """Output FIFO words: every sample accepted and not yet taken from ``o``."""
        c = self._contract
        return -(-(c.output_cycles + 2) // c.slots) + 2

    def _slot_inits(self, p):
        c, rmap = self._contract, self._rmap
        out = []
        for s in range(c.slots):
            ch = p * c.slots + s
            if ch >= c.channels:
                out.append(SlotInit(False, c.min_stream_length, 0, 0))
                continue
            out.append(SlotInit(True, rmap.reg("LENGTH", ch).field("length").reset,
                                rmap.reg("PHASE_INC", ch).field("inc").reset,
                                rmap.reg("BASE", ch).field("base").reset))
        return out

    def elaborate(self, platform):
        m = Module()
        c = self._contract
        N, M, P = c.channels, c.slots, c.pipelines
        # every stage reads the names the stages before it made (``env``)
        env = SimpleNamespace(m=m, platform=platform, c=c, N=N, M=M, P=P, Sw=REGISTER_STAGING,
                              b0=0 if M == 1 else 1,                  # a pipeline's update stage
                              K=c.output_cycles, regs_layout=channel_regs_layout(self._rmap),
                              values_layout=slot_values_layout(self._rmap))
        for stage in (self._input, self._registers, self._beam, self._follow, self._common_line,
                      self._pool_and_scan, self._pipelines, self._requests, self._sum_and_output):
            stage(env)
        return m

    def _input(self, env):
        """The slot counter, the input's ready and its credit, the accept and its sample in registers
        beside the pins."""
        M, m, platform = env.M, env.m, env.platform
        # ---- the slot counter and the input ------------------------------------
        slot = self.slot
        if M > 1:
            m.d.sync += slot.eq(Mux(slot == M - 1, 0, slot + 1))
        s0 = reset_slot(M)
        # The clock before the pipelines' period start (the top's slot s0, as
        # in the clock of reset), from a register: the compare drove the
        # enables of the fetch scan's ring, spread over the device (6.0-6.4
        # ns at 64 channels).
        start = Signal(init=1)
        m.d.sync += start.eq(slot == (s0 - 1) % M)
        F = self.fifo_depth
        in_flight = Signal(range(F + 1))
        accept = Signal()
        out_taken = Signal()
        # i.ready from a register (it fans out to every pipeline through
        # ``accept``): high in the period's first clock when the FIFO has
        # room for every sample in flight, counted the clock before.
        ready = Signal()
        if M == 1:
            m.d.sync += [ready.eq(in_flight + accept - out_taken < F),
                         in_flight.eq(in_flight + accept - out_taken)]
        else:
            # ``accept`` (i.valid & ready) is made beside the input's pins; in the
            # count that decides ``ready`` it was a loop from ``ready`` out to
            # the pins and back (n10_20_200's worst path, 7.3 ns, 5.5 routing),
            # and ``out_taken`` came from the output's pins through the FIFO
            # (7.4 ns). From M = 2 both enter the count a clock late, from
            # registers: the count is then the words accepted and not taken
            # before this clock. It decides ``ready`` in the period's last
            # clock, which accepts nothing (``ready`` is low there); a word
            # taken in that same clock frees its place for the next period's
            # decision, not this one's (the output then waits a period
            # sooner, never a word lost). The decision takes the count of the
            # clock before, as if a word had been accepted since and none taken
            # (count <= in_flight + 1): one place fewer than exact, which the
            # FIFO's spare places cover at the full input rate
            # (tests/test_hdl_replay_top.py); the sum and compare in one clock
            # were a 16-channel build's latest path (6.4 ns). The registers
            # hold the count's step, +1, -1 or 0, as the two's complement
            # the adder takes (``change``: the low bit, ``down``: every bit
            # above), so that the count is one carry chain from registers
            # (the step's LUT between the taken flag's register and the chain
            # was among the 16-channel builds' latest paths, 5.2-5.4 ns).
            change = Signal()
            down = Signal()
            step = Cat(change, down.replicate(len(in_flight) - 1))
            m.d.sync += [change.eq(accept ^ out_taken), down.eq(out_taken & ~accept),
                         ready.eq((slot == M - 1) & (in_flight < F - 1)),
                         in_flight.eq(in_flight + step)]
        m.d.comb += [self.i.ready.eq(ready), accept.eq(self.i.valid & ready),
                     out_taken.eq(self.o.valid & self.o.ready)]
        # The accept and its sample once more in registers (kept, so that
        # they stay beside the input's pins), ACCEPT_LAG - 1 clocks later: the
        # engine takes the step from here, the clock before the pipelines'
        # period start.
        stepped, x_in = accept, self.i.payload.as_value()
        for k in range(ACCEPT_LAG - 1):
            stepped_in = stepped          # (``stepped`` a clock earlier)
            stepped = kept_register(m, platform, stepped, f"accept_q{k}", reset=True)
            x_in = kept_register(m, platform, x_in, f"x_q{k}")
        env.__dict__.update(F=F, accept=accept, s0=s0, slot=slot, start=start, stepped=stepped, x_in=x_in,
                            start_in=slot == (s0 - 1) % M, stepped_in=stepped_in)

    def _registers(self, env):
        """The register file, and when it may take the bus."""
        K, M, N, P, Sw, b0, c, m, s0 = env.K, env.M, env.N, env.P, env.Sw, env.b0, env.c, env.m, env.s0
        slot = env.slot
        # ---- registers ---------------------------------------------------------
        # Writes land in the clock before the pipelines' period start (top
        # slot s0, a clock after the accepting one): taken Sw =
        # REGISTER_STAGING clocks earlier. A read samples the slots' mirrors
        # after the last slot's update of the step before (the update's end V
        # + b0 after its visit, its mirrors MIRROR_LAG later), the sticky
        # overflow in the clock of the next step's saturation (K clocks after
        # its accept, which is ACCEPT_LAG - 1 clocks before the landing).
        V = visit_cycles(M)
        m.submodules.regs = regs = RegisterFile(
            self._rmap, mirror_delay=V + b0 + MIRROR_LAG + 1 + Sw, status_delay=K + WRITE_STAGING,
            groups=[list(range(p * M, min(N, (p + 1) * M))) for p in range(P)], slots=M,
            # a read sees the beam after every step accepted before its landing
            # and none after: the generator takes a step ACCEPT_LAG clocks after
            # its accept, and the landing clock's own input in the clock after
            scan_delay=WRITE_STAGING + ACCEPT_LAG)
        if c.follow_rows:
            env.loader = loader = FollowLoader(self._rmap)
            _share_bus(m, self.bus, loader.bus, regs.bus)
        else:
            wiring.connect(m, wiring.flipped(self.bus), regs.bus)
        # ``take`` (the bus's ready) from a register: it reaches the host bridge's
        # control, and decoded from the slot counter it was the 10-channel
        # build's critical path (slot -> ready -> bridge, 7.7 ns). One clock
        # in take_interval(M) (whole periods), Sw clocks before a landing (in
        # clocks from reset, landings are at multiples of M); below M = 8 a
        # clock counter of its own counts the interval.
        W = take_interval(M)
        take_at = -Sw % W
        take = Signal(init=take_at == 0)
        if W == M:
            m.d.sync += take.eq(slot == (take_at - 1 + s0) % M)
        else:
            clock = Signal(range(W), name="take_clock")
            m.d.sync += [clock.eq(Mux(clock == W - 1, 0, clock + 1)),
                         take.eq(clock == (take_at - 1) % W)]
        m.d.comb += self.overflow.eq(regs.overflow)
        sdram = c.pool == "sdram"
        w_held = w_held_addr = w_held_data = w_lost = None          # (SDRAM pool only)
        if sdram:
            # A stream word goes from the register file to the SDRAM pool's
            # write port through a one-word holding register. No access is
            # taken while a write may still be on its way there (taken in the
            # last Sw + 1 clocks, or held): so every stream word is in the
            # pool's queue, which keeps order, before any later access (the
            # switch to the stream, hence its first fetch) is taken.
            w_held = Signal()
            w_held_addr = Signal.like(regs.wr_addr)
            w_held_data = Signal.like(regs.wr_data)
            w_lost = Signal()
            taken_write = Signal()
            recent = Signal(Sw + 1)
            busy = Signal()
            m.d.comb += taken_write.eq(self.bus.ready & self.bus.w_stb)
            m.d.sync += [recent.eq(Cat(taken_write, recent[:-1])),
                         busy.eq(taken_write | (recent != 0) | regs.wr_en | w_held)]
            m.d.comb += regs.take.eq(take & ~busy)
        else:
            m.d.comb += regs.take.eq(take)
        if c.start_frac:
            # the steps since reset, counted at the landing clock (``start``:
            # the clock before the pipelines' period start, where a write lands
            # and the period's step is ``stepped``), for FOLLOW_SWITCH; the
            # landing clock and its step from kept registers of the following's
            # own (``start`` fans out over the whole device: from it, the
            # switch's held flag was the following build's latest path, 9.3 ns
            # of which 7.9 routing)
            land_tick = kept_register(m, env.platform, env.start_in, "follow_land_tick", reset=True, init=1)
            land_step = kept_register(m, env.platform, env.start_in & env.stepped_in, "follow_land_step", reset=True)
            steps = Signal(FOLLOW_SWITCH_STEP_BITS, name="steps_lo")
            with m.If(land_step):
                m.d.sync += steps.eq(steps + 1)
            m.d.comb += [regs.step_lo.eq(steps), regs.land_tick.eq(land_tick), regs.land_step.eq(land_step)]
            env.__dict__.update(steps_lo=steps, land_step=land_step)
        env.__dict__.update(V=V, regs=regs, sdram=sdram, w_held=w_held, w_held_addr=w_held_addr,
                            w_held_data=w_held_data, w_lost=w_lost)

    def _common_line(self, env):
        """The common delay line, c[n] = x[n - COMMON_LAG - COMMON_DELAY], and the block-RAM floorplan."""
        M, P, c, m, platform, regs, sdram = env.M, env.P, env.c, env.m, env.platform, env.regs, env.sdram
        stepped, x_in = env.stepped, env.x_in
        # ---- the common delay line: c[n] = x[n - COMMON_LAG - COMMON_DELAY] ------
        # x[n] is handed to the line in the clock before the pipelines' period
        # start (``stepped``) and reaches the RAM in the period start (from M =
        # 2 both a clock later, below); the read for step n is asked in that
        # clock too (the step count before its increment, the common delay that
        # applies from the period start), so that c[n] is out three clocks after
        # the period start and in a register for the pipelines at
        # COMMON_OUT_CYCLES (4). The line's block RAMs are spread over the rows:
        # each has its own write registers (one register fed all 16: 7.7 ns of
        # routing in a two-pipeline build, docs/bitstream.md), and the read
        # address, registered once, is copied per row. Where the pool's banks
        # are placed, its floorplan keeps a block of sites in the middle of each
        # row for them (in the free sites the placer chose, one sat up to 61
        # rows from its registers: 6.4-6.8 ns of one route), and the sites left
        # in blocks, one for each pipeline's window (rows in turn), whose RAMs
        # the placer had put in single free sites far apart (a window's write
        # data, 5.6 ns of one route). An SDRAM build, with no banks, places
        # the lines the same way (delay_line_floorplan).
        ptag = fetch_tag_layout(M)
        pool_tag = data.StructLayout({"pipe": range(max(2, P)), "fetch": ptag})
        mode = dp16kd_mode(2 * INPUT_WIDTH, c.common_depth)
        win_mode = dp16kd_mode(2 * INPUT_WIDTH, c.window_depth)
        rows = block_ram_rows(platform)
        per_row = -(-mode[1] // len(rows)) if mode and rows else 0
        # a pipeline's block: its window's sites, then its pattern table's
        # (the placer's free choice put a table's block RAM 6.2 ns of one
        # route from its pipeline, the scan build's latest path at two seeds)
        block = (win_mode[1] + int(c.scan)) if win_mode else 0
        pool = None if sdram else StreamPool(c.pool_words, pool_tag.size, init=self._pool_init,
                                             reserve_sites=per_row, block_sites=block)
        reserved = pool and pool.reserved_sites(platform)
        window_blocks = (pool and pool.free_blocks(platform, P)) or []
        if sdram and mode and win_mode and (plan := delay_line_floorplan(rows, per_row, block, P)):
            reserved, window_blocks = plan
        common_bits = DelayLine.slice_bits(2 * INPUT_WIDTH, c.max_delay, COMMON_LAG)
        common_groups = -(-2 * INPUT_WIDTH // common_bits)
        m.submodules.common = common = DelayLine(
            2 * INPUT_WIDTH, c.max_delay, COMMON_LAG, group_bits=common_bits,
            sites=[bel for row in reserved for bel in row][:mode[1]] if reserved else None,
            address_copies=min(len(rows), common_groups) if rows else 1)
        # the read asked a clock before the period start, c[n] then in the top's register
        assert common.depth == c.common_depth and common.latency - 1 + 1 == COMMON_OUT_CYCLES
        # c[n] registered once beside the line's RAMs (their output registers'
        # clock-to-out and a route to every pipeline in one clock were a latest
        # path at 64 channels, 6.5-6.9 ns), then copied per pipeline (below)
        # The step count. From M = 2 it counts a clock after the accept, from
        # a register of its own beside it: the next accept is M clocks later,
        # when the count is up to date (``ready`` -> ``accept`` -> the count's
        # enable, from the input's pins to the line's RAMs, was the 64-channel
        # build's latest path, 7.4 ns, 6.0 of it one route). The write goes
        # with it, x[n] from a register (``ready`` -> ``accept`` -> the
        # groups' write enables was then the latest, 6.4 ns): it reaches the
        # RAM a clock after the period start, still M - 1 >= 1 clocks before
        # the read for step n + 1 addresses it.
        cnt = Signal(range(c.common_depth))
        x = x_in
        written = stepped
        if M > 1:
            written = kept_register(m, platform, stepped, "common_accept", reset=True)
            x = kept_register(m, platform, x, "common_x")
        # a second counter the same, for the read address's adder alone (the
        # count's fan-out to the write registers and the adder was late at
        # 16 channels, 5.3 ns; counters from their own registers are not one
        # to synthesis)
        cnt_read = Signal(range(c.common_depth), name="common_read_count")
        with m.If(written):
            m.d.sync += [cnt.eq(cnt + 1), cnt_read.eq(cnt_read + 1)]
        m.d.comb += [common.w_en.eq(written), common.w_index.eq(cnt), common.w_data.eq(x),
                     common.r_index.eq(cnt_read), common.r_delay.eq(regs.common_delay_next)]
        window_sites = [b[:win_mode[1]] for b in window_blocks]
        pattern_sites = [b[-1] for b in window_blocks] if c.scan else []
        env.__dict__.update(common=common, pool=pool, pool_tag=pool_tag, window_sites=window_sites,
                            pattern_sites=pattern_sites)

    def _pool_and_scan(self, env):
        """The stream pool and the fetch scan that offers each pipeline's slots a fetch."""
        P, V, c, m, platform, pool_tag = env.P, env.V, env.c, env.m, env.platform, env.pool_tag
        regs, sdram, start, w_held = env.regs, env.sdram, env.start, env.w_held
        w_held_addr, w_held_data, w_lost, pool = env.w_held_addr, env.w_held_data, env.w_lost, env.pool
        # ---- the pool and the fetch scan -----------------------------------------
        if sdram:
            m.submodules.pool = pool = SDRAMStreamPool(SDRAM_ADDRESS_WIDTH, pool_tag.size,
                                                       queue_depth=SDRAM_QUEUE_DEPTH, sdram_domain="sdram")
            wiring.connect(m, pool.native, wiring.flipped(self.native))
            with m.If(regs.wr_en):
                m.d.sync += [w_held.eq(1), w_held_addr.eq(regs.wr_addr), w_held_data.eq(regs.wr_data)]
                with m.If(w_held & ~pool.w_ready):
                    m.d.sync += w_lost.eq(1)
            with m.Elif(pool.w_ready):
                m.d.sync += w_held.eq(0)
            m.d.comb += [pool.w_valid.eq(w_held), pool.w_addr.eq(w_held_addr), pool.w_data.eq(w_held_data)]
            # POOL_CHECK: the host's read-back of what the SDRAM holds
            m.submodules.pool_check = check = PoolReadCheck(c.pool_address_width, c.length_width)
            m.d.comb += [check.start.eq(regs.check_start), check.addr.eq(regs.check_addr),
                         check.words.eq(regs.check_words), regs.check_busy.eq(check.busy),
                         regs.check_crc.eq(check.crc),
                         pool.rd_valid.eq(check.rd_valid), pool.rd_addr.eq(check.rd_addr),
                         check.rd_ready.eq(pool.rd_ready), check.rd_data_valid.eq(pool.rd_data_valid),
                         check.rd_data.eq(pool.rd_data)]
        else:
            m.submodules.pool = pool
            m.d.comb += [pool.w_en.eq(regs.wr_en), pool.w_addr.eq(regs.wr_addr), pool.w_data.eq(regs.wr_data)]
        # One pipeline's slots are offered a fetch per period, pipelines in turn
        # (from the pipelines' period start).
        scan = Signal(P, init=1)
        with m.If(start):
            m.d.sync += scan.eq(scan.rotate_left(1))
        req_valid = Signal()
        req_addr = Signal.like(pool.r_addr)
        req_tag = Signal(pool_tag)
        credit = Const(1)
        grouped = P > REQUEST_GROUP          # the requests ORed in two registered levels
        if sdram:
            # Fetches queue in a FIFO in front of the pool, which may refuse
            # them. An offer reaches the FIFO V + 3 + REQUEST_CYCLES clocks
            # later (the offer's register, the pipeline's offer delay, its
            # request registers, the top's request register; one more with
            # the group's), so a pipeline is offered fetches only while the
            # FIFO, as counted a clock before, has room for every offer since.
            # (buffered: the pool decides on its head from registers; its
            # level a thermometer code, so that the credit is a flip-flop's
            # copy: SDRAM_REQUEST_FIFO words, a ring of one fewer and the head)
            m.submodules.req_fifo = req_fifo = RegisteredFIFO(len(req_addr) + pool_tag.size,
                                                              SDRAM_REQUEST_FIFO - 1)
            credit = Signal()
            req_lost = Signal()
            most = SDRAM_REQUEST_FIFO - V - 4 - REQUEST_CYCLES - grouped
            assert 0 <= most < SDRAM_REQUEST_FIFO, "the request FIFO must hold every offer in flight"
            m.d.sync += credit.eq(~req_fifo.fill[most])          # level <= most
            with m.If(req_valid & ~req_fifo.w_rdy):
                m.d.sync += req_lost.eq(1)
            m.d.comb += [req_fifo.w_en.eq(req_valid), req_fifo.w_data.eq(Cat(req_addr, req_tag)),
                         pool.r_valid.eq(req_fifo.r_rdy), pool.r_addr.eq(req_fifo.r_data[:len(req_addr)]),
                         pool.r_tag.eq(req_fifo.r_data[len(req_addr):]), req_fifo.r_en.eq(pool.r_ready),
                         self.pool_error.eq(req_lost | w_lost | pool.lost)]
        else:
            m.d.comb += [pool.r_valid.eq(req_valid), pool.r_addr.eq(req_addr), pool.r_tag.eq(req_tag)]
        fill_valid = Signal()
        fill_tag = Signal(pool_tag)
        fill_data = Signal.like(pool.d_data, reset_less=True)
        m.d.sync += [fill_valid.eq(pool.d_valid), fill_tag.eq(pool.d_tag), fill_data.eq(pool.d_data)]
        # grant (visit) -> pipeline's request registers -> (the group's request
        # register, beyond REQUEST_GROUP pipelines) -> this register -> the
        # pool -> fill_* -> (the pair's copy, from three pipelines) -> the
        # pipeline's fill register -> the cache. The pair's copies are kept
        # registers: from the one register into every pipeline's copy was
        # 5.7 ns of one route at 16 channels, the pipelines spread over the chip.
        fill_pairs = P > 2
        if not sdram:
            assert 2 + REQUEST_CYCLES + grouped + pool.latency + 1 + fill_pairs <= POOL_FETCH_CYCLES, \
                "the contract's fetch latency is too short"
        fill_copies = {}
        for g in range((P + 1) // 2 if fill_pairs else 0):
            fill_copies[g] = (kept_register(m, platform, fill_valid & (fill_tag.pipe >> 1 == g), f"fill_valid_g{g}",
                                            reset=True),
                              kept_register(m, platform, fill_tag.as_value(), f"fill_tag_g{g}"),
                              kept_register(m, platform, fill_data, f"fill_data_g{g}"))
        env.__dict__.update(credit=credit, fill_copies=fill_copies, fill_data=fill_data,
                            fill_pairs=fill_pairs, fill_tag=fill_tag, fill_valid=fill_valid,
                            grouped=grouped, req_addr=req_addr, req_tag=req_tag, req_valid=req_valid,
                            scan=scan)

    def _beam(self, env):
        """The antenna scan: the radar's pulses, the beam's generator, and the
        beam of each step as the generator takes it, with the pattern's
        settings, for the pipelines (``beam``, ``pattern``)."""
        env.beam = env.pattern = env.gen_beam = None
        if not self._contract.scan:
            return
        m, regs, stepped = env.m, env.regs, env.stepped
        m.submodules.acp_in, m.submodules.arp_in = acp_in, arp_in = self._acp_inputs
        m.submodules.scan = gen = ScanGenerator(step_clocks=env.M)
        # The generator takes the step in the pipelines' period start, after a
        # write before it has landed (a clock before): SCAN_CTRL's restart and
        # mode count from the step they are written before, as GAIN does.
        takes = Signal(name="scan_takes")
        m.d.sync += takes.eq(stepped)
        m.d.comb += [acp_in.pin.eq(self.acp), arp_in.pin.eq(self.arp),
                     gen.acp.eq(acp_in.rise), gen.arp.eq(arp_in.rise),
                     gen.settings.eq(regs.scan), gen.restart.eq(regs.scan_restart), gen.accept.eq(takes),
                     regs.scan_beam.eq(gen.beam), regs.scan_lost.eq(gen.arp_lost),
                     regs.scan_learned.eq(gen.learned), regs.scan_per_rev.eq(gen.per_rev)]
        beam = Signal(BEAM_LAYOUT, name="step_beam")
        with m.If(takes):
            m.d.sync += [beam.code.eq(gen.beam), beam.on.eq(regs.scan.mode != SCAN_MODES["stare"])]
        pattern = Signal(PATTERN_LAYOUT, name="pattern")
        m.d.comb += [pattern.shift.eq(regs.pattern_shift), pattern.floor.eq(regs.pattern_floor),
                     pattern.w_en.eq(regs.pattern_w_en), pattern.w_addr.eq(regs.pattern_w_addr),
                     pattern.w_data.eq(regs.pattern_w_data)]
        env.beam, env.pattern, env.gen_beam = beam, pattern, gen.beam

    def _follow(self, env):
        """Channels that follow the beam: the turbine table, the assigner
        (the generator's beam), the loader (writing through the bus beside
        the host) and the scene's step counter (docs/beam_following.md)."""
        c = self._contract
        if not c.follow_rows:
            return
        m, regs, loader = env.m, env.regs, env.loader
        m.submodules.turbines = table = TurbineTable(c.follow_rows)
        m.submodules.assigner = assigner = BeamAssigner(rows=c.follow_rows, channels=c.channels)
        m.submodules.loader = loader
        # the scene's steps, counted at the landing clock as FOLLOW_SWITCH's; the
        # start lands before step 0: this period's, or the next one
        scene = Signal(FOLLOW_STEP_BITS, name="scene_step")
        with m.If(regs.follow_start):
            m.d.sync += scene.eq(env.stepped)
        with m.Elif(env.land_step):
            m.d.sync += scene.eq(scene + 1)
        overrun_q = Signal()
        m.d.sync += overrun_q.eq(assigner.overrun)
        took = assigner.event.valid & assigner.event.ready
        m.d.comb += [table.w_en.eq(regs.table_w_en), table.w_addr.eq(regs.table_w_addr),
                     table.w_data.eq(regs.table_w_data),
                     assigner.settings.eq(regs.follow), assigner.start.eq(regs.follow_start),
                     assigner.beam.eq(env.gen_beam),
                     table.az_addr.eq(assigner.az_addr), assigner.az_data.eq(table.az_data),
                     loader.event.payload.eq(assigner.event.payload),
                     loader.event.valid.eq(assigner.event.valid & regs.follow_on),
                     assigner.event.ready.eq(loader.event.ready & regs.follow_on),
                     table.row_addr.eq(loader.row_addr), loader.row_data.eq(table.row_data),
                     loader.scene.eq(scene), loader.steps_lo.eq(env.steps_lo),
                     regs.follow_late_set.eq(loader.late | (took & assigner.event.payload.enter
                                                           & assigner.event.payload.late)),
                     regs.follow_overrun_set.eq(assigner.overrun & ~overrun_q)]

    def _pipelines(self, env):
        """The pipelines, each with its copies of the accept, c[n], the offer and the pool's answers."""
        M, N, P, c, common, credit = env.M, env.N, env.P, env.c, env.common, env.credit
        fill_copies, fill_data, fill_pairs = env.fill_copies, env.fill_data, env.fill_pairs
        fill_tag, fill_valid, m, platform = env.fill_tag, env.fill_valid, env.m, env.platform
        pool_tag, regs, regs_layout, scan = env.pool_tag, env.regs, env.regs_layout, env.scan
        stepped, values_layout = env.stepped, env.values_layout
        window_sites, pattern_sites = env.window_sites, env.pattern_sites
        # ---- the pipelines ---------------------------------------------------------
        pipes = []
        reqs = []
        # c[n] from the common line's register through a tree of copies
        # (kept) where the windows' writes leave room (from M = 3): a level
        # per halving of the pipelines, down to pairs. One register into
        # every pipeline's first copy was the 64-channel build's latest path
        # (6.0 ns of one route); a copy per pair from it, 6.2 ns.
        # Where the windows leave no room for copies (M <= 2), the line's
        # register is itself a copy for each four pipelines (kept): one
        # register for eight pipelines, on both sides of the device, was a
        # 16-channel build's latest path (5.7 ns, 5.2 of it one route).
        win_data_lag = min(ChannelPipeline.win_data_room(M), max(0, (P - 1).bit_length() - 1))
        firsts = 1 if win_data_lag else -(-P // 4)
        copies = {(0, g): kept_register(m, platform, common.o, f"common_word_{g}") for g in range(firsts)}
        for level in range(1, win_data_lag + 1):
            shift = win_data_lag - level + 1          # the level's copies each serve 2**shift pipelines
            for g in range(((P - 1) >> shift) + 1):
                copies[(level, g)] = kept_register(m, platform, copies[(level - 1, g >> 1)],
                                                   f"common_word_l{level}_{g}")
        for p in range(P):
            win_data = copies[(win_data_lag, p >> 1)] if win_data_lag else copies[(0, p // 4)]
            pl = ChannelPipeline(c, p, self._slot_inits(p), regs_layout, values_layout,
                                 window_sites=window_sites[p] if p < len(window_sites) else None,
                                 pattern_site=pattern_sites[p] if p < len(pattern_sites) else None,
                                 win_data_lag=win_data_lag)
            m.submodules[f"pipe{p}"] = pl
            pipes.append(pl)
            # from the accept's register, a copy for each pipeline (kept:
            # equal registers are one to Yosys); from M = 3 a chain of two,
            # the pipeline taking it in its period's second clock
            # (accept_clock)
            acc_p = stepped
            for k in range(accept_clock(M), -1, -1):
                acc_p = kept_register(m, platform, acc_p, f"accept{p}" + (f"_{k}" if k else ""), reset=True)
            # the offer through a register of the pipeline's own too (from
            # the scan's one place into the pipelines' first offer register
            # was a latest path of the 64-channel build, 6.6 ns)
            offer = kept_register(m, platform, scan[p] & credit, f"offer{p}", reset=True)
            m.d.comb += [pl.accept.eq(acc_p), pl.win_data.eq(win_data), pl.offer.eq(offer),
                         pl.values.eq(regs.values[p])]
            if env.beam is not None:
                # a copy of the step's beam and of the pattern's settings for each pipeline
                m.d.comb += [pl.beam.eq(kept_register(m, platform, env.beam.as_value(), f"beam{p}")),
                             pl.pattern.eq(kept_register(m, platform, env.pattern.as_value(), f"pattern{p}"))]
            for s in range(M):
                ch = p * M + s
                if ch < N:
                    m.d.comb += [pl.regs[s].eq(regs.regs[ch]), regs.cmd_ack[ch].eq(pl.cmd_ack[s]),
                                 regs.pending[ch].eq(pl.pending[s]), regs.bank[ch].eq(pl.bank[s])]
            # each pipeline's copy of the answer, kept (one merged copy wrote
            # every pipeline's caches: 896 loads on each tag bit at 64 channels)
            if fill_pairs:
                valid_in, tag_value, data_in = fill_copies[p >> 1]
                tag_in = pool_tag(tag_value)
            else:
                valid_in, tag_in, data_in = fill_valid, fill_tag, fill_data
            fe = Signal(name=f"fill_en{p}")
            ft = kept_register(m, platform, tag_in.fetch, f"fill_tag{p}")
            fd = kept_register(m, platform, data_in, f"fill_data{p}")
            m.d.sync += fe.eq(valid_in & (tag_in.pipe == p))
            m.d.comb += [pl.fill_en.eq(fe), pl.fill_tag.eq(ft), pl.fill_data.eq(fd)]
            reqs.append(pl)
        env.__dict__.update(pipes=pipes, reqs=reqs)

    def _requests(self, env):
        """The pipelines' fetch requests ORed into the pool's request."""
        P, grouped, m, pipes, pool_tag, regs = env.P, env.grouped, env.m, env.pipes, env.pool_tag, env.regs
        req_addr, req_tag, req_valid, reqs = env.req_addr, env.req_tag, env.req_valid, env.reqs
        sdram = env.sdram
        # Only the offered pipeline asks: the requests are ORed, registered,
        # beyond REQUEST_GROUP pipelines in two levels (the groups', then
        # theirs): eight pipelines spread over the device into one OR were a
        # latest path of a 16-channel, 100 MS/s build (7.9 ns).
        def ored(requests, out):
            valid, addr, tag = out
            m.d.sync += [valid.eq(Cat(v for v, _, _ in requests).any()),
                         addr.eq(reduce(operator.or_, [Mux(v, a, 0) for v, a, _ in requests])),
                         tag.eq(reduce(operator.or_, [Mux(v, t, 0) for v, _, t in requests]))]
            return out
        requests = [(pl.req_valid, pl.req_addr, Cat(Const(p, len(req_tag.pipe)), pl.req_tag))
                    for p, pl in enumerate(reqs)]
        if grouped:
            requests = [ored(requests[g:g + REQUEST_GROUP],
                             (Signal(name=f"req_valid_g{g}"), Signal.like(req_addr, name=f"req_addr_g{g}"),
                              Signal(pool_tag.size, name=f"req_tag_g{g}")))
                        for g in range(0, P, REQUEST_GROUP)]
        ored(requests, (req_valid, req_addr, req_tag))

        if sdram:
            # the pipelines' flags ORed into a register first (STATUS's
            # sticky bit a clock later): from every pipeline into the sticky
            # bit's own logic was 5.9 ns at a 200 MHz SDRAM build
            underflow_any = Signal()
            m.d.sync += underflow_any.eq(Cat(pl.underflow for pl in pipes).any())
            m.d.comb += [regs.underflow_set.eq(underflow_any), self.underflow.eq(regs.underflow)]

    def _sum_and_output(self, env):
        """The sum over the pipelines, saturation, the output FIFO."""
        F, K, P, accept, c, m, pipes = env.F, env.K, env.P, env.accept, env.c, env.m, env.pipes
        regs = env.regs
        # ---- the sum over the pipelines, saturation, the output FIFO --------------
        assert ACCEPT_LAG + pipes[0].sum_cycles + tree_cycles(P) + SATURATION_CYCLES == K
        level = [pl.sum for pl in pipes]
        SW = c.sum_width
        depth = 0
        while len(level) > 1:
            nxt = []
            for j in range(0, len(level), 2):
                # each operand again in a register beside the adder (the pair's
                # pipelines may be far apart), then the sum
                pair = []
                for k, v in enumerate(level[j:j + 2]):
                    for d in range(tree_operand_registers(P, depth)):
                        r = Signal.like(v, name=f"tree{depth}_{j // 2}_in{k}_d{d + 1}", reset_less=True)
                        m.d.sync += r.eq(v)
                        v = r
                    pair.append(v)
                s_ = Signal(IQ(SW), name=f"tree{depth}_{j // 2}", reset_less=True)
                m.d.sync += [s_.re.eq(sum(v.re for v in pair)), s_.im.eq(sum(v.im for v in pair))]
                nxt.append(s_)
            level, depth = nxt, depth + 1
        total = level[0]
        lo, hi = -(1 << (OUTPUT_WIDTH - 1)), (1 << (OUTPUT_WIDTH - 1)) - 1
        y = Signal(IQ(OUTPUT_WIDTH), reset_less=True)
        sat = []
        for part in ("re", "im"):
            v = Signal(signed(SW), name=f"sum_{part}", reset_less=True)
            over = Signal(name=f"over_{part}", reset_less=True)
            under = Signal(name=f"under_{part}", reset_less=True)
            t = getattr(total, part)
            m.d.sync += [v.eq(t), over.eq(t > hi), under.eq(t < lo)]
            m.d.sync += getattr(y, part).eq(Mux(over, hi, Mux(under, lo, v)))
            s_flag = Signal(name=f"sat_{part}", reset_less=True)
            m.d.sync += s_flag.eq(over | under)
            sat.append(s_flag)
        out_valid = accept
        for k in range(K):
            nv = Signal(name=f"out_valid{k + 1}")
            m.d.sync += nv.eq(out_valid)
            out_valid = nv
        m.d.comb += regs.overflow_set.eq(out_valid & (sat[0] | sat[1]))
        m.submodules.ofifo = fifo = OutputFIFO(2 * OUTPUT_WIDTH, F)      # room: the credit above
        m.d.comb += [fifo.w_en.eq(out_valid), fifo.w_data.eq(y.as_value()),
                     self.o.valid.eq(fifo.r_rdy), self.o.payload.eq(fifo.r_data),
                     fifo.r_en.eq(self.o.ready)]



def _share_bus(m, host, loader, regs_bus):
    """The register bus shared by the host (``host``, the block's port) and
    the follow loader (writes only): the loader's write is offered whenever
    it has one, the host's access otherwise; each sees ``ready`` only for its
    own, so either waits as for a busy bus. Read data go to the host."""
    mine = loader.w_stb
    m.d.comb += [regs_bus.addr.eq(Mux(mine, loader.addr, host.addr)),
                 regs_bus.w_data.eq(Mux(mine, loader.w_data, host.w_data)),
                 regs_bus.w_stb.eq(Mux(mine, 1, host.w_stb)), regs_bus.r_stb.eq(~mine & host.r_stb),
                 host.ready.eq(regs_bus.ready & ~mine), loader.ready.eq(regs_bus.ready & mine),
                 host.r_data.eq(regs_bus.r_data), host.r_valid.eq(regs_bus.r_valid)]
