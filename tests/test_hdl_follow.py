"""The gateware units of channels that follow the beam in the Amaranth
simulator, against the rule (``rast.model.contract.follow``): the blade
phase at a step, the assigner's events."""

import random

import pytest
from amaranth.sim import Simulator

from rast.hdl.follow.phase_at_step import PhaseAtStep
from rast.model.contract.follow import FOLLOW_LOAD_CLOCKS, FOLLOW_STEP_BITS, follow_phase


def simulate(dut, bench):
    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()


def test_the_phase_at_a_step_is_the_rules_clock_for_clock():
    rng = random.Random(5)
    top = (1 << FOLLOW_STEP_BITS) - 1
    cases = [(0, 12345, 100), (1, (1 << 32) - 1, 1), (top, (1 << 32) - 1, 1), (top, (1 << 32) - 1, (1 << 24) - 1),
             (top, 1, (1 << 24) - 1), (123456789, 0, 4096)]
    cases += [(rng.randrange(1 << FOLLOW_STEP_BITS), rng.randrange(1 << 32), rng.randrange(1, 1 << 24))
              for _ in range(12)]
    cases += [(rng.randrange(1 << 20), rng.randrange(1 << 32), rng.randrange(1, 40)) for _ in range(6)]
    dut = PhaseAtStep()
    results = []

    async def bench(ctx):
        for step, inc, length in cases:
            ctx.set(dut.step, step)
            ctx.set(dut.inc, inc)
            ctx.set(dut.length, length)
            ctx.set(dut.start, 1)
            await ctx.tick()
            ctx.set(dut.start, 0)
            ctx.set(dut.step, 0)                     # taken at the start: later inputs change nothing
            ctx.set(dut.inc, 0)
            clocks = 0
            while True:
                await ctx.tick()
                clocks += 1
                assert ctx.get(dut.busy) or ctx.get(dut.done)
                if ctx.get(dut.done):
                    break
                assert clocks < 1000
            results.append((ctx.get(dut.phase), clocks))

    simulate(dut, bench)
    for (step, inc, length), (phase, clocks) in zip(cases, results):
        assert phase == follow_phase(step, inc, length), (step, inc, length)
        assert clocks == PhaseAtStep.latency
    assert PhaseAtStep.latency + 8 <= FOLLOW_LOAD_CLOCKS
