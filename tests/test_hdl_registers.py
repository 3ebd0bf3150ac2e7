"""The register file's RAM view (rast.hdl.registers.RegisterFile.values)
against the values the host wrote, before and after a reset."""

import numpy as np
import pytest
from amaranth.hdl import Module, Signal, ResetInserter
from amaranth.sim import Simulator

from rast.hdl.registers import RegisterFile, SLOT_RAM_FIELDS
from rast.model.fixedpoint import ReplayContract, REGISTER_STAGING, take_interval
from rast.model.powerup import ChannelInit
from rast.model.regmap import register_map


@pytest.mark.parametrize("slots, channels", [(1, 2), (3, 5), (4, 6), (10, 13)])
def test_the_ram_view_shows_each_slots_written_values_and_after_a_reset_the_reset_values(slots, channels):
    rng = np.random.default_rng(slots)
    c = ReplayContract(channels=channels, slots=slots, pool_words=64, max_delay=5, max_tap=2,
                       interpolation="hold")
    inits = [ChannelInit(words=(1,) * int(rng.integers(1, 9)), phase_increment=int(rng.integers(1, 1 << 20)),
                         gain=int(rng.integers(1, 1 << 17)), base=int(rng.integers(0, 32)))
             for _ in range(channels)]
    rmap = register_map(c, inits)
    groups = [list(range(p * slots, min(channels, (p + 1) * slots))) for p in range(c.pipelines)]
    wd = REGISTER_STAGING
    dut = RegisterFile(rmap, groups=groups, slots=slots)
    rst = Signal()
    top = Module()
    top.submodules.dut = ResetInserter(rst)(dut)

    def reset_values():
        return {(ch, name): rmap.reg(reg, ch).field(field).reset
                for ch in range(channels) for name, (reg, field) in SLOT_RAM_FIELDS.items()}

    def random_value(ch, name):
        f = rmap.reg(SLOT_RAM_FIELDS[name][0], ch).field(SLOT_RAM_FIELDS[name][1])
        lo, hi = f.clamp or (0, (1 << f.width) - 1)
        return int(rng.integers(lo, hi + 1))

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
        expect = reset_values()
        seen, since_reset = await view(ctx, 0)
        # power-up is as after a reset: the view's slot counter at slots - 1
        assert seen == expect, "power-up: the view must show the reset values"
        for _ in range(3):
            for ch in rng.permutation(channels)[:max(1, channels // 2)]:
                name = str(rng.choice(list(SLOT_RAM_FIELDS)))
                v = random_value(int(ch), name)
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
        expect = reset_values()
        assert seen == expect, "after a reset the view must show the reset values, not the RAM's"
        assert written != expect
        ch, name = 0, "gain"
        v = random_value(ch, name)
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
    for groups in ([[0, 2], [1, 3]], [[1, 0], [2, 3]]):
        with pytest.raises(ValueError, match="consecutive channels"):
            RegisterFile(rmap, groups=groups, slots=2)
