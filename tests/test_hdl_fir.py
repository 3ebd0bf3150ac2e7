"""The FIR interpolator of the replay block: gateware against the bit-exact
model (Amaranth simulator), and the interpolator against the signal it
interpolates (independent of the model)."""

import numpy as np
import pytest

from rast.hdl.replay_top import WindFarmReplay
from rast.model.contract import datapath as dp
from rast.model.contract.fixedpoint import (pack_iq, FIR_MAX_INCREMENT, FIR_MIN_LENGTH, FIR_REFILL_SAMPLES,
                                            FIR_PHASES, PHASE_FRAC_BITS, STREAM, FIR_LEAD, FIR_COEF_FRAC,
                                            fir_coefficients)
from rast.model.contract.regmap import CTRL_ENABLE, CTRL_SWAP, stream_crc32
from rast.model.contract.powerup import ChannelInit

from hdl_harness import run_replay, model_replay, assert_same

KW = dict(pool_words=64, max_delay=12, max_tap=4, interpolation="fir")


def _inits(rng, n, depth=32):
    """Random streams of up to ``depth`` words, one after the other in the pool."""
    out, base = [], 0
    for _ in range(n):
        length = int(rng.integers(FIR_MIN_LENGTH, depth + 1))
        words = pack_iq(rng.integers(-32768, 32768, length), rng.integers(-32768, 32768, length))
        inc = int(rng.integers(FIR_MAX_INCREMENT // 2, FIR_MAX_INCREMENT + 1))
        out.append(ChannelInit(tuple(int(w) for w in words), inc, int(rng.integers(1 << 15, 1 << 17)),
                               int(rng.integers(0, 4)), True, base))
        base += length
    return out


def _check(dut, inits, xi, xq, ops=(), valid=(1,), ready=(1,), name="fir"):
    hi, hq, done = run_replay(dut, xi, xq, ops, valid, ready)
    mi, mq, _, model = model_replay(dut.contract, inits, xi, xq, done)
    assert_same(name, xi, xq, hi, hq, mi, mq)
    return hi, hq, model


@pytest.mark.parametrize("slots", [1, 2])
@pytest.mark.parametrize("valid, ready", [((1,), (1,)), ((1, 1, 0), (1, 0, 1, 1))])
def test_fir_at_its_highest_rate_matches_model(valid, ready, slots):
    """Increments up to the largest the MAC can follow (J advances every 24
    samples), random full-scale words, every stall pattern: integer equal."""
    rng = np.random.default_rng(len(valid) + 10 * len(ready))
    inits = _inits(rng, 2)
    dut = WindFarmReplay(2, slots=slots, init=inits, **KW)
    T = 2500
    xi, xq = rng.integers(-32768, 32768, T), rng.integers(-32768, 32768, T)
    hi, _, _ = _check(dut, inits, xi, xq, valid=valid, ready=ready)
    # muted while the cache fills and the MAC computes after reset, then playing
    R = dut.contract.refill_samples
    assert np.count_nonzero(hi[dut.latency + R:]) > 0.9 * (T - dut.latency - R)


@pytest.mark.parametrize("slots", [1, 3])
def test_fir_saturates_both_ways_like_the_model(slots):
    """Full-scale words +, +, -, - (a tone at a quarter of the stream rate,
    its peaks between the words 41 % above full scale) overshoot in the FIR:
    its U values clip at both ends of the 16-bit range, integer equal to the
    model. The input is half scale, so the output itself does not clip and
    one LSB of U shows at the output."""
    L = 16
    square = np.where((np.arange(L) // 2) % 2 == 0, STREAM.max, STREAM.min)
    # the stream's unsaturated FIR sums (fixedpoint: U = sat(round(sum_k c[p][k] m[w + FIR_LEAD - k])))
    c = np.array(fir_coefficients(), dtype=np.int64)
    j = np.arange(L)
    sums = np.array([[sum(int(c[p, k]) * int(square[(w + FIR_LEAD - k) % L]) for k in range(c.shape[1]))
                      for w in j] for p in range(c.shape[0])])
    assert (sums > STREAM.max << FIR_COEF_FRAC).any() and (sums < STREAM.min << FIR_COEF_FRAC).any(), \
        "the stream does not overshoot: the test would not reach the saturation"
    words = pack_iq(square, -square)
    inits = [ChannelInit(tuple(int(w) for w in words), FIR_MAX_INCREMENT, 1 << 16, 0, True, 0)]
    dut = WindFarmReplay(1, slots=slots, init=inits, **KW)
    T = 5000                       # a word every 768 samples at this increment
    xi, xq = np.full(T, 1 << 14), np.zeros(T, dtype=np.int64)
    hi, hq, _ = _check(dut, inits, xi, xq, name="fir saturation")
    R = dut.latency + dut.contract.refill_samples
    # U at its rails (32767, -32768) times a half-scale input: the output's extremes
    assert hi[R:].max() >= (1 << 14) - 1 and hi[R:].min() <= -(1 << 14) + 1, \
        "the clipped U values do not reach the output"


@pytest.mark.slow
@pytest.mark.parametrize("seed, slots", [(1, 1), (2, 3)])
def test_fir_reloads_and_forced_switches_match_model(seed, slots):
    """Stream reloads into free pool space switching at the period boundary,
    forced switches (also in the middle of a refill), rate and length writes
    beyond the clamps."""
    from rast.sim.scenario import PoolTracker
    rng = np.random.default_rng(200 + seed)
    N = 2
    inits = _inits(rng, N, depth=16)
    dut = WindFarmReplay(N, slots=slots, init=inits, **KW)
    a = dut.register_map.addr
    pool = PoolTracker(dut.contract, [(i.base, len(i.words)) for i in inits])
    T = 3000
    xi, xq = rng.integers(-32768, 32768, T), rng.integers(-32768, 32768, T)
    ops = []
    for k in sorted(rng.integers(0, T, 40).tolist()):
        l = int(rng.integers(0, N))
        r = rng.integers(0, 6)
        length = int(rng.integers(1, 20))
        base = pool.place(l, max(length, 8)) if r == 0 else None
        if r == 0 and base is not None:  # reload, switch at the period boundary
            words = rng.integers(0, 1 << 32, max(length, 8))
            ops += [(k, "w", a("STREAM_ADDR"), base)]
            ops += [(k, "w", a("STREAM_DATA"), int(w)) for w in words]
            ops += [(k, "w", a("BASE", l), base), (k, "w", a("LENGTH", l), length),     # clamped to 8..
                    (k, "w", a("PHASE_INC", l), int(rng.integers(1 << 20, 1 << 32))),  # clamped
                    (k, "w", a("CRC", l), stream_crc32(words)),
                    (k, "w", a("CTRL", l), CTRL_ENABLE | CTRL_SWAP)]
        elif r == 1:                     # forced switch (disabled channel)
            ops += [(k, "w", a("CTRL", l), CTRL_SWAP), (k + 1, "w", a("CTRL", l), CTRL_ENABLE)]
            pool.forced_switch(l)
        elif r == 2:
            ops.append((k, "w", a("GAIN", l), int(rng.integers(0, 1 << 17))))
        elif r == 3:
            ops.append((k, "r", a("CTRL", l), 0))
        elif r == 4:
            ops.append((k, "r", a("PHASE_INC", l), 0))
        else:
            ops += [(k, "w", a("DELAY", l), int(rng.integers(0, 5))), (k, "w", a("APPLY"), 1)]
    ops.sort(key=lambda o: o[0])
    _check(dut, inits, xi, xq, ops, valid=(1, 1, 0), ready=(1, 1, 1, 0), name=f"fir stress {seed}")


def test_fir_clamps_rate_and_length():
    """Around each bound, and with the bound's upper half and a lower half
    above or below it (the register file compares the halves a clock
    apart)."""
    dut = WindFarmReplay(1, **KW)
    a = dut.register_map.addr
    top, low = FIR_MAX_INCREMENT & ~0xFFFF, FIR_MAX_INCREMENT & 0xFFFF
    cases = [("PHASE_INC", v, min(v, FIR_MAX_INCREMENT))
             for v in (1 << 31, FIR_MAX_INCREMENT - 1, FIR_MAX_INCREMENT, FIR_MAX_INCREMENT + 1,
                       top | 0xFFFF, top | (low - 1), top - 1, top + 0x10000, (1 << 32) - 1, 0)]
    cases += [("LENGTH", v, max(v, FIR_MIN_LENGTH)) for v in (3, 0, FIR_MIN_LENGTH - 1, FIR_MIN_LENGTH, FIR_MIN_LENGTH + 1)]
    ops = [op for k, (name, v, _) in enumerate(cases)
           for op in ((k, "w", a(name, 0), v), (k, "r", a(name, 0), 0))]
    T = len(cases) + 4
    hi, hq, done = run_replay(dut, np.zeros(T, np.int64), np.zeros(T, np.int64), ops, (1,), (1,))
    assert [v for k, kind, ad, v in done if kind == "r"] == [want for _, _, want in cases]


def test_fir_interpolates_a_band_limited_tone():
    """Independent of the model's code: a complex tone at 1/4 of the stream
    rate, replayed at 0.37 of the largest rate, equals the continuous tone at
    each sample's phase, up to one complex gain (the kernel's passband response
    at that frequency, within 0.05 dB), to within 12 LSB: the linear step's
    own error A*(2*pi*f/32)**2/8 = 6.9 LSB at f = 1/4 word^-1 plus the words',
    U's and the step's roundings. Holding the words is off by thousands."""
    L = 64
    amp = 0.7 * STREAM.max
    k = np.arange(L)
    tone = amp * np.exp(2j * np.pi * 16 * k / L)           # 16 cycles in 64 words: f = rate/4
    words = pack_iq(np.round(tone.real), np.round(tone.imag))
    inc = int(0.37 * FIR_MAX_INCREMENT)
    n = np.arange(200_000, dtype=np.int64)
    ph = (n * inc) % (L << PHASE_FRAC_BITS)
    exact = amp * np.exp(2j * np.pi * 16 * (ph / 2.0 ** PHASE_FRAC_BITS) / L)
    for mode, bound in (("fir", 12.0), ("hold", None)):
        wi, wq = dp.stream_words(mode, words, L, ph)
        got = wi + 1j * wq
        gain = np.vdot(exact, got) / np.vdot(exact, exact)
        err = np.abs(got - gain * exact).max()
        if bound is None:
            assert err > 5000, f"{mode}: {err}"
        else:
            assert abs(20 * np.log10(abs(gain))) < 0.05, f"{mode}: passband gain {abs(gain)}"
            assert err < bound, f"{mode}: max error {err:.2f} LSB"


def test_fir_table_passes_dc():
    """Every phase of the kernel has unit gain at DC: constant words give U
    equal to them, exactly, at every phase."""
    for c in (20000, -32768, 32767, 1):
        u = dp.fir_table(np.full(40, c), np.full(40, -c))
        assert (u[0] == c).all() and (u[1] == min(-c, 32767)).all()      # 32768 saturates
