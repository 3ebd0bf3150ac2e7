"""ArrivalCheck judged by what a cache read really saw, in the Amaranth
simulator: a word cache (a memory read in the clock of the read's address
register, as the pipeline's) is written with a fresh token by every fill,
and a checked read is late exactly when the word it read is not the token of
the latest fetch granted for its position by its visit (the clock before its
address register). The check's ``underflow`` must say so, LATENCY clocks
after each read, for random grants, fill latencies and reads, with reads
aimed at fills and grants in the read's own clock and the clock before (where
a check a clock off gets it wrong)."""

import gc
import random
import warnings

import pytest
from amaranth.hdl import Module
from amaranth.lib.memory import Memory
from amaranth.sim import Simulator

from rast.hdl.arrival_check import ArrivalCheck


@pytest.mark.parametrize("positions, reads, seed", [(16, 2, 1), (40, 1, 2), (256, 2, 3), (1, 1, 4)])
def test_underflow_says_which_reads_missed_their_word(positions, reads, seed):
    dut = ArrivalCheck(positions, reads)
    m = Module()
    m.submodules.dut = dut
    m.submodules.cache = cache = Memory(shape=16, depth=positions, init=[])
    wp = cache.write_port()
    m.d.comb += [wp.en.eq(dut.fill_en), wp.addr.eq(dut.fill_pos)]
    rps = [cache.read_port(domain="comb") for _ in range(reads)]
    for k, rp in enumerate(rps):
        m.d.comb += rp.addr.eq(dut.read_pos[k])
    sim = Simulator(m)
    sim.add_clock(1e-8)
    counts = {"late": 0, "on_time": 0, "fill_at_read": 0, "grant_before_read": 0}

    async def bench(ctx):
        rng = random.Random(seed)
        token = 0
        latest = {}          # position -> token of its latest grant (made in an earlier clock)
        outstanding = {}     # position -> token of a granted fetch not yet written
        fills_at = {}        # clock -> position written then
        granted_at = {}      # clock -> position granted then
        expect = {}          # clock -> underflow the reads of an earlier clock must give
        for now in range(6000):
            # this clock's grant, for a position with no fetch outstanding
            free = [p for p in range(positions) if p not in outstanding]
            grant = bool(free) and rng.random() < 0.3
            if grant:
                p = rng.choice(free)
                token += 1
                fill = now + rng.randint(1, 12)
                while fill in fills_at:
                    fill += 1
                outstanding[p], fills_at[fill], granted_at[now] = token, p, p
                ctx.set(dut.grant_pos, p)
            ctx.set(dut.grant, grant)
            fill_pos = fills_at.pop(now, None)
            ctx.set(dut.fill_en, fill_pos is not None)
            if fill_pos is not None:
                ctx.set(dut.fill_pos, fill_pos)
                ctx.set(wp.data, outstanding.pop(fill_pos))
            # this clock's reads, aimed at this clock's and the last clock's fill
            # and grant half of the time
            late_now = False
            for k, rp in enumerate(rps):
                aims = [x for x in (fill_pos, fills_at.get(now - 1), granted_at.get(now - 1), granted_at.get(now))
                        if x is not None]
                p = rng.choice(aims) if aims and rng.random() < 0.5 else rng.randrange(positions)
                matters = p in latest and rng.random() < 0.9
                ctx.set(dut.read_pos[k], p)
                ctx.set(dut.read_matters[k], matters)
                if matters:
                    late = ctx.get(rp.data) != latest[p]
                    late_now |= late
                    counts["late" if late else "on_time"] += 1
                    counts["fill_at_read"] += p == fill_pos
                    counts["grant_before_read"] += p == granted_at.get(now - 1)
            expect[now + dut.LATENCY] = late_now
            if now in expect:
                assert ctx.get(dut.underflow) == expect.pop(now), now
            if grant:
                latest[granted_at[now]] = token     # seen by reads from the next clock on
            await ctx.tick()

    sim.add_testbench(bench)
    sim.run()
    assert counts["late"] > 100 and counts["on_time"] > 100, counts
    if positions > 1:
        assert counts["fill_at_read"] > 50 and counts["grant_before_read"] > 50, counts


@pytest.mark.parametrize("positions, reads", [(0, 1), (4, 0), (True, 1), (4, 2.0)])
def test_bad_parameters_are_named(positions, reads):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")      # the refused one is never elaborated: UnusedElaboratable
        with pytest.raises(ValueError, match="positions" if positions in (0, True) else "reads"):
            ArrivalCheck(positions, reads)
        gc.collect()
