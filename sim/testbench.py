"""Testbench building blocks shared by the cocotb modules ``sim/tb_*.py``.

* :class:`Scoreboard`: in-order comparison of integer sequences, reporting the
  first mismatch with its step, simulation time, channel/lane and both values
  (also written to ``failure.txt`` in the run directory, which the pytest
  side puts into its assertion message).
* :class:`StepBench`: clock, reset and a per-cycle driver/monitor for the
  components that advance on an ``en`` strobe (complex multiplier, delay
  line, stream replay). Short runs only: one Python ``await`` per cycle.
* :class:`BulkBench`: driver of the :mod:`rast.sim.bulk` wrapper (a C++
  clock or the wrapper's own, no Python per cycle; Python writes the stimulus
  files, raises ``start`` and waits for ``done``).
* :func:`stall_pattern`: the valid/ready/en patterns tests are parametrised with.
"""

from __future__ import annotations

import itertools
import json
import os
import random
from pathlib import Path

import numpy as np

__all__ = ["X_VALUE", "run_dir", "params", "stall_pattern", "STALL_PATTERNS", "Scoreboard", "Mismatch",
           "StepBench", "BulkBench"]


def run_dir() -> Path:
    return Path(os.environ.get("RAST_RUN_DIR", "."))


def params() -> dict:
    """The test's parameters, passed by the pytest side as JSON in ``RAST_TB_PARAMS``."""
    return json.loads(os.environ.get("RAST_TB_PARAMS", "{}"))


#: Named stall patterns (1 = the strobe is high in that cycle).
STALL_PATTERNS = {
    "none": None,              # always 1
    "1110": (1, 1, 1, 0),
    "10": (1, 0),
    "1000": (1, 0, 0, 0),
    "random": "random",        # 50 % with a fixed seed
}


def stall_pattern(name: str, seed: int = 0):
    """An endless iterator of 0/1 for a named pattern."""
    p = STALL_PATTERNS[name]
    if p is None:
        return itertools.repeat(1)
    if p == "random":
        rng = random.Random(seed)
        return iter(lambda: rng.random() < 0.5, None)
    return itertools.cycle(p)


#: Stands for an output with X/Z bits (4-state simulators); never equals a model value.
X_VALUE = -(1 << 62)


def _fmt(v: int) -> str:
    return "X" if v <= X_VALUE // 2 else f"{v} (0x{v & 0xFFFFFFFF:x})"


class Mismatch(AssertionError):
    pass


class Scoreboard:
    """In-order checker: expected and observed sequences as integer arrays.

    ``lanes`` maps a lane name (e.g. ``"I"``, ``"Q"``, ``"ch2.I"``) to the
    pair ``(got, expected)``; ``times_ns`` (optional) gives the simulation time
    of each observed sample, ``index`` its step number (default 0..n-1).
    """

    def __init__(self, name: str, *, sample_rate_hz: float | None = None, context=None):
        self.name = name
        self.sample_rate_hz = sample_rate_hz
        self.context = context          # callable(step) -> str with the inputs of that step
        self.compared = 0
        self.mismatches = 0

    def check(self, lanes: dict, *, times_ns=None, index=None, channel_of=None) -> None:
        first = None
        n = None
        arrays = {}
        for lane, (got, exp) in lanes.items():
            got = np.asarray(got, dtype=np.int64)
            exp = np.asarray(exp, dtype=np.int64)
            if got.shape != exp.shape:
                self._fail(f"{self.name}: lane {lane}: {got.size} samples observed, "
                           f"{exp.size} expected")
            n = got.size
            arrays[lane] = (got, exp)
            bad = np.nonzero(got != exp)[0]
            self.mismatches += int(bad.size)
            if bad.size and (first is None or bad[0] < first[0]):
                first = (int(bad[0]), lane, int(got[bad[0]]), int(exp[bad[0]]), int(bad.size))
        self.compared += n or 0
        if first is None:
            return
        k, lane, g, e, count = first
        step = int(index[k]) if index is not None else k
        where = [f"step {step}"]
        if self.sample_rate_hz:
            where.append(f"radar time {step / self.sample_rate_hz * 1e6:.3f} us")
        if times_ns is not None:
            where.append(f"sim time {int(times_ns[k])} ns")
        chan = channel_of(k, lane) if channel_of else lane
        msg = [f"{self.name}: first mismatch at {', '.join(where)}, channel {chan}: "
               f"RTL {_fmt(g)}, model {_fmt(e)}; "
               f"{self.mismatches} mismatching values in {self.compared} samples "
               f"x {len(lanes)} lanes"]
        g_arr, e_arr = arrays[lane]
        lo, hi = max(0, k - 3), min(g_arr.size, k + 5)
        msg.append(f"lane {lane} steps {lo}..{hi - 1}: RTL {g_arr[lo:hi].tolist()} "
                   f"model {e_arr[lo:hi].tolist()}")
        if self.context:
            msg.append("inputs: " + str(self.context(step)))
        self._fail("\n".join(msg))

    def _fail(self, text: str):
        try:
            (run_dir() / "failure.txt").write_text(text + "\n")
        except OSError:
            pass
        raise Mismatch(text)


class StepBench:
    """Per-cycle driver for an ``en``-strobed component (clock ``clk``, reset ``rst``).

    Each call of :meth:`step` drives the given inputs during one clock cycle
    with ``en`` from the stall pattern, and returns the outputs sampled in that
    cycle (before the clock edge): the values "visible during" that cycle.
    """

    def __init__(self, dut, *, en_pattern: str = "none", seed: int = 0, period_ns: int = 10):
        self.dut = dut
        self.period_ns = period_ns
        self.en = stall_pattern(en_pattern, seed)
        self.cycle = 0

    async def start(self, reset_cycles: int = 3, idle: dict | None = None):
        import cocotb
        from cocotb.clock import Clock
        from cocotb.triggers import ClockCycles, FallingEdge
        Clock(self.dut.clk, self.period_ns, unit="ns").start()
        self.dut.rst.value = 1
        self.dut.en.value = 0
        for k, v in (idle or {}).items():
            getattr(self.dut, k).value = v
        await ClockCycles(self.dut.clk, reset_cycles)
        await FallingEdge(self.dut.clk)
        self.dut.rst.value = 0
        await FallingEdge(self.dut.clk)

    async def cycle_with(self, inputs: dict, outputs: tuple, en: int) -> dict:
        """Drive ``inputs`` and ``en`` for one cycle; return ``outputs`` (signed ints
        for names in ``self.signed``) read in that cycle."""
        from cocotb.triggers import FallingEdge, ReadOnly
        for k, v in inputs.items():
            getattr(self.dut, k).value = v
        self.dut.en.value = en
        await ReadOnly()
        got = {}
        for k in outputs:
            v = getattr(self.dut, k).value
            got[k] = int(v) if v.is_resolvable else X_VALUE

        await FallingEdge(self.dut.clk)
        self.cycle += 1
        return got

    async def steps(self, inputs_per_step: list, outputs: tuple):
        """Drive one input dict per enabled step, idling (en=0) where the pattern says.

        Returns ``(observed, times_ns)``: per step, the outputs visible during it.
        """
        from cocotb.utils import get_sim_time
        observed, times = [], []
        k = 0
        while k < len(inputs_per_step):
            en = next(self.en)
            if en:
                got = await self.cycle_with(inputs_per_step[k], outputs, 1)
                observed.append(got)
                times.append(get_sim_time("ns"))
                k += 1
            else:
                await self.cycle_with({}, outputs, 0)
        return observed, np.array(times)


class BulkBench:
    """Drives the :mod:`rast.sim.bulk` wrapper: write files, start, wait for done."""

    def __init__(self, dut):
        self.dut = dut

    #: clock cycles without an input taken or an output given after which
    #: ``run(..., timeout_s=...)`` gives up
    STUCK_CYCLES = 100_000

    async def run(self, job, *, n_out=None, timeout_s: float | None = None, progress: bool = False):
        """Run ``job`` (a :class:`rast.sim.bulk.BulkJob`) and return the
        wrapper's summary with ``wall_s``, the wall-clock time from ``start``
        to ``done``, and ``cpu_s``, this process's CPU time in it.
        ``timeout_s`` set: give up when neither the input nor the output
        count moved for :attr:`STUCK_CYCLES` clock cycles (whatever the
        engine's clocks per sample)."""
        import sys
        import time
        from cocotb.triggers import SimTimeoutError, Timer
        from rast.sim import bulk
        d = run_dir()
        bulk.write_job(job, d, n_out=n_out)
        clock = os.environ.get(bulk.CLOCK_ENV, "")
        if clock:
            # built with runner.BULK_VERILATOR_ARGS: cocotb's clock in C++ (GPI), no Python per edge
            from cocotb.clock import Clock
            Clock(self.dut.tick if clock == "burst" else self.dut.clk, bulk.CLOCK_PERIOD_NS, "ns",
                  impl="gpi").start()
        # simulated ns per clock cycle of the wrapper: a burst clock runs
        # BURST_CYCLES cycles at each of its edges, two per period
        half_ns = bulk.CLOCK_PERIOD_NS // 2
        cycles_per_half = bulk.BURST_CYCLES if clock == "burst" else 0.5
        self.dut.start.value = 0
        await Timer(4 * half_ns, "ns")
        t0, c0 = time.monotonic(), time.process_time()
        self.dut.start.value = 1
        # Poll ``done`` with timers instead of awaiting its edge: a value-change
        # callback makes Verilator's VPI compare the signal after every
        # evaluation (docs/cosim_speed.md); done only ends the job, so a
        # poll a little late costs idle cycles, nothing else.
        step = min(max(job.n_in // 256, 256), 65536)
        halves = max(1, -(-step // cycles_per_half))
        step = int(halves * cycles_per_half)
        waited, still, seen = 0, 0, None
        report_every, next_report = 2_000_000, 2_000_000
        while not int(self.dut.done.value):
            if timeout_s is not None:
                counts = (int(self.dut.in_idx.value), int(self.dut.out_idx.value))
                still = still + step if counts == seen else 0
                seen = counts
                if still >= self.STUCK_CYCLES:
                    raise SimTimeoutError(f"the bulk job is stuck: no input taken and no output given in "
                                          f"{still:,} clock cycles ({counts[0]:,} in, {counts[1]:,} out of "
                                          f"{job.n_in:,}, {waited:,} cycles after start)")
            await Timer(int(halves) * half_ns, "ns")
            waited += step
            if progress and waited >= next_report:
                next_report += report_every
                done_in = int(self.dut.in_idx.value)
                el = time.monotonic() - t0
                print(f"[rast cosim] {done_in / job.n_in:6.1%}  {done_in:>11,d}/{job.n_in:,d} samples  "
                      f"{el:6.1f} s  {done_in / max(el, 1e-9):9,.0f} samples/s",
                      file=sys.stderr, flush=True)
        wall, cpu = time.monotonic() - t0, time.process_time() - c0
        summary = bulk.read_summary(d)
        summary["wall_s"] = wall
        # the simulator's CPU time (this process: Verilator and cocotb; not a forked model),
        # which a busy machine inflates less than the wall-clock time
        summary["cpu_s"] = cpu
        (d / "perf.json").write_text(json.dumps(summary))
        return summary
