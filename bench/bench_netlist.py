"""Netlist cosimulation vs behavioural cosimulation: build time and simulated samples per second.

Runs one random scenario (register sequences with reloads, valid gaps and
ready stalls) of the replay top at the default build's depths twice, under
cocotb + Verilator and the bulk wrapper, the same job and scoreboard:

1. the behavioural Verilog (``rast.sim.top.top_sources``), what the other
   cosimulations run;
2. the netlist after ``synth_ecp5`` with the ECP5 cell models
   (``rast.sim.netlist.replay_netlist_sources``).

Prints, per design: Yosys time (netlist only, 0 when cached), Verilator build
time (0 when cached), samples, simulation wall time from ``start`` to
``done`` and samples per second; and the ratio. Both runs must pass the
scoreboard (every sample equal to the model).

    .venv/bin/python bench/bench_netlist.py [--channels 1] [--pulses 400]
"""

from __future__ import annotations

import argparse
import json
import time

from rast.gateware.build import BuildConfig
from rast.sim import runner
from rast.sim.netlist import replay_netlist_sources
from rast.sim.top import top_sources


def _measure(label, make_sources, channels, contract, pulses, seed):
    t0 = time.monotonic()
    sources, top = make_sources(channels, interpolation="fir", **contract)
    prep = time.monotonic() - t0
    b = runner.build(sources, top, simulator="verilator", bulk=True, label=f"bench-{label}")
    params = dict(kind="random", channels=channels, seed=seed, gap_thresh=48, stall_thresh=48,
                  pulses=pulses, contract=contract)
    d = runner.run(b, "rast.sim.tb_top", name=f"bench-{label}", testcase="replay_bulk", quiet=True,
                   extra_env={"RAST_TB_PARAMS": json.dumps(params)})
    rep = json.loads((d / "report.json").read_text())
    return dict(design=label, prepare_s=round(prep, 1), build_s=round(b.build_seconds, 1),
                samples=rep["samples"], mismatches=rep["mismatches"], sim_wall_s=round(rep["wall_s"], 2),
                samples_per_s=round(rep["samples_per_s"]))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--channels", type=int, default=1)
    ap.add_argument("--pulses", type=int, default=400, help="PRIs of 240 samples (default 400)")
    ap.add_argument("--seed", type=int, default=21)
    args = ap.parse_args(argv)
    d = BuildConfig()
    contract = dict(pool_words=d.pool_words, max_delay=d.max_delay, max_tap=d.max_tap)
    rows = [_measure("behavioural", top_sources, args.channels, contract, args.pulses, args.seed),
            _measure("netlist", replay_netlist_sources, args.channels, contract, args.pulses, args.seed)]
    print(f"replay top, {args.channels} channel(s), default build depths, FIR, {args.pulses} PRIs of 240 samples")
    print(f"{'design':<12} {'Yosys+gen s':>11} {'build s':>8} {'samples':>9} {'sim s':>7} {'samples/s':>10}")
    for r in rows:
        print(f"{r['design']:<12} {r['prepare_s']:>11} {r['build_s']:>8} {r['samples']:>9} {r['sim_wall_s']:>7} "
              f"{r['samples_per_s']:>10}")
    print(f"netlist / behavioural simulation speed: {rows[1]['samples_per_s'] / rows[0]['samples_per_s']:.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
