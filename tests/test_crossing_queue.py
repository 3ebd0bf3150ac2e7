"""The SDRAM pool's crossings (CrossingQueue) in the Amaranth simulator:
every word across in order, takes from registers at most every other clock
or by a slow reader's handshake, the write side's level, an overfull write
flagged."""

import random

import pytest
from amaranth.hdl import ClockDomain, Module
from amaranth.sim import Simulator

from rast.hdl.crossing_queue import CrossingQueue


def run(depth, w_period_ns, r_period_ns, words, *, write_p=0.7, keep_room=True, reader="take"):
    """Random writes from domain ``w`` (only while ``w_rdy`` with
    ``keep_room``); returns the words written, the words taken with the
    read-side clock of each take, and the final ``overflow``. A ``"stream"``
    reader asks at random, half of its clocks."""
    dut = CrossingQueue(16, depth, w_domain="w", r_domain="sync", reader=reader)
    m = Module()
    m.submodules.q = dut
    m.domains.w = ClockDomain()
    m.domains.sync = ClockDomain()
    sim = Simulator(m)
    sim.add_clock(w_period_ns * 1e-9, domain="w")
    sim.add_clock(r_period_ns * 1e-9, domain="sync", phase=0.37 * r_period_ns * 1e-9)
    sent, got, overflow = [], [], []

    async def writer(ctx):
        rng = random.Random(depth * 1000 + w_period_ns)
        for _ in range(words):
            en = rng.random() < write_p and (ctx.get(dut.w_rdy) or not keep_room)
            value = rng.randrange(1 << 16)
            ctx.set(dut.w_en, en)
            ctx.set(dut.w_data, value)
            if en and ctx.get(dut.w_rdy):
                sent.append(value)
            await ctx.tick("w")
        ctx.set(dut.w_en, 0)
        await ctx.tick("w").repeat(20)
        overflow.append(ctx.get(dut.overflow))

    async def take_reader(ctx):
        clock = 0
        async for *_, take, data in ctx.tick("sync").sample(dut.r_take, dut.r_data):
            clock += 1
            if take:
                got.append((clock, data))

    async def stream_reader(ctx):
        rng = random.Random(depth)
        clock = 0
        while True:
            en = rng.random() < 0.5
            ctx.set(dut.r_en, en)
            if en and ctx.get(dut.r_rdy):
                got.append((clock, ctx.get(dut.r_data)))
            await ctx.tick("sync")
            clock += 1

    sim.add_testbench(writer)
    if reader == "take":
        sim.add_process(take_reader)
    else:
        sim.add_testbench(stream_reader, background=True)
    sim.run_until((words + 40) * w_period_ns * 1e-9)
    return sent, got, overflow[0]


@pytest.mark.parametrize("depth, w_ns, r_ns", [(2, 20, 5), (4, 20, 10), (32, 20, 5), (8, 10, 10)])
def test_every_word_across_in_order(depth, w_ns, r_ns):
    """Words written at random from a slower (or equal) clock all come out,
    in order, none twice; takes are at least two read clocks apart."""
    sent, got, overflow = run(depth, w_ns, r_ns, 600, write_p=0.45 if w_ns == r_ns else 0.7)
    assert len(sent) > 200
    assert [v for _, v in got] == sent
    assert all(b - a >= 2 for (a, _), (b, _) in zip(got, got[1:]))
    assert not overflow


@pytest.mark.parametrize("depth, w_ns, r_ns", [(4, 5, 20), (64, 5, 20), (8, 10, 10)])
def test_a_slow_stream_reader_gets_every_word_in_order(depth, w_ns, r_ns):
    """The command queue's shape: a fast writer keeping room by ``w_rdy``, a
    reader in a slower clock taking by ``r_rdy``/``r_en`` at random."""
    sent, got, overflow = run(depth, w_ns, r_ns, 800, write_p=0.1 if w_ns < r_ns else 0.3, reader="stream")
    assert len(sent) > 60
    assert [v for _, v in got] == sent
    assert not overflow


@pytest.mark.parametrize("depth", [2, 4, 16])
def test_a_queue_with_room_takes_every_write(depth):
    """One clock for both sides, writes at random while fewer than half the
    queue's words are in it (the pool's reservation does the same): through
    many pointer wraps ``w_rdy`` never drops, nothing overflows, every word
    comes out in order. ``w_level`` never counts fewer words than were in
    the queue a clock before, nor more than three taken since (its lag)."""
    dut = CrossingQueue(16, depth, w_domain="sync", r_domain="sync")
    sent, got, refused, levels = [], [], [], []

    async def bench(ctx):
        rng = random.Random(depth)
        before = 0
        for k in range(3000):
            level = ctx.get(dut.w_level)
            levels.append((before, level))
            before = len(sent) - len(got)
            if ctx.get(dut.r_take):
                got.append(ctx.get(dut.r_data))
            en = rng.random() < 0.6 and len(sent) - len(got) < max(1, depth // 2)
            if en and not ctx.get(dut.w_rdy):
                refused.append(k)
            ctx.set(dut.w_en, en)
            ctx.set(dut.w_data, k)
            if en:
                sent.append(k)
            await ctx.tick()
        ctx.set(dut.w_en, 0)
        for _ in range(4 * depth + 10):       # the queue drains a word every other clock
            if ctx.get(dut.r_take):
                got.append(ctx.get(dut.r_data))
            await ctx.tick()
        assert not ctx.get(dut.overflow)

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    assert len(sent) > 4 * 2 * depth and not refused
    assert got == sent
    assert all(true <= seen <= true + 3 for true, seen in levels)
    assert max(seen for _, seen in levels) >= depth // 2


def test_a_write_into_a_full_queue_is_flagged():
    """Writing on regardless of ``w_rdy`` while the reader drains at half the
    write clock's rate: the queue fills and ``overflow`` is set."""
    _, _, overflow = run(4, 10, 10, 200, write_p=1.0, keep_room=False)
    assert overflow


@pytest.mark.parametrize("args, msg", [
    ((0, 4), "Crossing queue width must be a positive integer, not 0"),
    ((8, 6), "Crossing queue depth must be a power of two of at least 2, not 6"),
    ((8, 1), "Crossing queue depth must be a power of two of at least 2, not 1"),
])
def test_parameters_are_checked(args, msg):
    with pytest.raises(ValueError, match=f"^{msg}$"):
        CrossingQueue(*args, w_domain="w")


def test_the_reader_kind_is_checked():
    with pytest.raises(ValueError, match="^Crossing queue reader must be 'take' or 'stream', not 'fast'$"):
        CrossingQueue(8, 4, w_domain="w", reader="fast")
