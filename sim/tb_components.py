"""cocotb testbenches of the replay block's components, against the bit-exact model.

Run from ``tests/test_cosim_components.py``; parameters arrive as JSON in
``RAST_TB_PARAMS`` (see :func:`rast.sim.testbench.params`). Every output is
compared as an integer from step 0 (the pipelines reset to zero, the model's
history before step 0 is zero).
"""

from __future__ import annotations

import cocotb
import numpy as np

from rast.model.contract import datapath as dp
from rast.sim.testbench import X_VALUE, Scoreboard, StepBench, params, stall_pattern



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
    """The step-indexed line as the engine drives it: a step (where the stall
    pattern allows) writes x[k] at index k and asks for step k at the delay
    of the schedule in the same clock; in other clocks nothing is written and
    the read repeats. The answer for step k is ``o`` ``latency`` clocks
    later: x[k - lag - d[k]], zero before step 0."""
    from cocotb.clock import Clock
    from cocotb.triggers import ClockCycles, FallingEdge, ReadOnly
    p = params()
    width, max_delay, lag, depth, lat = p["width"], p["max_delay"], p["lag"], p["depth"], p["latency"]
    d = delay_schedule(p["n"], max_delay, p["seed"])
    rng = np.random.default_rng(p["seed"] + 1)
    x = rng.integers(0, 1 << width, size=d.size, dtype=np.int64)
    exp = dp.delay_line(x, d, lag)
    en = stall_pattern(p["en_pattern"], p["seed"])
    Clock(dut.clk, 10, unit="ns").start()
    dut.rst.value = 1
    for name in ("w_en", "w_index", "w_data", "r_index", "r_delay"):
        getattr(dut, name).value = 0
    await ClockCycles(dut.clk, 3)
    await FallingEdge(dut.clk)
    dut.rst.value = 0
    asked = {}                   # clock -> step asked in it
    got = np.full(d.size, X_VALUE, dtype=np.int64)
    k = clock = 0
    while k < d.size or clock - lat <= max(asked):
        await FallingEdge(dut.clk)
        step = k < d.size and next(en, True)
        dut.w_en.value = int(step)
        if step:
            dut.w_index.value = dut.r_index.value = k % depth
            dut.w_data.value = int(x[k])
            dut.r_delay.value = int(d[k])
            asked[clock] = k
            k += 1
        await ReadOnly()
        if clock - lat in asked:
            v = dut.o.value
            got[asked[clock - lat]] = int(v) if v.is_resolvable else X_VALUE
        clock += 1

    def ctx(step):
        return f"x[{step}] read at delay {d[step]}"
    Scoreboard(f"delay_line[max {max_delay}, lag {lag}]", context=ctx).check({"o": (got, exp)})
