"""Stream replay, complex multiplier and delay line against the bit-exact model."""

import itertools
import warnings
from fractions import Fraction

import numpy as np
import pytest
from amaranth.sim import Simulator

from rast.hdl.cmult import ComplexMultiplier
from rast.hdl.delay_line import DelayLine
from rast.hdl.stream_replay import StreamReplay
from rast.hdl.stream_pool import StreamPool
from rast.sim.pooled_stream import PooledStream
from rast.hdl.iq import IQ
from rast.model import datapath as dp
from rast.model.fixedpoint import pack_iq, unpack_iq, PHASE_FRAC_BITS, ReplayContract

ONE = 1 << PHASE_FRAC_BITS


def simulate(dut, bench):
    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()


# ---------------------------------------------------------------- parameters

@pytest.mark.parametrize("args, exc, msg", [
    (dict(a_width=0), TypeError, r"^Operand A width must be a positive integer, not 0$"),
    (dict(shift=0), ValueError, r"^Rounding shift must be an integer in \[1, 32\], not 0$"),
    (dict(form="5mult"), ValueError,
     r"^Complex multiplier form must be one of 4mult, 3mult, not '5mult'$"),
])
def test_cmult_parameters(args, exc, msg):
    with pytest.raises(exc, match=msg):
        ComplexMultiplier(**args)


def test_delay_line_parameters():
    with pytest.raises(TypeError, match=r"^Delay line width must be a positive integer, not 0$"):
        DelayLine(0, 4)
    with pytest.raises(TypeError, match=r"^Maximum delay must be a non-negative integer, not -1$"):
        DelayLine(8, -1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")      # never elaborated: UnusedElaboratable
        assert [DelayLine(8, d).depth for d in (0, 14, 15)] == [2, 16, 32]


def test_stream_replay_parameters():
    with pytest.raises(ValueError, match=r"^Pool words must be an integer of at least 16, not 6$"):
        StreamReplay(6)
    with pytest.raises(ValueError, match=r"^Channels must be an integer in \[1, 64\], not 0$"):
        StreamReplay(16, channels=0)
    with pytest.raises(ValueError, match=r"^Interpolation must be one of hold, linear, fir, not 'cubic'$"):
        StreamReplay(16, interpolation="cubic")
    with pytest.raises(ValueError, match=r"^Initial length must be an integer in \[8, 16\], not 4$"):
        StreamReplay(16, init_length=4)
    with pytest.raises(ValueError, match=r"^Initial base must be a pool address in \[0, 15\], not 16$"):
        StreamReplay(16, init_base=16)
    with pytest.raises(ValueError, match=r"^Initial increment must be an integer in \[0, 5592405\], not 5592406$"):
        StreamReplay(16, init_increment=5592406)
    with pytest.raises(ValueError, match=r"^Initial increment must be an integer in \[0, 2147483647\], not 2147483648$"):
        StreamReplay(16, channels=2, interpolation="hold", init_increment=1 << 31)
    with pytest.raises(ValueError, match=r"^Pool words must be a power of two from 16 to 16384 or a "
                                         r"multiple of 16384, not 48$"):
        StreamPool(48, 4)


@pytest.mark.parametrize("args, exc, msg", [
    (dict(channels=0), ValueError, r"^Channel count must be a positive integer, not 0$"),
    (dict(channels=65), ValueError, r"^Channel count must be at most 64, not 65$"),
    (dict(channels=2.0), TypeError, r"^Channel count must be a positive integer, not 2.0$"),
    (dict(pool_words=100), ValueError,
     r"^Pool words must be a power of two from 16 to 16384 or a multiple of 16384, not 100$"),
    (dict(pool_words=8), ValueError, r"^Pool words must be an integer of at least 16, not 8$"),
    (dict(pool_words=20000), ValueError,
     r"^Pool words must be a power of two from 16 to 16384 or a multiple of 16384, not 20000$"),
    (dict(max_delay=-1), ValueError, r"^Maximum delay must be a positive integer, not -1$"),
    (dict(max_tap=0), ValueError, r"^Maximum tap must be a positive integer, not 0$"),
    (dict(cmult_form="x"), ValueError,
     r"^Complex multiplier form must be one of 4mult, 3mult, not 'x'$"),
])
def test_contract_parameters(args, exc, msg):
    with pytest.raises(exc, match=msg):
        ReplayContract(**args)


def test_iq_layout():
    assert IQ(16).size == 32
    with pytest.raises(TypeError, match=r"^I/Q width must be a positive integer, not 0$"):
        IQ(0)


# ---------------------------------------------------------------- cmult

@pytest.mark.parametrize("form", ["4mult", "3mult"])
def test_cmult_random_and_extremes(form):
    rng = np.random.default_rng(3)
    ext = [-32768, -32767, -1, 0, 1, 32767]
    corner = np.array(list(itertools.product(ext, repeat=4)), dtype=np.int64)
    rand = rng.integers(-32768, 32768, size=(300, 4))
    ops = np.concatenate([corner, rand])
    dut = ComplexMultiplier(form=form)
    assert dut.o_width == 18
    lat = dut.latency
    got = []
    en_pat = itertools.cycle([1, 1, 0, 1, 0, 0, 1])

    async def bench(ctx):
        n = 0
        while len(got) < len(ops):
            en = next(en_pat)
            ar, ai, br, bi = (int(v) for v in ops[min(n, len(ops) - 1)])
            ctx.set(dut.a.re, ar); ctx.set(dut.a.im, ai)
            ctx.set(dut.b.re, br); ctx.set(dut.b.im, bi)
            ctx.set(dut.en, en)
            if en:
                if n >= lat:
                    got.append((ctx.get(dut.o.re), ctx.get(dut.o.im)))
                n += 1
            await ctx.tick()

    simulate(dut, bench)
    got = np.array(got)
    ei, eq = dp.cmult(ops[:, 0], ops[:, 1], ops[:, 2], ops[:, 3])
    for k in range(len(ops)):
        assert (got[k, 0], got[k, 1]) == (ei[k], eq[k]), \
            f"{form}: a=({ops[k,0]},{ops[k,1]}) b=({ops[k,2]},{ops[k,3]}) step {k}: gateware " \
            f"{tuple(got[k])}, model ({ei[k]}, {eq[k]})"


# ---------------------------------------------------------------- delay line

def test_delay_line_every_delay_with_gaps():
    maxd = 13
    dut = DelayLine(16, maxd)
    rng = np.random.default_rng(5)
    per = 40
    delays = np.repeat(np.arange(maxd + 1), per)
    delays = np.concatenate([delays, rng.integers(0, maxd + 1, 200)])  # random changes too
    x = rng.integers(0, 1 << 16, len(delays))
    got = []
    en_pat = itertools.cycle([1, 0, 1, 1, 0])

    async def bench(ctx):
        n = 0
        while n < len(x):
            en = next(en_pat)
            ctx.set(dut.en, en); ctx.set(dut.i, int(x[n])); ctx.set(dut.delay, int(delays[n]))
            if en:
                got.append(ctx.get(dut.o))
                n += 1
            await ctx.tick()

    simulate(dut, bench)
    expect = dp.delay_line(x, delays)
    got = np.array(got)
    bad = np.nonzero(got != expect)[0]
    assert not len(bad), f"step {bad[0]} delay {delays[bad[0]]}: gateware {got[bad[0]]}, model {expect[bad[0]]}"
    # exactness, independently of the model: with a constant delay d, out[n] = x[n - 3 - d]
    for d in range(maxd + 1):
        lo = d * per + 3 + maxd + 1
        for n in range(lo, (d + 1) * per):
            assert got[n] == x[n - 3 - d], f"delay {d}, step {n}"


# ---------------------------------------------------------------- stream replay

def _run_stream(dut, steps, en_pat=(1,)):
    idx, words = [], []
    pat = itertools.cycle(en_pat)

    async def bench(ctx):
        n = 0
        while n < steps:
            en = next(pat)
            ctx.set(dut.en, en)
            if en:
                idx.append(ctx.get(dut.index))
                words.append((ctx.get(dut.o.re), ctx.get(dut.o.im)))
                n += 1
            await ctx.tick()

    simulate(dut, bench)
    return np.array(idx), np.array(words)


@pytest.mark.parametrize("interpolation", ["hold", "linear", "fir"])
def test_stream_replay_wraps_at_length(interpolation):
    rng = np.random.default_rng(7)
    depth, length = 16, 11
    wi, wq = rng.integers(-32768, 32768, depth), rng.integers(-32768, 32768, depth)
    words = pack_iq(wi, wq)
    c = ReplayContract(channels=1, pool_words=depth, interpolation=interpolation)
    # FIR: the largest rates it takes, so J advances as often as allowed
    inc = int(rng.integers(c.max_phase_increment // 5, c.max_phase_increment + 1))
    dut = PooledStream(depth, interpolation=interpolation, init=list(words), init_length=length,
                       init_increment=inc)
    # the phase is held at 0 for the refill after reset
    mute = c.refill_samples
    steps = mute + length * ONE // inc + 600
    idx, got = _run_stream(dut, steps, en_pat=(1, 1, 0))
    ph = np.concatenate([np.zeros(mute, dtype=np.int64), dp.phase_sequence(0, inc, length, steps - mute)])
    assert (idx == ph >> 32).all()
    assert idx.max() == length - 1
    # word at step n comes from the phase at step n - latency; 0 while muted
    ei, eq = dp.stream_words(interpolation, words, length, ph)
    ei[:mute] = 0
    eq[:mute] = 0
    lat = dut.latency
    for n in range(lat, steps):
        assert tuple(got[n]) == (ei[n - lat], eq[n - lat]), \
            f"step {n}: gateware {tuple(got[n])}, model ({ei[n-lat]}, {eq[n-lat]}), phase {ph[n-lat]:#x}"


def test_stream_replay_long_run_exact_period():
    # 3 words at 0.3709... words per sample: thousands of wraps, index exact at every step
    inc = 1593012345
    dut = PooledStream(16, interpolation="hold", init=[1, 2, 3], init_length=3, init_increment=inc)
    steps = 20000
    mute = dut.stream.refill_samples
    idx, got = _run_stream(dut, steps)
    ph = np.concatenate([np.zeros(mute, dtype=np.int64), dp.phase_sequence(0, inc, 3, steps - mute)])
    assert (idx == ph >> 32).all()
    lat = dut.latency
    assert (got[mute + lat:, 0] == (ph[mute:steps - lat] >> 32) + 1).all()      # words 1, 2, 3


@pytest.mark.parametrize("rate", [Fraction(1, 3), Fraction(4321, 1000000), Fraction(999, 1000)])
def test_rate_accumulator_drift_bound(rate):
    """Model, long run: the phase after n steps differs from the exact rate by at most
    n * 2**-33 words (the increment is rounded to 2**-32 words per sample)."""
    inc = round(rate * ONE)
    length = 1000
    for n in (10**6, 10**9, 10**12):
        ph = int(dp.phase_sequence((n - 1) * inc % (length * ONE), inc, length, 2)[1])
        exact = (rate * n) % length
        err = abs(Fraction(ph, ONE) - exact)
        err = min(err, length - err)
        assert err <= Fraction(n, 2 * ONE), f"rate {rate}, n {n}: error {float(err)} words"
