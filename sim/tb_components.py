"""cocotb testbenches of the replay block's components, against the bit-exact model.

Run from ``tests/test_cosim_components.py``; parameters arrive as JSON in
``RAST_TB_PARAMS`` (see :func:`rast.sim.testbench.params`). Every output is
compared as an integer from step 0 (the pipelines reset to zero, the model's
history before step 0 is zero).
"""

from __future__ import annotations

import cocotb
import numpy as np

from rast.model import datapath as dp
from rast.model.fixedpoint import PHASE_FRAC_BITS, INTERP_FRAC_BITS, unpack_iq
from rast.sim.testbench import X_VALUE, Scoreboard, StepBench, params

ONE = 1 << PHASE_FRAC_BITS


def _signed(v, width):
    v = np.asarray(v, dtype=np.int64)
    return ((v & ((1 << width) - 1)) ^ (1 << (width - 1))) - (1 << (width - 1))


def _iq(o, width):
    """Signed I (low) and Q of packed outputs; X (unresolvable) stays X in both."""
    o = np.asarray(o, dtype=np.int64)
    x = o == X_VALUE
    i, q = _signed(o, width), _signed(o >> width, width)
    i[x] = X_VALUE
    q[x] = X_VALUE
    return i, q


def _pack(i, q, width):
    m = (1 << width) - 1
    return ((int(q) & m) << width) | (int(i) & m)


# ---------------------------------------------------------------------------
# Complex multiplier

def cmult_vectors(n: int, seed: int, width: int = 16, shift: int = 15):
    """Corner operands first (every combination of -2**(W-1) and 2**(W-1)-1 and 0),
    then rounding ties of both signs, then uniform random values."""
    lo, hi = -(1 << (width - 1)), (1 << (width - 1)) - 1
    corners = [lo, hi, 0, -1, 1]
    vec = []
    for ai in (lo, hi, 0):
        for aq in (lo, hi, 0):
            for bi in (lo, hi, -1):
                for bq in (lo, hi, 1):
                    vec.append((ai, aq, bi, bq))
    # exact ties: re = ±2**(shift-1) (+ k·2**shift), im likewise
    half = 1 << (shift - 1)
    for k in (0, 1, -1, 3, -4):
        vec.append((half // 1, 0, 1 + 2 * k, 0))       # re = half·(1+2k): a tie for every k
        vec.append((-half, 0, 1 + 2 * k, 0))
        vec.append((0, half, 0, 1 + 2 * k))            # re = -half·(1+2k)
        vec.append((half, 0, 0, 1 + 2 * k))            # im tie
    rng = np.random.default_rng(seed)
    r = rng.integers(lo, hi + 1, size=(max(0, n - len(vec)), 4))
    vec += [tuple(map(int, row)) for row in r]
    del corners
    return vec


@cocotb.test()
async def cmult(dut):
    p = params()
    width, shift, lat = p["width"], p["shift"], p["latency"]
    o_width = 2 * width + 1 - shift
    vec = cmult_vectors(p["n"], p["seed"], width, shift)
    ai, aq, bi, bq = (np.array(c, dtype=np.int64) for c in zip(*vec))
    ei, eq = dp.cmult(ai, aq, bi, bq, shift)
    bench = StepBench(dut, en_pattern=p["en_pattern"], seed=p["seed"])
    await bench.start(idle={"a": 0, "b": 0})
    steps = [{"a": _pack(v[0], v[1], width), "b": _pack(v[2], v[3], width)} for v in vec]
    steps += [{"a": 0, "b": 0}] * lat
    obs, times = await bench.steps(steps, ("o",))
    o = np.array([s["o"] for s in obs], dtype=np.int64)
    gi, gq = _iq(o, o_width)
    exp_i = np.concatenate([np.zeros(lat, np.int64), ei])
    exp_q = np.concatenate([np.zeros(lat, np.int64), eq])

    def ctx(step):
        k = step - lat
        return f"a=({vec[k][0]},{vec[k][1]}) b=({vec[k][2]},{vec[k][3]})" if 0 <= k < len(vec) else "reset"
    Scoreboard(f"cmult[{p['form']}]", context=ctx).check({"I": (gi, exp_i), "Q": (gq, exp_q)},
                                                        times_ns=times)


# ---------------------------------------------------------------------------
# Delay line

def delay_schedule(n: int, max_delay: int, seed: int):
    """Per-step programmed delay: every delay class held for a while, then
    run-time changes every few steps (up, down, extremes)."""
    rng = np.random.default_rng(seed)
    d = []
    classes = sorted({0, 1, 2, 3, max_delay // 2, max_delay - 1, max_delay} & set(range(max_delay + 1)))
    for c in classes:                       # each class long enough to flush the pipeline
        d += [c] * (max_delay + 8)
    for c in range(max_delay + 1):          # every value once, briefly
        d += [c] * 3
    while len(d) < n:                       # random changes at run time
        d += [int(rng.integers(0, max_delay + 1))] * int(rng.integers(1, 12))
    return np.array(d, dtype=np.int64)


@cocotb.test()
async def delay_line(dut):
    p = params()
    width, max_delay = p["width"], p["max_delay"]
    d = delay_schedule(p["n"], max_delay, p["seed"])
    rng = np.random.default_rng(p["seed"] + 1)
    x = rng.integers(0, 1 << width, size=d.size, dtype=np.int64)
    exp = dp.delay_line(x, d)
    bench = StepBench(dut, en_pattern=p["en_pattern"], seed=p["seed"])
    await bench.start(idle={"i": 0, "delay": 0})
    obs, times = await bench.steps([{"i": int(a), "delay": int(b)} for a, b in zip(x, d)], ("o",))
    got = np.array([s["o"] for s in obs], dtype=np.int64)

    def ctx(step):
        return f"delay[{step - 3}]={d[step - 3] if step >= 3 else None}"
    Scoreboard(f"delay_line[max {max_delay}]", context=ctx).check({"o": (got, exp)}, times_ns=times)


# ---------------------------------------------------------------------------
# Stream replay

class StreamRef:
    """Step model of the stream replay state (the rule in its docstring): the
    stream is ``length`` pool words from ``base``; after reset and every
    switch the phase is held at 0 and the word is 0 for ``refill`` steps."""

    def __init__(self, pool_words, refill):
        self.pool = np.zeros(pool_words, dtype=np.int64)
        self.refill_samples = refill
        self.refill = refill
        self.bank = 0
        self.base = 0
        self.idx = 0
        self.frac = 0
        self.length = 1
        self.inc = 0
        self.pending = 0

    def switch(self, base, length, inc):
        self.bank ^= 1
        self.base, self.length, self.inc = base, length, inc
        self.idx = self.frac = 0
        self.pending = 0
        self.refill = self.refill_samples

    def step(self, next_base, next_length, next_inc):
        if self.refill:
            self.refill -= 1
            return
        acc = self.frac + self.inc
        carry = acc >> PHASE_FRAC_BITS
        wrap = carry and self.idx == self.length - 1
        if self.pending and wrap:
            self.switch(next_base, next_length, next_inc)
        elif wrap:
            self.idx, self.frac = 0, acc & (ONE - 1)
        else:
            self.idx, self.frac = self.idx + carry, acc & (ONE - 1)

    def word(self, interpolation):
        if self.refill:
            return 0, 0
        b = self.pool[self.base:self.base + self.length]
        wi, wq = unpack_iq(b[self.idx])
        if interpolation == "hold":
            return int(wi), int(wq)
        j = 0 if self.idx + 1 == self.length else self.idx + 1
        w1i, w1q = unpack_iq(b[j])
        return (int(dp.interpolate_words(wi, w1i, self.frac)),
                int(dp.interpolate_words(wq, w1q, self.frac)))


@cocotb.test()
async def stream_replay(dut):
    p = params()
    depth, interp, lat = p["depth"], p["interpolation"], p["latency"]
    rng = np.random.default_rng(p["seed"])
    ref = StreamRef(depth, p["refill"])
    bench = StepBench(dut, en_pattern=p["en_pattern"], seed=p["seed"])
    idle = {"base": 0, "length": 1, "increment": 0, "swap_req": 0, "swap_force": 0, "wr_en": 0,
            "wr_addr": 0, "wr_data": 0}
    await bench.start(idle=idle)

    async def control(**kw):           # one cycle with en = 0
        await bench.cycle_with({**idle, **kw}, (), 0)

    async def load(base, words):
        for a, w in enumerate(words):
            await control(wr_en=1, wr_addr=base + a, wr_data=int(w))
            ref.pool[base + a] = int(w)

    def random_words(n):
        # include the extreme words so interpolation differences reach 2**16 - 1
        w = rng.integers(0, 1 << 32, size=n, dtype=np.int64)
        w[0] = 0x8000_7FFF
        if n > 1:
            w[1] = 0x7FFF_8000
        return w

    got, exp, times, phases = [], [], [], []
    state_hist = []
    rtl_state = []

    async def run(n, base, length, inc):
        nonlocal got
        obs, t = await bench.steps([{**idle, "base": base, "length": length, "increment": inc}] * n,
                                   ("o", "index", "bank", "active_length"))
        for s in obs:
            rtl_state.append((s["bank"], s["index"], s["active_length"]))
            state_hist.append(ref.word(interp))
            phases.append((ref.bank, ref.idx, ref.frac))
            ref.step(base, length, inc)
            got.append(s["o"])
        times.extend(t)

    # 1: a stream at the pool's start forced active, a length that is not a
    #    power of two, a rate that does not divide 2**32 (wrap with a carried fraction)
    L1 = int(p["length1"])
    inc1 = int(p["inc1"])
    B2 = depth // 2
    await load(0, random_words(L1))
    await control(base=0, length=L1, increment=inc1, swap_force=1)
    ref.switch(0, L1, inc1)
    await run(p["n1"], 0, L1, inc1)
    # 2: new words into the pool's second half, new length/rate, switch at the period boundary
    L2 = int(p["length2"])
    inc2 = int(p["inc2"])
    await load(B2, random_words(L2))
    await control(base=B2, length=L2, increment=inc2, swap_req=1)
    ref.pending = 1
    await run(p["n2"], B2, L2, inc2)
    assert ref.bank == 0, "the test never reached the period boundary that switches streams"
    # o during step n is the word of the state of step n - latency; the first
    # `lat` steps of each run show the previous word and are checked from the
    # continuous sequence (states recorded across control cycles).
    hist = np.array(state_hist, dtype=np.int64)
    o = np.array(got, dtype=np.int64)
    gi, gq = _iq(o, 16)
    ei, eq = hist[:-lat, 0], hist[:-lat, 1]

    def ctx(step):
        b, i, f = phases[step - lat]
        rb, ri, rl = rtl_state[step - lat]
        return (f"model state {lat} steps earlier: bank {b} index {i} frac 0x{f:08x}; "
                f"RTL then: bank {rb} index {ri} length {rl}")
    Scoreboard(f"stream_replay[{interp}]", context=ctx).check(
        {"I": (gi[lat:], ei), "Q": (gq[lat:], eq)},
        times_ns=np.array(times)[lat:], index=np.arange(lat, o.size))
