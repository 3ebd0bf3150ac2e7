"""RegisteredFIFO against Amaranth's SyncFIFOBuffered of one word more, clock
for clock, in the Amaranth simulator: the same ready flags, the same words
out and the same level, under random writes and reads that fill and empty
it (its level read from its thermometer code, which must be one)."""

import random

import pytest
from amaranth.hdl import Module
from amaranth.lib.fifo import SyncFIFOBuffered
from amaranth.sim import Simulator

from rast.hdl.registered_fifo import RegisteredFIFO


@pytest.mark.parametrize("depth, write_p, read_p", [(2, 0.5, 0.5), (4, 0.8, 0.3), (15, 0.6, 0.6), (16, 0.3, 0.9),
                                                    (15, 0.9, 0.2), (5, 0.5, 0.5)])
def test_the_fifo_behaves_as_sync_fifo_buffered(depth, write_p, read_p):
    dut, ref = RegisteredFIFO(12, depth), SyncFIFOBuffered(width=12, depth=depth + 1)
    m = Module()
    m.submodules.dut, m.submodules.ref = dut, ref
    sim = Simulator(m)
    sim.add_clock(1e-8)
    seen = {"full": 0, "empty": 0, "taken": 0}

    async def bench(ctx):
        rng = random.Random(depth * 100 + int(10 * write_p))
        for clock in range(3000):
            # phases that fill it and empty it, between random traffic
            phase = (clock // 300) % 3
            w = rng.random() < (0.95 if phase == 1 else 0.05 if phase == 2 else write_p)
            r = rng.random() < (0.05 if phase == 1 else 0.95 if phase == 2 else read_p)
            value = rng.randrange(1 << 12)
            for q in (dut, ref):
                ctx.set(q.w_en, w)
                ctx.set(q.w_data, value)
                ctx.set(q.r_en, r)
            fill = [ctx.get(dut.fill) >> k & 1 for k in range(depth + 1)]
            got = {"w_rdy": ctx.get(dut.w_rdy), "r_rdy": ctx.get(dut.r_rdy), "level": sum(fill)}
            want = {k: ctx.get(getattr(ref, k)) for k in ("w_rdy", "r_rdy", "level")}
            assert got == want, (clock, got, want)
            assert fill == [int(got["level"] > k) for k in range(depth + 1)]
            if got["r_rdy"]:
                assert ctx.get(dut.r_data) == ctx.get(ref.r_data), clock
                seen["taken"] += r
            seen["full"] += not got["w_rdy"]
            seen["empty"] += got["level"] == 0
            await ctx.tick()

    sim.add_testbench(bench)
    sim.run()
    assert seen["full"] > 10 and seen["empty"] > 10 and seen["taken"] > 300, seen


@pytest.mark.parametrize("width, depth", [(0, 4), (8, 1), (8, 2.0), (8, True)])
def test_bad_parameters_are_named(width, depth):
    with pytest.raises(ValueError, match="width" if width == 0 else "depth"):
        RegisteredFIFO(width, depth)
