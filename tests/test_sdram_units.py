"""SDRAM back end, piece by piece: the generator's cache and init-sequence
reading, the init sequencer, the pool against a native-port model in the
Amaranth simulator, and every constructor's parameter checks."""

import math
import random
from fractions import Fraction
from pathlib import Path

import pytest
from amaranth.hdl import IOPort
from amaranth.sim import Simulator

from rast.gateware.sdram.core import LiteDRAMCore
from rast.gateware.sdram.generate import (InitOp, LiteDRAMGenError, generate_core,
                                          parse_init_sequence)
from rast.gateware.sdram.init import SDRAMInit, bios_sdram_init
from rast.hdl.sdram_pool import SDRAMStreamPool
from rast.sim.sdram_top import FractionalClock, fabric_clocks_per_sdram_clock


@pytest.fixture(scope="module")
def core():
    return generate_core(sim=False)


# ------------------------------------------------------------------ generator

def test_generated_core_description(core):
    """The ULX3S config: 32-bit port over 8 M words, CL 2, the DFII map of csr.csv,
    BIOS order precharge-all, MRS, precharge-all, 2 refreshes, MRS."""
    assert (core.port_addr_width, core.port_data_width, core.cl) == (23, 32, 2)
    assert core.csr["sdram_dfii_control"] == 0x800
    assert core.geometry == {"bankbits": 2, "rowbits": 13, "colbits": 9, "module": "MT48LC16M16"}
    cmd = core.csr["sdram_dfii_pi0_command"]
    addr = core.csr["sdram_dfii_pi0_address"]
    issued = [(o.data, prev.data) for prev, o in zip(core.init_ops, core.init_ops[1:])
              if o.kind == "write" and o.addr == cmd]
    assert [c for c, _ in issued] == [0b1011, 0b1111, 0b1011, 0b1101, 0b1101, 0b1111]
    mrs = [o.data for o in core.init_ops if o.kind == "write" and o.addr == addr]
    assert mrs[-1] == 0x20                # CL=2 (A6:4), burst length 1
    assert core.init_ops[3] == InitOp("wait", cdelay=20000, comment="Bring CKE high")
    ops = bios_sdram_init(core)
    assert ops[-2:] == (InitOp("write", 0x800, 1, comment="hand over to the controller"),
                        InitOp("write", 0x0, 1, comment="init done"))


def test_generator_cache(core, tmp_path):
    """Generated once per key: a second call reuses the folder; --sim is another key."""
    stamp = core.directory / "GENERATED_OK"
    before = stamp.stat().st_mtime_ns
    again = generate_core(sim=False)
    assert again.directory == core.directory and stamp.stat().st_mtime_ns == before
    assert generate_core(sim=True).directory != core.directory
    assert "litedram" in core.directory.parent.name and core.verilog_path.exists()


def test_init_sequence_parser_refuses_what_it_cannot_follow():
    header = ("#define DFII_COMMAND_CS 0x01\nstatic inline void init_sequence(void)\n{\n"
              "\tsdram_dfii_pi0_address_write(0x400);\n\tmystery(3);\n}\n")
    with pytest.raises(LiteDRAMGenError, match=r"cannot follow 'mystery\(3\);'"):
        parse_init_sequence(header, {"sdram_dfii_pi0_address": 0x80c})


# ------------------------------------------------------------------ init sequencer

def test_init_sequencer_runs_the_bios_sequence(core):
    """Every write reaches wb_ctrl in order with its address and data, each wait
    lasts its cdelay clocks, init_done rises after the last write."""
    ops = [o for o in bios_sdram_init(core)]
    ops = [InitOp("wait", cdelay=5) if o.kind == "wait" else o for o in ops]   # short waits
    dut = SDRAMInit(ops, cdelay_clocks=3)
    seen = []

    async def bench(ctx):
        cycle = 0
        last = 0
        while not ctx.get(dut.init_done):
            if ctx.get(dut.bus.cyc) and ctx.get(dut.bus.stb):
                assert ctx.get(dut.bus.we) and ctx.get(dut.bus.sel) == 0xF
                ctx.set(dut.bus.ack, 1)
                seen.append((cycle, ctx.get(dut.bus.adr) << 2, ctx.get(dut.bus.dat_w)))
                await ctx.tick()
                ctx.set(dut.bus.ack, 0)
                cycle += 1
                last = cycle
            await ctx.tick()
            cycle += 1
            assert cycle < 10_000
        assert cycle - last <= 3

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    writes = [(o.addr, o.data) for o in ops if o.kind == "write"]
    assert [(a, d) for _, a, d in seen] == writes
    # the write after each wait comes at least cdelay * cdelay_clocks later
    k = 0
    for i, o in enumerate(ops):
        if o.kind == "wait":
            assert seen[k][0] - seen[k - 1][0] >= 15
        else:
            k += 1


# ------------------------------------------------------------------ pool, native-port model

def _pool_bench(queue_depth, seed, n_ops):
    """The pool in one domain against an in-order native-port model with random
    ready and random read latency; asserts inside, returns the answers
    expected and the most clocks one fetch waited for ``r_ready``."""
    dut = SDRAMStreamPool(10, 4, queue_depth=queue_depth, sdram_domain="sync")
    rng = random.Random(seed)
    mem = {}
    expect = []          # ("d", tag, word) or ("rd", word)
    longest_wait = [0]

    async def port(ctx):
        """Native port: takes commands when a coin says so, answers reads in order."""
        sdram = {}
        pending = []     # (due cycle, word)
        cycle = 0
        wdata_due = None
        while True:
            ready = rng.random() < 0.6
            ctx.set(dut.native.cmd.ready, ready and wdata_due is None)
            wready = wdata_due is not None and rng.random() < 0.7
            ctx.set(dut.native.wdata.ready, wready)
            ans = pending and pending[0][0] <= cycle
            ctx.set(dut.native.rdata.valid, bool(ans))
            if ans:
                ctx.set(dut.native.rdata.payload, pending[0][1])
            _, _, cv, we, addr, wv, wd = await ctx.tick().sample(
                dut.native.cmd.valid, dut.native.cmd.payload.we, dut.native.cmd.payload.addr,
                dut.native.wdata.valid, dut.native.wdata.payload.data)
            # sample() gives the values at the edge; ready as set above
            if ans:
                pending.pop(0)
            if wdata_due is not None and wv and wready:
                sdram[wdata_due] = wd
                wdata_due = None
            elif cv and ready and wdata_due is None:
                if we:
                    wdata_due = addr
                else:
                    pending.append((cycle + rng.randint(2, 12), sdram.get(addr, 0)))
            cycle += 1

    async def engine(ctx):
        done = 0
        while done < n_ops:
            kind = rng.choice("ffffwr")
            addr = rng.randrange(64)
            if kind == "f":
                ctx.set(dut.r_valid, 1)
                ctx.set(dut.r_addr, addr)
                tag = rng.randrange(16)
                ctx.set(dut.r_tag, tag)
                wait = 0
                while True:             # a stream: the fetch stays until taken
                    _, _, rdy = await ctx.tick().sample(dut.r_ready)
                    if rdy:
                        break
                    wait += 1
                longest_wait[0] = max(longest_wait[0], wait)
                ctx.set(dut.r_valid, 0)
                expect.append(("d", tag, mem.get(addr, 0)))
                done += 1
            elif kind == "w":
                word = rng.getrandbits(32)
                ctx.set(dut.w_valid, 1)
                ctx.set(dut.w_addr, addr)
                ctx.set(dut.w_data, word)
                while True:
                    _, _, rdy = await ctx.tick().sample(dut.w_ready)
                    if rdy:
                        break
                ctx.set(dut.w_valid, 0)
                mem[addr] = word
                done += 1
            else:
                ctx.set(dut.rd_valid, 1)
                ctx.set(dut.rd_addr, addr)
                while True:
                    _, _, rdy = await ctx.tick().sample(dut.rd_ready)
                    if rdy:
                        break
                ctx.set(dut.rd_valid, 0)
                expect.append(("rd", mem.get(addr, 0)))
                done += 1

    async def monitor(ctx):
        got = 0
        async for _, _, dv, tag, word, hv, hword, lost in ctx.tick().sample(
                dut.d_valid, dut.d_tag, dut.d_data, dut.rd_data_valid, dut.rd_data, dut.lost):
            assert not lost
            assert not (dv and hv)
            if dv or hv:
                e = expect[got]
                assert (("d", tag, word) if dv else ("rd", hword)) == e, (got, e)
                got += 1

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_process(port)
    sim.add_process(monitor)
    sim.add_testbench(engine)
    sim.run_until(1e-8 * (n_ops * 40))
    return len(expect), longest_wait[0]


@pytest.mark.parametrize("queue_depth", [2, 16])
def test_pool_against_port_model(queue_depth):
    """In-order answers with their tags, host reads after writes see the new
    word, fetches held until taken. With room a fetch waits at most four
    clocks (a take in progress, a host access granted and taken, its own
    grant); at a queue depth of 2 it also waits for answers (reads
    outstanding full), longer than that."""
    answers, longest_wait = _pool_bench(queue_depth, seed=queue_depth, n_ops=400)
    assert answers > 150
    if queue_depth == 2:
        assert longest_wait > 4
    else:
        assert longest_wait <= 4


# ------------------------------------------------------------------ parameters

@pytest.mark.parametrize("args, exc, msg", [
    (dict(addr_width=0), TypeError, r"^Address width must be a positive integer, not 0$"),
    (dict(tag_width=True), TypeError, r"^Tag width must be a positive integer, not True$"),
    (dict(queue_depth=12), ValueError, r"^Queue depth must be a power of two of at least 2, not 12$"),
    (dict(queue_depth=1), ValueError, r"^Queue depth must be a power of two of at least 2, not 1$"),
    (dict(sdram_domain=""), TypeError, r"^SDRAM domain must be a domain name, not ''$"),
])
def test_pool_parameters(args, exc, msg):
    with pytest.raises(exc, match=msg):
        SDRAMStreamPool(**args)


def test_init_and_core_parameters(core):
    with pytest.raises(TypeError, match=r"^Init operations must be a non-empty sequence of InitOp, not \(\)$"):
        SDRAMInit([])
    with pytest.raises(TypeError, match=r"^Clocks per cdelay unit must be a positive integer, not 0$"):
        SDRAMInit(core.init_ops, cdelay_clocks=0)
    with pytest.raises(ValueError, match=r"^Init write must have a word-aligned"):
        SDRAMInit([InitOp("write", 2, 0)])
    with pytest.raises(TypeError, match=r"^LiteDRAM core must be a GeneratedCore, not 'x'$"):
        LiteDRAMCore("x")
    with pytest.raises(TypeError, match=r"^Data pads must be a 16-bit IOPort, not None$"):
        LiteDRAMCore(core)


def test_hardware_core_elaborates(core):
    """The hardware variant: an instance of litedram_core with the data pads raw."""
    from amaranth.back import rtlil
    dut = LiteDRAMCore(core, dq=IOPort(16, name="sdram_dq"))
    text = rtlil.convert(dut, name="sdram_hw")
    assert "litedram_core" in text and "sdram_dq" in text


# ------------------------------------------------------- the engine's contract

from rast.model.contract import fixedpoint as fx                        # noqa: E402
from rast.model.contract.fixedpoint import ReplayContract              # noqa: E402


@pytest.mark.parametrize("kwargs, msg", [
    (dict(pool="dram"), r"Pool must be one of bram, sdram, not 'dram'"),
    (dict(pool="sdram", pool_words=3 * 16384), r"Pool words of an SDRAM pool must be a power of two"),
    (dict(pool="sdram", pool_words=1 << 24), r"Pool words must be at most 8388608"),
    (dict(pool="bram", pool_words=1 << 23), r"Pool words must be at most 1048576"),
])
def test_contract_pool_parameters(kwargs, msg):
    with pytest.raises(ValueError, match=msg):
        ReplayContract(**kwargs)


SHAPES = [dict(channels=n, slots=m, interpolation=i, sample_rate_hz=sr)
          for n, m, i, sr in [(4, 1, "fir", 0), (5, 4, "fir", 0), (12, 4, "linear", 0), (64, 10, "fir", 20_000_000),
                              (64, 10, "linear", 20_000_000), (10, 10, "hold", 10_000_000), (255, 64, "linear", 0)]]


@pytest.mark.parametrize("shape", SHAPES, ids=lambda s: f"{s['channels']}ch-m{s['slots']}-{s['interpolation']}")
def test_sdram_contract_keeps_its_own_promises(shape):
    """What the SDRAM contract derives satisfies the conditions docs/sdram.md
    states, recomputed here from their parts: the fetch bound covers every
    word that can be ahead of a fetch plus the refreshes of that window; at
    the highest stream rate the channels ask no more than the pool's
    write-interleaved word rate, and a word asked at a release arrives before
    the consumer needs it; a refill covers every cache's fill queued ahead;
    and the SDRAM never allows more than block RAM."""
    b = ReplayContract(pool="bram", **shape)
    s = ReplayContract(pool="sdram", **shape)
    ratio = (s.clock_hz or fx.SDRAM_FABRIC_HZ) / fx.SDRAM_CLOCK_HZ
    ahead = fx.SDRAM_REQUEST_FIFO + 3 * fx.SDRAM_QUEUE_DEPTH + 1
    busy = fx.SDRAM_PATH_CLOCKS + ahead * fx.SDRAM_WORD_CLOCKS
    clocks = fx.sdram_fetch_clocks()
    refreshes = (clocks - busy) // fx.SDRAM_REFRESH_CLOCKS
    assert refreshes * fx.SDRAM_REFRESH_INTERVAL_CLOCKS >= clocks           # one per interval, and one more
    assert s.pool_fetch_cycles >= fx.POOL_FETCH_CYCLES + clocks * ratio
    per_word = 2 * fx.SDRAM_WORD_CLOCKS * ratio                            # fabric clocks
    highest_rate = s.max_phase_increment / 2 ** fx.PHASE_FRAC_BITS         # words per sample
    assert s.channels * highest_rate / s.slots <= 1 / per_word
    lead = fx.CACHE_FILL_WORDS - fx.cache_need_words(s.interpolation) - 1
    assert lead / highest_rate * s.slots >= s.pool_fetch_cycles + s.pipelines * s.slots
    assert s.refill_samples * s.slots >= s.pool_fetch_cycles + s.channels * (fx.CACHE_FILL_WORDS + 1) * per_word
    assert s.refill_samples > b.refill_samples and s.max_phase_increment <= b.max_phase_increment
    assert ReplayContract.from_dict(s.to_dict()) == s and s.to_dict()["pool"] == "sdram"


def test_sdram_bounds_follow_the_fabric_clock():
    """The bounds are in controller clocks: a fabric half as fast waits half as
    many fabric clocks (the engine's own path aside)."""
    fast = ReplayContract(channels=10, slots=10, sample_rate_hz=20_000_000, pool="sdram")
    slow = ReplayContract(channels=10, slots=10, sample_rate_hz=10_000_000, pool="sdram")
    assert (fast.pool_fetch_cycles - fx.POOL_FETCH_CYCLES) == 2 * (slow.pool_fetch_cycles - fx.POOL_FETCH_CYCLES)
    assert ReplayContract(channels=10, slots=10, pool="sdram").pool_fetch_cycles == fast.pool_fetch_cycles


def test_an_sdram_engine_has_no_power_up_streams():
    from rast.hdl.replay_top import WindFarmReplay
    from rast.model.contract.powerup import ChannelInit
    with pytest.raises(ValueError, match="an SDRAM pool powers up empty"):
        WindFarmReplay(2, pool="sdram", pool_words=4096, init=[ChannelInit(words=(1, 2, 3))])
    e = WindFarmReplay(2, pool="sdram", pool_words=4096)
    assert {"native", "pool_error"} <= set(e.signature.members.keys())
    assert "native" not in WindFarmReplay(2, pool_words=4096).signature.members.keys()


def test_a_reload_goes_beside_the_playing_streams_as_fast_as_the_pool_takes_it():
    """``rast cosim --reload-at``'s writes: the pool holds two copies, the
    reload's words go into its second half, RELOAD_GROUP writes at a time from
    the reload's sample on, spaced so that the pool keeps up, every word of
    every stream written again and every channel switched at once (disable,
    SWAP, enable)."""
    from rast.model.contract.regmap import CTRL_ENABLE, CTRL_SWAP, register_map
    from rast.sim.e2e import RELOAD_GROUP, prepare
    config = Path(__file__).resolve().parent.parent / "examples" / "two_windmills.toml"
    e = prepare(config, 0.05, slots=10, pool="sdram", reload_s=0.02)
    c = e.scenario.contract
    words = [list(s.words) for s in e.streams.streams]
    assert c.pool == "sdram" and c.pool_words >= 2 * sum(map(len, words))
    rmap = register_map(c)
    first = [r for r in e.scenario.job.regs if r[0] == 0]
    reload = [r for r in e.scenario.job.regs if r[0] != 0]
    at = round(0.02 * e.farm.sample_rate_hz)
    spacing = -(-RELOAD_GROUP * c.pool_word_cycles // c.slots)
    assert spacing * c.slots >= RELOAD_GROUP * 2 * fx.SDRAM_WORD_CLOCKS * 4      # 200 MHz / 50 MHz
    assert [r[0] for r in reload] == [at + k // RELOAD_GROUP * spacing for k in range(len(reload))]
    data = [v for _, a, v in reload if a == rmap.addr("STREAM_DATA")]
    assert data == [w for ws in words for w in ws]
    starts = [v for _, a, v in reload if a == rmap.addr("STREAM_ADDR")]
    assert len(starts) == len(words) and min(starts) >= c.pool_words // 2
    first_data = [v for _, a, v in first if a == rmap.addr("STREAM_DATA")]
    assert first_data == data                                   # the same streams, the second time
    for ch in range(len(words)):
        assert [r[2] for r in reload if r[1] == rmap.addr("CTRL", ch)] == [0, CTRL_SWAP, CTRL_ENABLE]


# ------------------------------------------------- the simulated controller clock

@pytest.mark.parametrize("ratio", [Fraction(4), Fraction(16, 5), Fraction(2), Fraction(5, 2), Fraction(3)],
                         ids=str)
def test_the_simulated_controller_clock_runs_at_its_ratio(ratio):
    """FractionalClock: over whole cycles of its pattern, exactly one period
    per ``ratio`` clocks; every half period is the fabric clocks of half a
    period rounded down or up (no gap longer than the board's clock allows);
    at 4 the pattern is bit 1 of a counter from 0 (the divider it replaces)."""
    dut = FractionalClock(ratio)
    clocks = 20 * ratio.numerator              # 20 whole cycles of the pattern
    seen = []

    async def bench(ctx):
        for _ in range(clocks + 1):
            seen.append(ctx.get(dut.clk))
            await ctx.tick()

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    toggles = [k for k in range(1, clocks + 1) if seen[k] != seen[k - 1]]
    rises = [k for k in toggles if seen[k]]
    assert len(rises) == clocks / ratio and len(toggles) == 2 * len(rises) and seen[-1] == seen[0] == 0
    half = ratio / 2
    runs = {b - a for a, b in zip(toggles, toggles[1:])}
    assert runs == {math.floor(half), math.ceil(half)}        # one value when half is whole
    if ratio == 4:
        assert seen == [(k >> 1) & 1 for k in range(clocks + 1)]


@pytest.mark.parametrize("ratio, exc, msg", [
    (Fraction(3, 2), ValueError, r"^Clock ratio must be at least 2 \(a clock a half period\), not 3/2$"),
    (1, ValueError, r"^Clock ratio must be at least 2 \(a clock a half period\), not 1$"),
    (4.0, TypeError, r"^Clock ratio must be a rational number, not 4\.0$"),
    (True, TypeError, r"^Clock ratio must be a rational number, not True$"),
])
def test_the_simulated_controller_clock_needs_two_clocks_a_period(ratio, exc, msg):
    with pytest.raises(exc, match=msg):
        FractionalClock(ratio)


def test_the_simulated_controller_runs_at_the_boards_ratio():
    """SDRAM_CLOCK_HZ against the contract's fabric clock: 4 at 200 MHz (and
    when the fabric is not stated), 16/5 at 160 MHz."""
    assert fabric_clocks_per_sdram_clock(0) == 4
    assert fabric_clocks_per_sdram_clock(200_000_000) == 4
    assert fabric_clocks_per_sdram_clock(160_000_000) == Fraction(16, 5)
