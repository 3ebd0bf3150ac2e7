"""The gateware units of channels that follow the beam in the Amaranth
simulator, against the rule (``rast.model.contract.follow``): the blade
phase at a step, the assigner's events."""

import gc
import random
import warnings

import numpy as np
import pytest
from amaranth.sim import Simulator
from amaranth.hdl import Elaboratable, Module

from rast.hdl.ecp5_primitives import RegisteredRAM
from rast.hdl.follow.assigner import BeamAssigner
from rast.hdl.follow.phase_at_step import PhaseAtStep
from rast.model.contract.follow import (FOLLOW_STEP_BITS, PHASE_CLOCKS, Follower, follow_occupancy,
                                        follow_pattern, follow_phase)
from rast.model.contract.scan import AZIMUTH_CODES, pattern_words
from rast.model.physics.antenna import AntennaScan


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
    assert PhaseAtStep.latency == PHASE_CLOCKS


# ------------------------------------------------------------------ the assigner


class _AssignerWithTable(Elaboratable):
    """The assigner reading its rows' azimuths from a block RAM with its
    output register (the turbine table's read)."""

    def __init__(self, az, rows, channels):
        self.dut = BeamAssigner(rows=rows, channels=channels)
        self.table = RegisteredRAM(16, max(2, rows), init=[int(a) for a in az] + [0] * (rows - len(az)),
                                   continuous=True)
        assert self.table.latency == BeamAssigner.READ_LATENCY

    def elaborate(self, platform):
        m = Module()
        m.submodules.dut, m.submodules.table = self.dut, self.table
        m.d.comb += [self.table.r_addr.eq(self.dut.az_addr), self.dut.az_data.eq(self.table.r_data)]
        return m


def _window():
    scan = AntennaScan("free", 12.5, 0.0, 4096, 1.4, -70.0, None, -60.0)
    return follow_pattern(scan, pattern_words(scan))


def _run_assigner(az, guard, channels, beam0, beams, *, rows=None, hold=1, ready_p=1.0, seed=0):
    """Start at ``beam0``, then hold each of ``beams`` for ``hold`` clocks
    (``hold=None``: until the assigner is quiet); events as tuples."""
    window = _window()
    rows = rows or len(az)
    top = _AssignerWithTable(az, rows, channels)
    dut = top.dut
    rng = random.Random(seed)
    events = []

    async def bench(ctx):
        ctx.set(dut.settings.rows, len(az))
        ctx.set(dut.settings.entry_off, (window.lo - guard) % AZIMUTH_CODES)
        ctx.set(dut.settings.exit_off, (window.hi + 1) % AZIMUTH_CODES)
        ctx.set(dut.settings.width, window.hi + 1 - window.lo + guard)
        ctx.set(dut.settings.guard, guard)
        ctx.set(dut.beam, beam0)
        ctx.set(dut.start, 1)
        await ctx.tick()
        ctx.set(dut.start, 0)

        async def clock():
            ready = rng.random() < ready_p
            ctx.set(dut.event.ready, ready)
            await ctx.tick()
            # the transfer of the clock just ticked: sampled before the edge
            return ready

        async def settle():
            quiet = 0               # a pass is never more than 7 clocks between events
            while quiet < 10 or ctx.get(dut.seeding):
                valid = ctx.get(dut.event.valid)
                p = ctx.get(dut.event.payload)
                took = await clock()
                if valid and took:
                    events.append((int(p.enter), int(p.row), int(p.channel), int(p.late)))
                quiet = 0 if valid else quiet + 1

        await settle()
        for b in beams:
            ctx.set(dut.beam, b)
            if hold is None:
                await settle()
            else:
                for _ in range(hold):
                    valid = ctx.get(dut.event.valid)
                    p = ctx.get(dut.event.payload)
                    took = await clock()
                    if valid and took:
                        events.append((int(p.enter), int(p.row), int(p.channel), int(p.late)))
        await settle()
        assert not ctx.get(dut.overrun)

    simulate(top, bench)
    return events


def _model_events(az, guard, channels, beam0, beams):
    follower = Follower(az, _window(), guard, channels)
    out = follower.start(beam0)
    for b in beams:
        out += follower.move(b)
    return [(int(e.kind == "enter"), e.row, e.channel, int(e.late)) for e in out]


def _scene(seed, n):
    rng = np.random.default_rng(seed)
    return np.sort(np.concatenate([rng.integers(0, AZIMUTH_CODES, n - 12), np.full(6, 65534), np.full(6, 700)]))


@pytest.mark.parametrize("step,ready_p", [(13, 1.0), (16, 0.6), (3000, 0.8)])
def test_the_assigner_makes_the_models_events_beam_by_beam(step, ready_p):
    """Each beam held until the assigner is quiet: the events, their order,
    channels and late flags are the model's. Steps of 13 and 16 codes lie
    within the guard (never late); steps of 3000 jump past it (late)."""
    az = _scene(step, 60)
    guard = 18
    channels = follow_occupancy(az, _window(), guard).channels
    beam0 = 60000
    beams = [(beam0 + step * (k + 1)) % AZIMUTH_CODES for k in range(AZIMUTH_CODES // step + 3)]
    if step > 100:
        beams = beams[:30]
    got = _run_assigner(az, guard, max(channels, 4 if step > 100 else 1), beam0, beams, hold=None,
                        ready_p=ready_p, seed=step)
    want = _model_events(az, guard, max(channels, 4 if step > 100 else 1), beam0, beams)
    assert got == want
    assert sum(e[0] for e in want) >= len(az)                # every row entered
    assert any(e[3] for e in want) == (step > guard)


def test_the_assigner_keeps_up_with_a_beam_that_moves_every_clock():
    """The beam a code a clock, with stalls on the events: the passes take
    whatever beam they find, and the events (without the late flags, which
    depend on it) are the model's for the whole path."""
    az = _scene(9, 40)
    guard = 18
    channels = follow_occupancy(az, _window(), guard).channels
    beam0 = 100
    beams = [(beam0 + k + 1) % AZIMUTH_CODES for k in range(8000)]
    got = _run_assigner(az, guard, channels, beam0, beams, hold=1, ready_p=0.7, seed=3)
    want = _model_events(az, guard, channels, beam0, beams)
    assert [e[:3] for e in got] == [e[:3] for e in want] and len(want) > 10


def test_the_assigner_with_fewer_rows_than_its_table():
    az = _scene(4, 20)
    guard = 5
    channels = follow_occupancy(az, _window(), guard).channels
    beams = [(30000 + 50 * k) % AZIMUTH_CODES for k in range(1400)]
    got = _run_assigner(az, guard, channels, 30000, beams, rows=64, hold=None)
    assert got == _model_events(az, guard, channels, 30000, beams)


def test_an_entry_that_finds_every_channel_held_is_flagged():
    az = _scene(4, 20)                   # twelve rows in two clusters 738 codes apart
    guard = 5
    channels = follow_occupancy(az, _window(), guard).channels - 1
    beams = [(30000 + 50 * k) % AZIMUTH_CODES for k in range(1400)]
    with pytest.raises(ValueError, match="finds no free channel"):
        _model_events(az, guard, channels, 30000, beams)
    with pytest.raises(AssertionError, match="overrun"):
        _run_assigner(az, guard, channels, 30000, beams, hold=None)


@pytest.mark.parametrize("bad", [0, -1, 2.0, True])
def test_the_assigner_names_its_parameters(bad):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")      # the refused one is never elaborated: UnusedElaboratable
        with pytest.raises(ValueError, match="rows must be a positive integer"):
            BeamAssigner(rows=bad, channels=4)
        with pytest.raises(ValueError, match="channels must be a positive integer"):
            BeamAssigner(rows=4, channels=bad)
        gc.collect()


def test_the_assigner_frees_a_channel_before_it_gives_it_again_at_one_code():
    """Rows W codes apart: one's entry code is the other's exit code; with
    the channels the scene needs, the exit must come first."""
    window, guard = _window(), 9
    width = window.hi + 1 - window.lo + guard
    az = np.array([5000 + k * width for k in range(8)] + [40000, 40000 + width, 40000 + 2 * width])
    channels = follow_occupancy(az, window, guard).channels
    assert channels == 1
    beams = [(4000 + 11 * k) % AZIMUTH_CODES for k in range(1, 6050)]
    got = _run_assigner(az, guard, channels, 4000, beams, hold=None)
    assert got == _model_events(az, guard, channels, 4000, beams) and len(got) >= 2 * len(az)
