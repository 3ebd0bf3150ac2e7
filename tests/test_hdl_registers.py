"""The register file's RAM view (rast.hdl.registers.RegisterFile.values)
against the values the host wrote, before and after a reset."""

import gc
import warnings

import numpy as np
import pytest
from amaranth.hdl import Module, Signal, ResetInserter
from amaranth.sim import Simulator

from rast.hdl.registers import RegisterFile, SLOT_RAM_FIELDS
from rast.model.contract.fixedpoint import ReplayContract, REGISTER_STAGING, take_interval
from rast.model.contract.powerup import ChannelInit
from rast.model.contract.regmap import register_map


def _ram_view_dut(slots, inits):
    """The register file of ``len(inits)`` channels in pipelines of
    ``slots`` (as the engine groups them), under a reset of the test's own:
    (register map, groups, dut, top module, reset signal)."""
    channels = len(inits)
    c = ReplayContract(channels=channels, slots=slots, pool_words=64, max_delay=5, max_tap=2,
                       interpolation="hold")
    rmap = register_map(c, inits)
    groups = [list(range(p * slots, min(channels, (p + 1) * slots))) for p in range(c.pipelines)]
    dut = RegisterFile(rmap, groups=groups, slots=slots)
    rst = Signal()
    top = Module()
    top.submodules.dut = ResetInserter(rst)(dut)
    return rmap, groups, dut, top, rst


def _reset_values(rmap, channels):
    return {(ch, name): rmap.reg(reg, ch).field(field).reset
            for ch in range(channels) for name, (reg, field) in SLOT_RAM_FIELDS.items()}


def _random_value(rng, rmap, ch, name):
    """A value of the field ``name`` of channel ``ch`` inside its range."""
    f = rmap.reg(SLOT_RAM_FIELDS[name][0], ch).field(SLOT_RAM_FIELDS[name][1])
    lo, hi = f.clamp or (0, (1 << f.width) - 1)
    return int(rng.integers(lo, hi + 1))


@pytest.mark.parametrize("slots, channels", [(1, 2), (3, 5), (4, 6), (10, 13)])
def test_the_ram_view_shows_each_slots_written_values_and_after_a_reset_the_reset_values(slots, channels):
    rng = np.random.default_rng(slots)
    inits = [ChannelInit(words=(1,) * int(rng.integers(1, 9)), phase_increment=int(rng.integers(1, 1 << 20)),
                         gain=int(rng.integers(1, 1 << 17)), base=int(rng.integers(0, 32)))
             for _ in range(channels)]
    rmap, groups, dut, top, rst = _ram_view_dut(slots, inits)
    wd = REGISTER_STAGING

    async def write(ctx, addr, value):
        ctx.set(dut.bus.addr, addr)
        ctx.set(dut.bus.w_data, value)
        ctx.set(dut.bus.w_stb, 1)
        await ctx.tick()
        ctx.set(dut.bus.w_stb, 0)
        for _ in range(take_interval(slots) + wd):     # landed, and writes stay take_interval clocks apart
            await ctx.tick()

    async def view(ctx, since_reset):
        """Every slot's values over one round of the view's slot counter."""
        seen = {}
        for _ in range(slots):
            await ctx.tick()
            since_reset += 1
            s = (slots - 1 + since_reset - 1) % slots   # the slot read in the clock before
            for g, members in enumerate(groups):
                if s < len(members):
                    for name in SLOT_RAM_FIELDS:
                        seen[(members[s], name)] = ctx.get(dut.values[g][name])
                else:                                    # no channel: 0
                    assert all(ctx.get(dut.values[g][name]) == 0 for name in SLOT_RAM_FIELDS)
        return seen, since_reset

    async def bench(ctx):
        ctx.set(dut.take, 1)
        expect = _reset_values(rmap, channels)
        seen, since_reset = await view(ctx, 0)
        # power-up is as after a reset: the view's slot counter at slots - 1
        assert seen == expect, "power-up: the view must show the reset values"
        for _ in range(3):
            for ch in rng.permutation(channels)[:max(1, channels // 2)]:
                name = str(rng.choice(list(SLOT_RAM_FIELDS)))
                v = _random_value(rng, rmap, int(ch), name)
                await write(ctx, rmap.addr(SLOT_RAM_FIELDS[name][0], int(ch)), v)
                since_reset += 1 + take_interval(slots) + wd
                expect[(int(ch), name)] = v
            seen, since_reset = await view(ctx, since_reset)
            assert seen == expect, "the view must show the values written"
        written = dict(expect)
        ctx.set(rst, 1)
        await ctx.tick()
        ctx.set(rst, 0)
        seen, since_reset = await view(ctx, 0)
        expect = _reset_values(rmap, channels)
        assert seen == expect, "after a reset the view must show the reset values, not the RAM's"
        assert written != expect
        ch, name = 0, "gain"
        v = _random_value(rng, rmap, ch, name)
        await write(ctx, rmap.addr("GAIN", ch), v)
        since_reset += 1 + slots + wd
        expect[(ch, name)] = v
        seen, since_reset = await view(ctx, since_reset)
        assert seen == expect, "a write after the reset must show, the others keep their reset values"

    sim = Simulator(top)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()


def test_groups_that_are_not_runs_of_consecutive_channels_are_refused():
    c = ReplayContract(channels=4, slots=2, pool_words=64, max_delay=5, max_tap=2, interpolation="hold")
    rmap = register_map(c, [ChannelInit(words=(1,)) for _ in range(4)])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")      # never elaborated: UnusedElaboratable
        for groups in ([[0, 2], [1, 3]], [[1, 0], [2, 3]]):
            with pytest.raises(ValueError, match="consecutive channels"):
                RegisterFile(rmap, groups=groups, slots=2)
        gc.collect()


@pytest.mark.parametrize("slots, channels", [(3, 5), (10, 13)])
def test_the_ram_view_shows_a_write_from_the_same_clock_on_at_every_phase_of_its_slot_counter(slots, channels):
    """Clock by clock: the view in clock k shows a slot's value as a
    flip-flop register (CTRL.enable's) holds a write in clock k - 1,
    whichever slot the view's counter reads when the write lands (the first
    test checks the values only once the writes have settled)."""
    rng = np.random.default_rng(100 + slots)
    rmap, groups, dut, top, rst = _ram_view_dut(slots, [ChannelInit(words=(1, 2)) for _ in range(channels)])
    reset_of = _reset_values(rmap, channels)

    def write_at(ctx, k, when, addr, value):
        """Hold the write on the bus in clock ``when``; the clock number k of the tick to come."""
        if k == when:
            ctx.set(dut.bus.addr, addr)
            ctx.set(dut.bus.w_data, value)
        ctx.set(dut.bus.w_stb, k == when)

    async def bench(ctx):
        ctx.set(dut.take, 1)
        # the reference: CTRL.enable, in a flip-flop (``regs[l].enable``
        # shows it); the clock it shows a write taken in clock 1 from on
        ctrl = rmap.reg("CTRL", 0)
        assert ctx.get(dut.regs[0].enable) == ctrl.field("enable").reset
        shown = None
        for k in range(1, 4 * REGISTER_STAGING):
            write_at(ctx, k, 1, ctrl.addr, (1 - ctrl.field("enable").reset) << ctrl.field("enable").lsb)
            await ctx.tick()
            if shown is None and ctx.get(dut.regs[0].enable) != ctrl.field("enable").reset:
                shown = k
        assert shown is not None, "CTRL.enable must show the write"
        landed = shown - 1
        for phase in range(slots):
            taken = phase + 1
            for name, (reg_name, _) in SLOT_RAM_FIELDS.items():
                ch = int(rng.integers(channels))
                v = reset_of[(ch, name)]
                while v == reset_of[(ch, name)]:
                    v = _random_value(rng, rmap, ch, name)
                ctx.set(rst, 1)
                await ctx.tick()
                ctx.set(rst, 0)
                for k in range(1, taken + 4 * slots + landed + 1):
                    write_at(ctx, k, taken, rmap.addr(reg_name, ch), v)
                    await ctx.tick()
                    s = (slots - 1 + k - 1) % slots      # the slot the view read, its values of clock k - 1
                    for g, members in enumerate(groups):
                        if s >= len(members):
                            continue
                        for n in SLOT_RAM_FIELDS:
                            written = (members[s], n) == (ch, name) and k - 1 >= taken + landed
                            want = v if written else reset_of[(members[s], n)]
                            got = ctx.get(dut.values[g][n])
                            assert got == want, (f"phase {phase}, {name} of channel {ch} written at clock "
                                                 f"{taken}: clock {k}, channel {members[s]}'s {n} is {got}, "
                                                 f"not {want}")

    sim = Simulator(top)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
