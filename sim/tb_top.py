"""cocotb testbench of the wind-farm top through the bulk wrapper (``rast.sim.bulk``).

The scenario (stimulus, register script, capture plan) is rebuilt here from
the parameters in ``RAST_TB_PARAMS`` (deterministic in the seed); the
wrapper runs it without Python in the loop; the scoreboard then compares
every output sample with the bit-exact model as integers, and the wrapper's
checksums, sample counts and the sticky overflow flag with the model's.
"""

from __future__ import annotations

import json

import cocotb
import numpy as np

from rast.sim import bulk
from rast.sim.scenario import Scenario, farm_scenario, model_outputs, random_scenario, worst_fetch_scenario
from rast.sim.testbench import BulkBench, Scoreboard, params, run_dir

__all__ = ["scenario_from_params", "check_bulk_run", "check_sdram_flags"]


def scenario_from_params(p: dict) -> Scenario:
    if p["kind"] == "worst":
        return worst_fetch_scenario(p["channels"], p["seed"], interpolation=p.get("interpolation", "linear"),
                                    pulses=p.get("pulses", 80), gap_thresh=p["gap_thresh"],
                                    stall_thresh=p["stall_thresh"], contract=p.get("contract"))
    if p["kind"] == "farm":
        return farm_scenario(p["channels"], p["seed"], pulses=p.get("pulses", 30), gap_thresh=p["gap_thresh"],
                             stall_thresh=p["stall_thresh"], contract=p.get("contract"))
    return random_scenario(p["channels"], p["seed"], kind=p["kind"], interpolation=p.get("interpolation", "fir"),
                           gap_thresh=p["gap_thresh"], stall_thresh=p["stall_thresh"],
                           pulses=p.get("pulses", 40), contract=p.get("contract"))


def check_bulk_run(sc: Scenario, summary: dict, *, expected=None, overflow_observed=None,
                   min_active=None) -> dict:
    """Scoreboard a finished bulk run of ``sc``; returns a small report dict.
    ``min_active``: the fewest non-zero model outputs that show the scenario
    exercises the block (default: 2 % of them; a radar's pulse train sets its
    own, its echoes filling only the pulses' duty cycle)."""
    d = run_dir()
    yi, yq, ovf = expected if expected is not None else model_outputs(sc)
    sb = Scoreboard(sc.name, sample_rate_hz=sc.sample_rate_hz)
    if summary.get("x_count", 0):
        sb._fail(f"{sc.name}: {summary['x_count']} output samples had X/Z bits")
    if summary["timeout"] or summary["out"] != len(yi):
        sb._fail(f"{sc.name}: RTL produced {summary['out']} outputs for {summary['in']} inputs, "
                 f"model {len(yi)} (timeout={summary['timeout']})")
    cyc, idx, gi, gq = bulk.read_outputs(d)
    if sc.job.cap_offsets is None:
        sb.check({"I": (gi, yi), "Q": (gq, yq)}, times_ns=cyc * bulk.CLOCK_PERIOD_NS, index=idx)
    else:
        sb.check({"I": (gi, yi[idx]), "Q": (gq, yq[idx])}, times_ns=cyc * bulk.CLOCK_PERIOD_NS, index=idx)
    active = int(np.count_nonzero((yi != 0) | (yq != 0)))
    if active < (len(yi) // 50 if min_active is None else min_active):
        sb._fail(f"{sc.name}: only {active} of {len(yi)} model outputs are non-zero: "
                 "the scenario exercises nothing")
    want = bulk.checksums(yi, yq)
    got = {k: summary[k] for k in want}
    if got != want:
        sb._fail(f"{sc.name}: checksums of all {len(yi)} outputs differ: RTL {got}, model {want}")
    if overflow_observed is not None and overflow_observed != ovf:
        sb._fail(f"{sc.name}: sticky overflow flag RTL {overflow_observed}, model {ovf}")
    report = dict(name=sc.name, compared=int(sb.compared), checksummed=len(yi), mismatches=int(sb.mismatches),
                  nonzero=active,
                  overflow=ovf, cycles=summary["cycles"], samples=summary["in"],
                  wall_s=summary["wall_s"], samples_per_s=summary["in"] / max(summary["wall_s"], 1e-9))
    (d / "report.json").write_text(json.dumps(report))
    return report


@cocotb.test()
async def replay_bulk(dut):
    p = params()
    sc = scenario_from_params(p)
    summary = await BulkBench(dut).run(sc.job, timeout_s=600)
    rep = check_bulk_run(sc, summary, overflow_observed=summary.get("obs_overflow"))
    if p["kind"] == "saturate":
        assert rep["overflow"] == 1, "saturation scenario did not saturate: the test would prove nothing"
    cocotb.log.info("%s", rep)


@cocotb.test()
async def replay_bulk_sdram(dut):
    """The same with the engine's pool in SDRAM (:func:`check_sdram_flags` too)."""
    p = params()
    sc = scenario_from_params(p)
    summary = await BulkBench(dut).run(sc.job, timeout_s=1800)
    check_sdram_flags(sc.name, summary)             # before the samples: a late word says why
    rep = check_bulk_run(sc, summary, overflow_observed=summary.get("obs_overflow"))
    cocotb.log.info("%s", rep)


def check_sdram_flags(name: str, summary: dict) -> None:
    """The SDRAM engine's flags at the end of a run: no underflow (a word read
    before it arrived), no pool error, LiteDRAM initialised without error."""
    flags = {k: summary.get(f"obs_{k}") for k in ("underflow", "pool_error", "init_done", "init_error")}
    want = {"underflow": 0, "pool_error": 0, "init_done": 1, "init_error": 0}
    if flags != want:
        raise AssertionError(f"{name}: SDRAM flags at the end {flags}, want {want}"
                             + (" (underflow: a channel read a stream word before it arrived)"
                                if flags["underflow"] else ""))
