"""WindFarmReplay in the Amaranth simulator against the bit-exact model."""

import copy
import itertools
import warnings

import numpy as np
import pytest
from amaranth.hdl import Module, Signal, ResetInserter
from amaranth.sim import Simulator

from rast.hdl.replay_top import WindFarmReplay
from rast.model.contract.datapath import ReplayModel
from rast.model.contract.fixedpoint import (pack_iq, unpack_iq, ReplayContract, take_interval, TAKE_SPACING,
                                            WRITE_STAGING)
from rast.model.contract.regmap import (register_map, stream_crc32, ID_VALUE, CTRL_ENABLE, CTRL_SWAP,
                                        CTRL_BANK, CTRL_REJECTED)
from rast.model.contract.loadplan import manifest_to_register_writes, manifest_channel_inits
from rast.model.contract.powerup import ChannelInit

from hdl_harness import run_replay, model_replay, assert_same, assert_reads

# Hold: the tests below check exact words and echo positions (FIR: test_hdl_fir.py).
KW = dict(pool_words=256, max_delay=20, max_tap=6, interpolation="hold")


def rand_inits(rng, n, depth=16, enable=True):
    """Random streams of up to ``depth`` words, one after the other in the pool."""
    out, base = [], 0
    for l in range(n):
        length = int(rng.integers(1, depth + 1))
        words = pack_iq(rng.integers(-32768, 32768, length), rng.integers(-32768, 32768, length))
        out.append(ChannelInit(tuple(int(w) for w in words), int(rng.integers(0, 1 << 32)),
                               int(rng.integers(0, 1 << 17)), int(rng.integers(0, 7)), enable, base))
        base += length
    return out


def access_steps(slots):
    """Steps one register access may take at most: the bus is taken once in
    take_interval(M) clocks (8 steps at M = 1)."""
    return take_interval(slots) // slots


def check(dut, inits, xi, xq, ops=(), valid=(1,), ready=(1,), name="replay", hold=False):
    hi, hq, done = run_replay(dut, xi, xq, ops, valid, ready, hold=hold)
    mi, mq, reads, model = model_replay(dut.contract, inits, xi, xq, done, dut.init_common_delay)
    assert_same(name, xi, xq, hi, hq, mi, mq)
    assert_reads(name, reads)
    return hi, hq, done, model


def test_top_parameters():
    with pytest.raises(ValueError, match=r"^Channel count must be a positive integer, not 0$"):
        WindFarmReplay(0)
    with pytest.raises(ValueError, match=r"^Initial contents must be given for at most 1 channels, not 2$"):
        WindFarmReplay(1, init=[ChannelInit(), ChannelInit()])
    with pytest.raises(TypeError, match=r"^Initial contents of channel 0 must be a ChannelInit, not 3$"):
        WindFarmReplay(1, init=[3])
    with pytest.raises(ValueError, match=r"^Slots per pipeline must be a positive integer, not 0$"):
        WindFarmReplay(1, slots=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")      # never elaborated: UnusedElaboratable
        # in samples, only the two delay lines' lags: the pipeline's clocks are
        # not seen in the step count
        assert WindFarmReplay(16).latency == 2
        assert WindFarmReplay(64, slots=10, cmult_form="3mult").latency == 2
        # in clocks: the accept's two registers, the last slot, its visit, word
        # (7), product (5; 6 in the 3-multiplier form), gain (5), slot sum, tree
        # (log2 P levels of 2, from three levels one more), saturation (2)
        assert WindFarmReplay(64, slots=10).contract.output_cycles == 2 + 9 + 2 + 7 + 5 + 5 + 1 + 7 + 2
        assert WindFarmReplay(5, cmult_form="3mult").contract.output_cycles == 2 + 0 + 1 + 7 + 6 + 5 + 1 + 7 + 2
        assert WindFarmReplay(4).contract.output_cycles == 2 + 0 + 1 + 7 + 5 + 5 + 1 + 4 + 2
    with pytest.raises(ValueError, match=r"^Initial common delay must be an integer in \[0, 4094\], not 4095$"):
        WindFarmReplay(2, init_common_delay=4095)


def test_window_data_lag_is_checked():
    """The top may take only the registers c[n] passes on its way to the
    window's write (none at M = 2, where the window is written straight
    from ``win_data``)."""
    from rast.hdl.channel_pipeline import ChannelPipeline, SlotInit
    from rast.hdl.registers import channel_regs_layout, slot_values_layout
    for slots, lag in ((2, 1), (10, ChannelPipeline.win_data_room(10) + 1)):
        dut = WindFarmReplay(slots, slots=slots)
        layouts = channel_regs_layout(dut.register_map), slot_values_layout(dut.register_map)
        inits = [SlotInit()] * slots
        with pytest.raises(ValueError, match=rf"^Window data lag must be an integer in \[0, {lag - 1}\] "
                                             rf"at {slots} slots, not {lag}$"):
            ChannelPipeline(dut.contract, 0, inits, *layouts, win_data_lag=lag)


STALLS = [((1,), (1,)), ((1, 1, 0), (1, 0, 1, 1)), ((0, 1, 0, 0, 1), (1,)), ((1,), (0, 1))]


@pytest.mark.parametrize("valid, ready", STALLS)
@pytest.mark.parametrize("channels, opts", [(1, {}), (3, {}), (2, dict(interpolation="linear")),
                                            (2, dict(interpolation="fir")), (2, dict(cmult_form="3mult")),
                                            (3, dict(slots=3)), (4, dict(slots=3)), (5, dict(slots=2)),
                                            (3, dict(slots=2, interpolation="linear")),
                                            (4, dict(slots=3, interpolation="fir")),
                                            # more than REQUEST_GROUP pipelines: the fetch requests ORed in two levels
                                            (6, {}), (9, dict(slots=2, interpolation="fir"))])
def test_random_against_model(channels, opts, valid, ready):
    rng = np.random.default_rng(channels * 100 + len(valid) * 10 + len(ready) + len(opts))
    inits = rand_inits(rng, channels)
    dut = WindFarmReplay(channels, init=inits, **{**KW, **opts})
    T = 300
    xi, xq = rng.integers(-32768, 32768, T), rng.integers(-32768, 32768, T)
    check(dut, inits, xi, xq, valid=valid, ready=ready, name=f"N={channels} {opts} {valid} {ready}")


@pytest.mark.slow
@pytest.mark.parametrize("slots", [1, 2, 3, 8, 10])
def test_an_output_held_back_fills_the_fifo_and_loses_no_sample(slots):
    """``o.ready`` one clock in 100: slower than the input at every M and rarer than
    the pipeline's latency, so the output FIFO fills and ``i.ready`` must hold the
    input back exactly while every place is taken (a sample too many finds the
    FIFO full and is dropped: one output fewer)."""
    rng = np.random.default_rng(slots)
    inits = rand_inits(rng, slots + 1)
    dut = WindFarmReplay(slots + 1, init=inits, slots=slots, **{k: v for k, v in KW.items()})
    T = 60
    xi, xq = rng.integers(-32768, 32768, T), rng.integers(-32768, 32768, T)
    hi, hq, done = run_replay(dut, xi, xq, ready=(1,) + (0,) * 99, max_cycles=T * 100 + 2000)
    mi, mq, _, _ = model_replay(dut.contract, inits, xi, xq, done, dut.init_common_delay)
    assert_same(f"M={slots}, output held back", xi, xq, hi, hq, mi, mq)


@pytest.mark.parametrize("slots", [1, 2, 3, 8, 10])
def test_an_input_every_period_is_taken_every_period(slots):
    """The board's ADC gives a sample every period and does not wait: with
    ``o.ready`` always high the block must take one input in every period,
    from the first period after its pipeline has filled (``i.ready`` high in
    every period's accepting clock, never refusing for want of FIFO room)."""
    dut = WindFarmReplay(slots + 1, slots=slots, **KW)
    periods = 4 * (dut.contract.output_cycles // slots + 4)
    taken_in = []

    async def bench(ctx):
        ctx.set(dut.i.valid, 1)
        ctx.set(dut.o.ready, 1)
        for clock in range(periods * slots):
            if ctx.get(dut.i.ready):
                taken_in.append(clock // slots if slots > 1 else clock)
            await ctx.tick()

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    # every period but the first (the clock of reset), once each
    assert taken_in[-periods // 2:] == list(range(periods - periods // 2, periods)), \
        f"M={slots}: periods with an input taken: {taken_in}"
    assert len(taken_in) >= periods - 2, f"M={slots}: {len(taken_in)} inputs in {periods} periods"


@pytest.mark.parametrize("slots", [1, 3])
def test_gaps_do_not_change_output(slots):
    rng = np.random.default_rng(11)
    inits = rand_inits(rng, 2)
    T = 200
    xi, xq = rng.integers(-32768, 32768, T), rng.integers(-32768, 32768, T)
    runs = []
    for valid, ready in STALLS:
        dut = WindFarmReplay(2, slots=slots, init=inits, **KW)
        hi, hq, _ = run_replay(dut, xi, xq, (), valid, ready)
        runs.append((hi, hq))
    for hi, hq in runs[1:]:
        assert (hi == runs[0][0]).all() and (hq == runs[0][1]).all()


@pytest.mark.parametrize("slots", [1, 4, 10])
@pytest.mark.parametrize("register", ["COMMON_DELAY", "DELAY"])
def test_every_delay_echo_position(register, slots):
    """Impulse through channel 2, every value 0..max of COMMON_DELAY (tap 3) or
    of its DELAY (common delay 2): the echo is at exactly L + COMMON_DELAY +
    DELAY (checked directly, and against the model)."""
    N, channel = 3, 2
    maxd = KW["max_delay"] if register == "COMMON_DELAY" else KW["max_tap"]
    word = int(pack_iq([16384], [0])[0])
    inits = [ChannelInit((word,), 0, 1 << 16, 3 if register == "COMMON_DELAY" else 0, l == channel)
             for l in range(N)]
    common = 2 if register == "DELAY" else 0
    dut = WindFarmReplay(N, slots=slots, init=inits, init_common_delay=common, **KW)
    rmap = dut.register_map
    L = dut.latency
    base_sum = common + inits[channel].delay
    lead = 1 + 3 * access_steps(slots)     # steps the two writes take at most (valid gaps)
    per = lead + L + KW["max_delay"] + KW["max_tap"] + 4
    settle = dut.contract.refill_samples          # muted after reset while the caches fill
    T = settle + per * (maxd + 1)
    xi = np.zeros(T, dtype=np.int64); xq = np.zeros(T, dtype=np.int64)
    ops = []
    for d in range(maxd + 1):
        start = settle + d * per
        xi[start + lead] = 20000
        ops += [(start, "w", rmap.addr(register, None if register == "COMMON_DELAY" else channel), d),
                (start, "w", rmap.addr("APPLY"), 1)]
    hi, hq, done, _ = check(dut, inits, xi, xq, ops, valid=(1, 0, 1), name="delays")
    assert all(k <= settle + d * per + lead for d in range(maxd + 1) for k, _, _, _ in done[2 * d:2 * d + 2]), \
        "the writes must take effect before their impulse"
    for d in range(maxd + 1):
        seg = hi[settle + d * per + lead: settle + (d + 1) * per + lead]
        hit = np.nonzero(seg)[0]
        assert hit.tolist() == [L + base_sum + d], f"delay {d}: echo at {hit.tolist()}, expected {L + base_sum + d}"
        assert seg[hit[0]] == 10000


@pytest.mark.parametrize("slots", [1, 2])
def test_full_scale_in_phase_saturates_and_flags_overflow(slots):
    N = 4
    word = int(pack_iq([-32768], [-32768])[0])
    inits = [ChannelInit((word,), 0, (1 << 17) - 1, 0, True) for _ in range(N)]
    dut = WindFarmReplay(N, slots=slots, init=inits, **KW)
    rmap = dut.register_map
    L = dut.latency
    R = dut.contract.refill_samples               # muted after reset while the caches fill
    T = R + 3 * L + 40
    xi = np.zeros(T, dtype=np.int64); xq = np.zeros(T, dtype=np.int64)
    xi[R:R + 5] = -32768; xq[R:R + 5] = -32768        # full-scale burst
    st = rmap.addr("STATUS")
    ops = [(R + 2, "r", st, 0), (R + L + 3, "r", st, 0), (R + L + 3, "r", st, 0),
           (R + L + 20, "r", st, 0), (R + L + 22, "r", st, 0)]
    hi, hq, done, model = check(dut, inits, xi, xq, ops, valid=(1, 1, 0), name="full scale", hold=True)
    # (-1-1j)*(-1-1j) = 2j: Q saturates high, I is 0
    assert hq.max() == 32767 and (hq == 32767).sum() >= 4
    reads = [v for k, kind, a, v in done if kind == "r"]
    assert reads[0] == 0 and reads[1] == 1, reads          # set, then cleared by the read
    assert reads[-1] == 0


@pytest.mark.parametrize("slots", [1, 2, 3])
def test_register_writes_mid_stream(slots):
    rng = np.random.default_rng(21)
    N = 3
    inits = rand_inits(rng, N)
    dut = WindFarmReplay(N, slots=slots, init=inits, **KW)
    rmap = dut.register_map
    T = 600
    xi, xq = rng.integers(-32768, 32768, T), rng.integers(-32768, 32768, T)
    ops = []
    for k in sorted(rng.integers(0, T, 60).tolist()):
        l = int(rng.integers(0, N))
        what = rng.integers(0, 6)
        if what == 0:
            ops.append((k, "w", rmap.addr("GAIN", l), int(rng.integers(0, 1 << 17))))
        elif what == 1:
            ops.append((k, "w", rmap.addr("CTRL", l), int(rng.integers(0, 2))))
        elif what == 2:
            ops.append((k, "w", rmap.addr("DELAY", l), int(rng.integers(0, 40))))   # clamped
        elif what == 3:
            ops.append((k, "w", rmap.addr("APPLY"), 1))
        elif what == 4:
            ops.append((k, "r", rmap.addr(str(rng.choice(["GAIN", "DELAY", "CTRL", "LENGTH"])), l), 0))
        else:
            ops.append((k, "r", rmap.addr("STATUS"), 0))
    check(dut, inits, xi, xq, ops, valid=(1, 1, 0, 1), ready=(1, 1, 1, 0), name="mid-stream writes")


@pytest.mark.parametrize("slots", [1, 2, 3, 10])
def test_a_read_right_after_a_write_returns_the_value_written(slots):
    """Each per-channel field kept in the register file's RAMs, written and
    read back in the next access (from M = 2 the read-back reads the RAM one
    or two clocks before it samples the other registers)."""
    rng = np.random.default_rng(30 + slots)
    N = slots + 1
    inits = rand_inits(rng, N)
    dut = WindFarmReplay(N, slots=slots, init=inits, **KW)
    a = dut.register_map.addr
    values = {"GAIN": (0, 1 << 17), "LENGTH": (1, 64), "PHASE_INC": (0, 1 << 32), "BASE": (0, 256)}
    ops = []
    for k in range(5, 200, 7):
        l = int(rng.integers(0, N))
        name = str(rng.choice(list(values)))
        ops += [(k, "w", a(name, l), int(rng.integers(*values[name]))), (k, "r", a(name, l), 0)]
    xi, xq = rng.integers(-32768, 32768, 240), rng.integers(-32768, 32768, 240)
    _, _, done, _ = check(dut, inits, xi, xq, ops, name=f"write then read, M = {slots}")
    # besides the model: the unclamped fields read back as written
    pairs = list(zip(done[::2], done[1::2]))
    assert len(pairs) == len(ops) // 2
    for (_, w, wa, wv), (_, r, ra, rv) in pairs:
        assert (w, r, wa) == ("w", "r", ra)
        if wa in [a(name, l) for name in ("GAIN", "BASE") for l in range(N)]:
            assert rv == wv, f"register {wa:#x}: wrote {wv:#x}, read {rv:#x}"


@pytest.mark.parametrize("slots, l", [(1, 0), (2, 1), (3, 2), (2, 0), (3, 0)])
def test_a_read_sees_the_switches_of_the_steps_before_it_and_none_after(slots, l):
    """CTRL.swap and CTRL.bank read back as the model has them between the
    same two steps, also when a switch (a pending SWAP completing at a wrap)
    comes in the step just before the read or in the read's own step: the
    read-back samples the slots' mirrors after the last slot's update of
    the step before and before the first slot's update of the next. Rounds
    of a SWAP of channel l (slot l) to a 9-word stream and CTRL reads at
    every access until the next SWAP; the wrap moves against the reads from
    round to round. The test asserts that reads came right after a switch
    of the last slot, or right before one of the first (else it proves
    little)."""
    rng = np.random.default_rng(70 + slots + l)
    streams = [[int(w) for w in pack_iq(rng.integers(-32768, 32768, 9), rng.integers(-32768, 32768, 9))]
               for _ in range(2)]
    inc = (1 << 32) - 1                                 # a word a step: a wrap every 9 steps
    inits = [ChannelInit(tuple(streams[0]), inc, 1 << 16, 0, True, 0) if ch == l else ChannelInit()
             for ch in range(slots)]
    dut = WindFarmReplay(slots, slots=slots, init=inits, **KW)
    a = dut.register_map.addr
    R = dut.contract.refill_samples
    # Round r starts at step k (the bus idle by then); the wrap after the
    # SWAP's landing moves against the reads by the same amount modulo 9
    # from round to round, one amount for rounds 0-8 and another for 9-17:
    # one of the two is prime to 3, and then the rounds meet every position.
    steps = access_steps(slots)
    ops, k = [], R
    for r in range(18):
        base, words = 32 + 16 * (r % 2), streams[(r + 1) % 2]
        ops += [(k, "w", a("STREAM_ADDR"), base)] + [(k, "w", a("STREAM_DATA"), w) for w in words]
        ops += [(k, "w", a("BASE", l), base), (k, "w", a("LENGTH", l), 9),
                (k, "w", a("CRC", l), stream_crc32(words)), (k, "w", a("CTRL", l), CTRL_ENABLE | CTRL_SWAP)]
        ops += [(k, "r", a("CTRL", l), 0)] * 10
        k += steps * (30 + (1 if r < 9 else 2))
    T = k + 10
    xi, xq = rng.integers(-32768, 32768, T), rng.integers(-32768, 32768, T)
    _, _, done, _ = check(dut, inits, xi, xq, ops, name=f"switch and read, M = {slots}, slot {l}")
    assert len(done) == len(ops)
    # the model's CTRL at each read's step k, at k - 1 when no access lands
    # between, and at k + 1 (no CTRL write follows a read here): a switch
    # in step k - 1, in step k
    model = ReplayModel(dut.contract, inits)
    pos, after, before = 0, 0, 0
    for k, kind, ad, value in done:
        if kind == "r" and k - 1 >= pos:
            model.run(xi[pos:k - 1], xq[pos:k - 1])
            earlier = model.read(ad)
            model.run(xi[k - 1:k], xq[k - 1:k])
            pos = k
            peek = copy.deepcopy(model)
            peek.run(xi[k:k + 1], xq[k:k + 1])
            after += model.read(ad) != earlier
            before += peek.read(ad) != model.read(ad)
        else:
            model.run(xi[pos:k], xq[pos:k])
            pos = k
            if kind == "w":
                model.write(ad, value)
    if l == slots - 1:
        assert after >= 2, f"{after} reads came right after a switch of the last slot: the test proves little"
    if l == 0:
        assert before >= 2, f"{before} reads came right before a switch of the first slot: the test proves little"


@pytest.mark.parametrize("slots", [1, 2, 3, 4, 5, 7, 8, 10])
def test_the_bus_is_taken_once_in_take_interval_clocks_and_lands_in_an_accepting_clock(slots):
    """``bus.ready`` (docs/registers.md): once in take_interval(M) clocks, at
    least TAKE_SPACING apart, and each take's landing (WRITE_STAGING clocks
    later) is a clock in which the block can accept an input."""
    dut = WindFarmReplay(2, slots=slots, **KW)
    W = take_interval(slots)
    takes, accepting = [], set()

    async def bench(ctx):
        ctx.set(dut.i.valid, 0)
        ctx.set(dut.o.ready, 1)
        for cycle in range(6 * W + 40):
            if ctx.get(dut.bus.ready):
                takes.append(cycle)
            if ctx.get(dut.i.ready):
                accepting.add(cycle)
            await ctx.tick()

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    assert W % slots == 0 and W >= TAKE_SPACING
    assert len(takes) >= 5 and set(np.diff(takes).tolist()) == {W}, f"takes at {takes}"
    landings = [t + WRITE_STAGING for t in takes if t + WRITE_STAGING < 6 * W + 40]
    assert landings and all(t in accepting for t in landings), \
        f"landings {landings} not all in accepting clocks {sorted(accepting)[:12]}..."


def test_identification_registers():
    dut = WindFarmReplay(2, **KW)
    rmap = dut.register_map
    ops = [(0, "r", rmap.addr(n), 0) for n in ("ID", "CONFIG", "LATENCY", "POOL_WORDS", "MAX_DELAY",
                                               "MAX_TAP")]
    _, _, done, _ = check(dut, [], np.zeros(4, np.int64), np.zeros(4, np.int64), ops)
    vals = [v for *_, v in done]
    assert vals == [ID_VALUE, 2 | (1 << 16), dut.latency, KW["pool_words"], 20, 6]


@pytest.mark.parametrize("slots", [1, 3])
def test_switch_at_period_boundary(slots):
    """A new stream written into free pool space while running takes over
    exactly after the old stream's last word, after the refill's muted samples.
    The old stream's period (16 samples) is longer than the clocks between
    two accesses at M = 1 (take_interval), so the read after the SWAP sees it
    pending."""
    length_old, length_new = 12, 3
    old = pack_iq([1000 * (k + 1) for k in range(length_old)], [0] * length_old)
    new = pack_iq([-500 * (k + 1) for k in range(length_new)], [7] * length_new)
    inc = 3 << 30                       # 0.75 words per sample
    inits = [ChannelInit(tuple(int(w) for w in old), inc, 1 << 16, 0, True)]
    dut = WindFarmReplay(1, slots=slots, init=inits, **KW)
    rmap = dut.register_map
    R = dut.contract.refill_samples
    T = 2 * R + 260
    xi = np.full(T, 16384, dtype=np.int64); xq = np.zeros(T, dtype=np.int64)
    a = rmap.addr
    k0 = R + 10
    ops = [(k0, "w", a("STREAM_ADDR"), 100)]
    ops += [(k0 + 1, "w", a("STREAM_DATA"), int(w)) for w in new]
    ops += [(k0 + 2, "w", a("BASE", 0), 100), (k0 + 2, "w", a("LENGTH", 0), length_new),
            (k0 + 2, "w", a("PHASE_INC", 0), 1 << 31), (k0 + 2, "w", a("CRC", 0), stream_crc32(new)),
            (k0 + 3, "w", a("CTRL", 0), CTRL_ENABLE | CTRL_SWAP), (k0 + 3, "r", a("CTRL", 0), 0),
            (k0 + 150, "r", a("CTRL", 0), 0), (k0 + 150, "r", a("BASE", 0), 0)]
    hi, hq, done, model = check(dut, inits, xi, xq, ops, valid=(1, 0, 1, 1), name="switch")
    reads = [v for k, kind, ad, v in done if kind == "r"]
    assert reads[0] == CTRL_ENABLE | CTRL_SWAP            # pending
    assert reads[1] == CTRL_ENABLE | CTRL_BANK            # switched
    assert reads[2] == 100
    # the output is x * word / 2: old words 500..6000, new words -250, -500, -750
    L = dut.latency
    out = hi[L + R:]
    first_new = int(np.nonzero(out < 0)[0][0])
    assert out[first_new - R - 1] == 500 * length_old, "switch not at the end of the old period"
    assert not out[first_new - R:first_new].any(), "not muted while the cache refills"
    assert out[first_new] == -250, "new stream does not start at word 0"
    assert set(out[first_new:].tolist()) == {-250, -500, -750}


def reload_bench(slots):
    """One channel playing words 1000..5000 (I) at 0.75 words a sample, and a
    new 4-word stream (-500..-2000, 7) to load: the engine, the new words,
    the register addresses and the refill."""
    old = pack_iq([1000 * (k + 1) for k in range(5)], [0] * 5)
    new = [int(w) for w in pack_iq([-500 * (k + 1) for k in range(4)], [7] * 4)]
    inits = [ChannelInit(tuple(int(w) for w in old), 3 << 30, 1 << 16, 0, True)]
    dut = WindFarmReplay(1, slots=slots, init=inits, **KW)
    return dut, inits, new, dut.register_map.addr, dut.contract.refill_samples


@pytest.mark.parametrize("slots", [1, 10])
def test_the_stream_word_count_stops_at_its_largest_value(slots):
    """STREAM_COUNT counts the words written since STREAM_ADDR up to its
    largest value (2**9 - 1 in this build) and stays there; read around that
    value, gateware and model equal (check compares every read)."""
    dut, inits, new, a, R = reload_bench(slots)
    top = (1 << dut.contract.length_width) - 1
    assert top == 511
    xi = np.zeros(40, dtype=np.int64); xq = np.zeros(40, dtype=np.int64)
    ops = [(5, "w", a("STREAM_ADDR"), 200)]
    for n in range(1, top + 4):
        ops.append((5, "w", a("STREAM_DATA"), n))
        if n >= top - 2:
            ops.append((5, "r", a("STREAM_COUNT"), 0))
    _, _, done, _ = check(dut, inits, xi, xq, ops, name=f"word count, M = {slots}")
    counts = [v for _, kind, _, v in done if kind == "r"]
    assert counts == [top - 2, top - 1, top, top, top, top]


@pytest.mark.parametrize("slots, damage", [(1, "bit"), (3, "bit"), (5, "bit"), (1, "lost word"), (3, "moved"),
                                           (10, "moved")])
def test_a_stream_damaged_on_the_way_is_refused_and_the_old_one_plays_on(slots, damage):
    """A reload whose words are not the ones its CRC-32 names (a bit flipped,
    a word lost, the words written elsewhere than BASE) is refused at the
    SWAP: CTRL reads rejected and no pending switch, the old stream plays on,
    STREAM_CRC/STREAM_COUNT say what arrived (zlib's CRC of it). Sent again
    intact, the stream is taken and rejected clears. Gateware and model equal."""
    dut, inits, new, a, R = reload_bench(slots)
    length_new = len(new)
    sent, start = list(new), 100
    if damage == "bit":
        sent[2] ^= 1 << 20
    elif damage == "lost word":
        del sent[1]
    else:
        start = 101
    q = access_steps(slots)

    def load(k, words, at):
        return ([(k, "w", a("STREAM_ADDR"), at)] + [(k, "w", a("STREAM_DATA"), w) for w in words]
                + [(k, "w", a("BASE", 0), 100), (k, "w", a("LENGTH", 0), length_new),
                   (k, "w", a("PHASE_INC", 0), 1 << 31), (k, "w", a("CRC", 0), stream_crc32(new)),
                   (k, "w", a("CTRL", 0), CTRL_ENABLE | CTRL_SWAP), (k, "r", a("CTRL", 0), 0),
                   (k, "r", a("STREAM_CRC"), 0), (k, "r", a("STREAM_COUNT"), 0)])
    k0 = R + 10
    first = load(k0, sent, start)
    k1 = k0 + q * len(first) + R + 50
    second = load(k1, new, 100)
    T = k1 + q * len(second) + R + 140
    xi = np.full(T, 16384, dtype=np.int64); xq = np.zeros(T, dtype=np.int64)
    ops = first + [(k1 - 5, "r", a("CTRL", 0), 0)] + second + [(T - 5, "r", a("CTRL", 0), 0)]
    hi, hq, done, model = check(dut, inits, xi, xq, ops, name=f"damaged {damage}")
    reads = [v for k, kind, ad, v in done if kind == "r"]
    assert reads[:3] == [CTRL_ENABLE | CTRL_REJECTED, stream_crc32(sent), len(sent)]
    assert reads[3] == CTRL_ENABLE | CTRL_REJECTED            # still the old stream, nothing pending
    # intact: taken (pending, or already switched at the old stream's wrap)
    assert reads[4] in (CTRL_ENABLE | CTRL_SWAP, CTRL_ENABLE | CTRL_BANK)
    assert reads[5:7] == [stream_crc32(new), length_new]
    assert reads[7] == CTRL_ENABLE | CTRL_BANK                # switched, rejected cleared
    L = dut.latency
    before = hi[L + R:L + k1]
    assert before.min() > 0 and set(before.tolist()) <= {500, 1000, 1500, 2000, 2500}, \
        "the refused stream played"
    k_swap = [step for step, kind, addr, _ in done if kind == "w" and addr == a("CTRL", 0)][-1]
    assert set(hi[L + k_swap + 2 * R + 10:].tolist()) == {-250, -500, -750, -1000}


@pytest.mark.parametrize("slots", [1, 3, 10])
def test_a_swap_needs_base_length_and_crc_written_since_power_up(slots):
    """An intact stream written again at its power-up base, with LENGTH and
    CRC written but BASE left at its reset value (which equals the run's
    start): refused, since BASE was not written (the register file's RAMs
    are not reset, so the check takes only values the host wrote). Written,
    the same SWAP is taken. Gateware and model equal."""
    dut, inits, new, a, R = reload_bench(slots)
    old = list(inits[0].words)
    assert inits[0].base == 0
    T = 2 * R + 200
    xi = np.full(T, 16384, dtype=np.int64); xq = np.zeros(T, dtype=np.int64)
    k0, k1 = R + 10, R + 60
    run = [(k0, "w", a("STREAM_ADDR"), 0)] + [(k0, "w", a("STREAM_DATA"), w) for w in old]
    ops = run + [(k0, "w", a("LENGTH", 0), len(old)), (k0, "w", a("CRC", 0), stream_crc32(old)),
                 (k0, "w", a("CTRL", 0), CTRL_ENABLE | CTRL_SWAP), (k0, "r", a("CTRL", 0), 0),
                 (k0, "r", a("BASE", 0), 0),
                 (k1, "w", a("BASE", 0), 0), (k1, "w", a("CTRL", 0), CTRL_ENABLE | CTRL_SWAP),
                 (k1, "r", a("CTRL", 0), 0), (T - 5, "r", a("CTRL", 0), 0)]
    hi, hq, done, model = check(dut, inits, xi, xq, ops, name="unstated BASE")
    reads = [v for k, kind, ad, v in done if kind == "r"]
    assert reads[:2] == [CTRL_ENABLE | CTRL_REJECTED, 0], "BASE unwritten: the SWAP must be refused"
    assert reads[2] in (CTRL_ENABLE | CTRL_SWAP, CTRL_ENABLE | CTRL_BANK), "BASE written: taken"
    assert reads[3] == CTRL_ENABLE | CTRL_BANK


@pytest.mark.parametrize("slots", [1, 2])
def test_manifest_register_writes_place_echoes(slots):
    """A manifest (as `rast stream` writes it) loaded by register writes into a
    block that starts empty: each windmill's echo lands at its delay_samples."""
    N = 3
    dut = WindFarmReplay(N, slots=slots, **KW)
    L = dut.latency
    names = ["a", "b", "c"]
    delays = [L + 7, L + 7, L + 10]
    streams = [[int(pack_iq([8192 * (l + 1)], [0])[0])] * (l + 2) for l in range(N)]
    manifest = {
        "windmills": [{"name": n, "hex_file": f"{n}.hex", "length": len(s), "delay_samples": d}
                      for n, s, d in zip(names, streams, delays)],
        "registers": {"channels": [
            {"windmill": n, "enable": 1, "length": len(s), "phase_increment": 1 << 30,
             "gain": 1 << 16, "delay_samples": d}
            for l, (n, s, d) in enumerate(zip(names, streams, delays))]},
    }
    writes = manifest_to_register_writes(manifest, dut.contract, streams=streams)
    p = dut.contract.refill_samples + 2              # after the switches' refill
    T = p + 60
    xi = np.zeros(T, dtype=np.int64); xq = np.zeros(T, dtype=np.int64)
    xi[p] = 16384
    ops = [(0, "w", a, v) for a, v in writes]
    hi, hq, done, _ = check(dut, [], xi, xq, ops, valid=(1, 0), name="manifest", hold=True)
    # channels 0 and 1 share a range: their echoes add (8192+16384)/2 ... at delays[0]
    assert (np.nonzero(hi)[0] - p).tolist() == sorted(set(delays))
    assert hi[p + delays[0]] == (8192 + 16384) // 2 and hi[p + delays[2]] == 24576 // 2
    with pytest.raises(ValueError, match=r"shorter than the replay block's fixed latency"):
        bad = dict(manifest, registers={"channels": [dict(manifest["registers"]["channels"][0],
                                                          delay_samples=L - 1)]})
        manifest_to_register_writes(bad, dut.contract)
    inits, common = manifest_channel_inits(manifest, dut.contract, streams=streams)
    assert common == 7 and [i.delay for i in inits] == [0, 0, 3]


@pytest.mark.parametrize("seed, slots", [(1, 1), (2, 1), (3, 2), (4, 3), (5, 2)])
def test_random_register_stress(seed, slots):
    """Dense random register traffic (stream writes, switches forced and at
    wraps, taken or refused by the stream check, base/rate/length/CRC changes,
    delays, status reads) racing the samples. New stream words are written
    only where no channel can play (the pool's upper half): a playing stream's
    words are the host's to keep. Switches are taken after a "reseal": the
    words already in the pool's lower half written again (the pool does not
    change), then BASE, LENGTH and CRC naming them."""
    rng = np.random.default_rng(100 + seed)
    N = 2
    kw = dict(pool_words=32, max_delay=5, max_tap=3)
    inits = rand_inits(rng, N, depth=4)
    dut = WindFarmReplay(N, slots=slots, init=inits, interpolation=("hold", "linear")[seed % 2], **kw)
    a = dut.register_map.addr
    T = 500
    xi = rng.integers(-32768, 32768, T); xq = rng.integers(-32768, 32768, T)
    lower = ReplayModel(dut.contract, inits).pool[:16]
    ops = []
    for k in sorted(rng.integers(0, T, 400).tolist()):
        l = int(rng.integers(0, N))
        r = rng.integers(0, 11)
        if r == 0:
            ops.append((k, "w", a("CTRL", l), int(rng.integers(0, 4))))
        elif r == 10:
            b = int(rng.choice([0, 4, 8]))
            n = int(rng.integers(1, 7))
            ops += [(k, "w", a("STREAM_ADDR"), b)] + [(k, "w", a("STREAM_DATA"), int(w))
                                                      for w in lower[b:b + n]]
            ops += [(k, "w", a("BASE", l), b), (k, "w", a("LENGTH", l), n),
                    (k, "w", a("CRC", l), stream_crc32(lower[b:b + n])),
                    (k, "w", a("CTRL", l), int(rng.integers(2, 4)))]
        elif r == 1:
            ops.append((k, "w", a("BASE", l), int(rng.choice([0, 4, 8]))))
        elif r in (2, 3):
            ops += [(k, "w", a("STREAM_ADDR"), int(rng.integers(16, 32))),
                    (k, "w", a("STREAM_DATA"), int(rng.integers(0, 1 << 32)))]
        elif r == 4:
            ops.append((k, "w", a("LENGTH", l), int(rng.integers(0, 7))))
        elif r == 5:
            ops.append((k, "w", a("PHASE_INC", l), int(rng.integers(1 << 30, 1 << 32))))
        elif r == 6:
            ops.append((k, "w", a("GAIN", l), int(rng.integers(1 << 16, 1 << 17))))
        elif r == 7:
            ops += [(k, "r", a("STATUS"), 0), (k, "r", a("STREAM_CRC"), 0), (k, "r", a("STREAM_COUNT"), 0),
                    (k, "r", a("COMMON_DELAY"), 0)]
        elif r == 8:
            # what the channel plays: its bank, the CRC of the last SWAP taken, the tap in effect
            ops += [(k, "r", a("CTRL", l), 0), (k, "r", a("PLAYED", l), 0), (k, "r", a("DELAY", l), 0)]
        else:
            name = str(rng.choice(["DELAY", "APPLY", "COMMON_DELAY"]))
            ops.append((k, "w", a(name, l if name == "DELAY" else None), int(rng.integers(0, 8))))
    check(dut, inits, xi, xq, ops, valid=(1, 1, 0), ready=(1, 1, 1, 0), name=f"stress {seed}")


@pytest.mark.parametrize("slots", [1, 2])
def test_forced_switch_racing_a_wrap(slots):
    """A CTRL write that forces a switch in the very sample whose wrap completes
    a pending switch: both switches happen (bank toggles twice), as in the model."""
    words = [int(pack_iq([1000 * (k + 1)], [0])[0]) for k in range(4)]
    inits = [ChannelInit((words[0],), (1 << 32) - 1, 1 << 16, 0, True)]
    dut = WindFarmReplay(1, slots=slots, init=inits, pool_words=16, max_delay=3, max_tap=1,
                         interpolation="hold")
    a = dut.register_map.addr
    R = dut.contract.refill_samples                # each switch mutes (phase held) this long
    T = 11 * (R + 6)
    xi = np.full(T, 16384, dtype=np.int64); xq = np.zeros(T, dtype=np.int64)
    ops = [(0, "w", a("STREAM_ADDR"), 8), (0, "w", a("STREAM_DATA"), words[1]),
           (0, "w", a("BASE", 0), 8), (0, "w", a("LENGTH", 0), 1),
           (0, "w", a("CRC", 0), stream_crc32(words[1:2]))]
    for k in range(R + 5, 11 * (R + 6) - 10, R + 6):
        ops += [(k, "w", a("CTRL", 0), CTRL_ENABLE | CTRL_SWAP), (k, "w", a("CTRL", 0), CTRL_SWAP),
                (k, "r", a("CTRL", 0), 0), (k, "w", a("CTRL", 0), CTRL_ENABLE)]
    hi, hq, done, model = check(dut, inits, xi, xq, ops, name="race")
    banks = [v >> 2 for k, kind, ad, v in done if kind == "r"]
    # each round: the wrap completes the pending switch and the write forces
    # another in the same sample, so the bank is back where it was
    assert banks == [0] * len(banks) and len(banks) == 10


@pytest.mark.parametrize("channels, slots", [(16, 1), (16, 5), (20, 4)])
def test_many_channels(channels, slots):
    """16 pipelines of one slot; 4 of 5 slots (c[n] through a copy per pair
    of pipelines); 5 of 4 slots (c[n] through two levels of copies)."""
    rng = np.random.default_rng(16)
    inits = rand_inits(rng, channels, depth=4)
    dut = WindFarmReplay(channels, slots=slots, init=inits, pool_words=64, max_delay=5, max_tap=2,
                         interpolation="hold")
    T = dut.contract.refill_samples + 160         # past the caches' first fill
    xi, xq = rng.integers(-32768, 32768, T), rng.integers(-32768, 32768, T)
    check(dut, inits, xi, xq, valid=(1, 1, 0), name=f"N={channels}")


@pytest.mark.parametrize("slots, interpolation", [(1, "hold"), (3, "hold"), (1, "fir"), (3, "fir")])
def test_a_reset_mid_run_drops_every_sample_in_flight(slots, interpolation):
    """The data registers are not reset (rast.hdl.channel_pipeline): a reset
    in the middle of a run must still give, as at power-up, only muted
    (zero) samples for the refill after it, nothing left over from before."""
    rng = np.random.default_rng(slots * 7 + len(interpolation))
    inits = rand_inits(rng, 3)
    dut = WindFarmReplay(3, slots=slots, init=inits, **{**KW, "interpolation": interpolation})
    R = dut.contract.refill_samples
    rst = Signal()
    top = Module()
    top.submodules.dut = ResetInserter(rst)(dut)
    before, T_after = R + 120, R + 60
    outputs = []                       # (taken after the reset, I, Q)

    async def bench(ctx):
        n_in, reset_done = 0, False
        ctx.set(dut.o.ready, 1)
        for _ in range((before + T_after) * slots * 4 + 400):
            if reset_done and sum(a for a, _, _ in outputs) >= T_after:
                return
            pulse = n_in == before and not reset_done
            ctx.set(rst, pulse)
            ctx.set(dut.i.valid, 0 if pulse else 1)
            ctx.set(dut.i.payload.re, int(rng.integers(-32768, 32768)))
            ctx.set(dut.i.payload.im, int(rng.integers(-32768, 32768)))
            taken = not pulse and ctx.get(dut.i.ready)
            if not pulse and ctx.get(dut.o.valid):
                outputs.append((reset_done, ctx.get(dut.o.payload.re), ctx.get(dut.o.payload.im)))
            await ctx.tick()
            reset_done |= pulse
            n_in += taken
        raise AssertionError("the engine did not give its samples after the reset")

    sim = Simulator(top)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    old = np.array([(i, q) for after, i, q in outputs if not after])
    new = np.array([(i, q) for after, i, q in outputs if after])
    assert np.count_nonzero(old[R:]) > 0, "the channels should play before the reset"
    assert np.count_nonzero(new[:R]) == 0, (f"after the reset, sample {np.nonzero(new[:R])[0][0]} of the "
                                            f"{R}-sample refill is not zero: left over from before the reset")
    assert np.count_nonzero(new[R:]) > 0, "the channels should play again after the refill"


@pytest.mark.parametrize("slots", [1, 2, 3, 4, 5, 6, 7, 8, 10])
def test_a_swap_right_after_the_last_stream_word_is_taken(slots):
    """CTRL's SWAP written just after the stream's last word (the two land
    take_interval(M) clocks apart, the closest the bus allows): the CRC of
    that word (CRC_CLOCKS after the clock that loads it) and the registered
    check (MATCH_STAGES) are complete in time, so the intact stream is
    taken, not refused."""
    dut, inits, new, a, R = reload_bench(slots)
    length_new = len(new)
    k = R + 10
    ops = [(k, "w", a("BASE", 0), 100), (k, "w", a("LENGTH", 0), length_new),
           (k, "w", a("PHASE_INC", 0), 1 << 31), (k, "w", a("CRC", 0), stream_crc32(new)),
           (k, "w", a("STREAM_ADDR"), 100)] + [(k, "w", a("STREAM_DATA"), w) for w in new]
    ops += [(k, "w", a("CTRL", 0), CTRL_ENABLE | CTRL_SWAP), (k, "r", a("CTRL", 0), 0)]
    T = 2 * R + 120 + len(ops) * access_steps(slots)
    xi = np.full(T, 16384, dtype=np.int64); xq = np.zeros(T, dtype=np.int64)
    hi, hq, done, model = check(dut, inits, xi, xq, ops, name=f"swap after the last word, M = {slots}")
    reads = [v for _, kind, _, v in done if kind == "r"]
    assert reads[0] in (CTRL_ENABLE | CTRL_SWAP, CTRL_ENABLE | CTRL_BANK), f"CTRL reads {reads[0]:#x}"
    k_swap = next(step for step, kind, addr, _ in done if kind == "w" and addr == a("CTRL", 0))
    assert set(hi[dut.latency + k_swap + 2 * R + 10:].tolist()) == {-250, -500, -750, -1000}