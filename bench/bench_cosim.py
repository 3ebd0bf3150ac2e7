"""Cosimulation speed: the cocotb path against a bare Verilator C++ harness, same Verilog, same job.

For each ``--slots`` M (fabric clocks per RTS sample of the time-multiplexed
engine; M = 1 is one sample per clock, the default bitstream has M = 10)
the replay top inside the bulk wrapper (``rast.sim.bulk``) runs the same job
twice, in one invocation:

1. under cocotb + Verilator (``rast.sim.tb_e2e.bench``): Python writes the
   stimulus files, raises ``start`` and waits for ``done``; cocotb's GPI clock
   (C++) drives the wrapper's clock port, no Python runs per sample
   (``docs/cosim_speed.md``: where the time goes);
2. in a bare Verilator C++ harness (``sim/harness/main.cpp``): no Python, no
   VPI, the same clock port toggled from C++.

Both runs must end with identical output checksums and counts (every output
sample enters them): the exit status is 1 otherwise. The job is the
end-to-end one: ``--seconds`` of radar time of sampled pulses (seed Table 4.1
chirp) for the config's farm, every RTS sample through the DUT. ``--repeat``
runs both paths again on the same builds (alternating) and prints ranges: the
machine is shared, so read figures of one run against each other; the CPU
time of each path is printed too (the busy machine inflates it less).

``--clocks``: each job is run with the wrapper clocked in bursts (``burst``,
what ``rast.sim.runner`` builds now: each edge of the GPI clock runs 256
cycles in one evaluation) and one cycle per period (``clk``, the clocking
before, still used with waves), both paths built the same way each time: the
printed "before" and "now" of one run.

    .venv/bin/python bench/bench_cosim.py [--config C] [--slots 1,10] [--clocks burst,clk] [--seconds 0.2]
                                          [--repeat 3]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

CLOCKS = {"burst": "GPI clock on tick, BURST_CYCLES clock cycles per edge, one time slot",
          "clk": "GPI clock on clk, one clock cycle per period, two time slots"}
CHECKSUMS = ("in", "out", "s1_i", "s2_i", "s1_q", "s2_q")


def _clocks(text: str) -> list[str]:
    vals = [v.strip() for v in text.split(",") if v.strip()]
    if not vals or any(v not in CLOCKS for v in vals):
        raise argparse.ArgumentTypeError(f"clocks are {', '.join(CLOCKS)} separated by commas, not {text!r}")
    return vals


def _slots(text: str) -> list[int]:
    try:
        vals = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"slots must be integers separated by commas, not {text!r}")
    if not vals or any(v < 1 for v in vals):
        raise argparse.ArgumentTypeError(f"slots must be positive integers, not {text!r}")
    return vals


def _rng(vals, scale=1.0, fmt="{:.2f}") -> str:
    lo, hi = min(vals) / scale, max(vals) / scale
    return fmt.format(lo) if fmt.format(lo) == fmt.format(hi) else f"{fmt.format(lo)}-{fmt.format(hi)}"


def bench_slots(args, slots: int) -> list[dict]:
    from rast.sim import bulk, runner
    from rast.sim.e2e import prepare
    from rast.sim.harness.build import build_harness
    from rast.sim.top import top_sources

    config = str(Path(args.config).resolve())
    e = prepare(config, args.seconds, channels=args.channels, slots=slots)
    c = e.scenario.contract
    sources, top = top_sources(c.channels, slots=c.slots, pool_words=c.pool_words, max_delay=c.max_delay,
                               max_tap=c.max_tap, interpolation=c.interpolation)
    print(f"\n== slots M = {c.slots}: {Path(config).name}, {c.channels} channels in {c.pipelines} "
          f"pipeline(s) of {c.slots} slot(s), {e.pulse.n_pulses} pulses = {args.seconds:g} s of radar time, "
          f"{e.info['samples']:,} RTS samples at {e.farm.sample_rate_mhz:g} MHz", flush=True)
    params = dict(config=config, seconds=args.seconds, channels=args.channels, slots=c.slots)
    jobs = []
    for clock in args.clocks:
        t = time.monotonic()
        b = runner.build(sources, top, simulator="verilator", waves=False, label=f"bench{c.channels}m{c.slots}",
                         bulk=True, bulk_clock=clock, build_args=tuple(args.verilator_arg))
        cocotb_build = time.monotonic() - t
        t = time.monotonic()
        exe = build_harness(sources, top, extra_args=tuple(args.verilator_arg), clock=clock)
        harness_build = time.monotonic() - t
        print(f"clock {clock!r} ({CLOCKS[clock]}): builds: cocotb "
              f"{'cached' if b.build_seconds == 0 else f'{cocotb_build:.0f} s'}, bare harness "
              f"{harness_build:.0f} s incl. cache check", flush=True)
        hdir = exe.parent.parent / "run"
        runs = []
        for k in range(args.repeat):
            t = time.monotonic()
            run_dir = runner.run(b, "rast.sim.tb_e2e",
                                 name=f"bench-{c.channels}ch-m{c.slots}-{clock}-{args.seconds:g}s",
                                 testcase="bench", extra_env={"RAST_TB_PARAMS": json.dumps(params)}, quiet=True)
            cocotb_process = time.monotonic() - t
            cb = json.loads((run_dir / "bench.json").read_text())
            if hdir.exists():
                shutil.rmtree(hdir)
            hdir.mkdir()
            bulk.write_job(e.scenario.job, hdir)      # the same job files the cocotb run wrote
            t = time.monotonic()
            out = subprocess.run([str(exe)], cwd=hdir, capture_output=True, text=True, check=True)
            harness_process = time.monotonic() - t
            hb = json.loads(out.stdout.strip().splitlines()[-1])
            hs = bulk.read_summary(hdir)
            same = all(hs[key] == cb[key] for key in ("in", "out", "cycles", "s1_i", "s2_i", "s1_q", "s2_q"))
            r = dict(cosim_samples_per_s=cb["in"] / cb["wall_s"], cosim_cycles_per_s=cb["cycles"] / cb["wall_s"],
                     cosim_run_s=cb["wall_s"], cosim_process_s=cocotb_process,
                     bare_samples_per_s=hb["samples_per_s"], bare_cycles_per_s=hb["cycles_per_s"],
                     bare_run_s=hb["wall_s"], bare_process_s=harness_process,
                     cosim_cpu_s=cb["cpu_s"], bare_cpu_s=hb["cpu_s"],
                     samples=cb["in"], cycles=cb["cycles"], checksums={key: hs[key] for key in CHECKSUMS},
                     identical=same)
            r["ratio"] = r["bare_samples_per_s"] / r["cosim_samples_per_s"]
            r["ratio_cpu"] = r["cosim_cpu_s"] / r["bare_cpu_s"]
            runs.append(r)
            print(f"  run {k + 1}: cocotb {r['cosim_samples_per_s'] / 1e6:5.3f} M samples/s "
                  f"({r['cosim_cycles_per_s'] / 1e6:5.2f} M clocks/s, {r['cosim_run_s']:.1f} s; process "
                  f"{cocotb_process:.1f} s)   bare {r['bare_samples_per_s'] / 1e6:5.3f} M samples/s "
                  f"({r['bare_cycles_per_s'] / 1e6:5.2f} M clocks/s, {r['bare_run_s']:.1f} s)   "
                  f"bare/cocotb {r['ratio']:.2f} (CPU time {r['ratio_cpu']:.2f})   "
                  f"cocotb {100 / r['ratio']:.0f} % of bare   "
                  f"identical outputs: {same}", flush=True)
        jobs.append(dict(slots=c.slots, clock=clock, channels=c.channels, pipelines=c.pipelines,
                         samples=runs[0]["samples"], cycles=runs[0]["cycles"], cosim_build_s=b.build_seconds,
                         runs=runs, identical=all(r["identical"] for r in runs)))
    # every clocking did the same computation: same cycles, same outputs
    first = jobs[0]["runs"][0]
    for j in jobs:
        for r in j["runs"]:
            if (r["cycles"], r["checksums"]) != (first["cycles"], first["checksums"]):
                print(f"clock {j['clock']!r}: cycles or checksums differ from clock {jobs[0]['clock']!r}'s")
                j["identical"] = False
    return jobs


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", default=str(ROOT / "examples" / "sec4_3_4_four_windmills.toml"))
    ap.add_argument("--slots", type=_slots, default=[1, 10], metavar="M[,M...]",
                    help="fabric clocks per RTS sample of the engine, one job per value (default 1,10; "
                         "the default bitstream's engine is 10)")
    ap.add_argument("--seconds", type=float, default=0.2, help="radar time per job (default 0.2)")
    ap.add_argument("--channels", type=int, default=4)
    ap.add_argument("--clocks", type=_clocks, default=["burst", "clk"], metavar="C[,C...]",
                    help="how both paths clock the wrapper, one job per value: burst (rast's bulk builds, now), "
                         "clk (a cycle per period: the bulk builds with waves, and all of them before); "
                         "default burst,clk")
    ap.add_argument("--repeat", type=int, default=1, help="runs of both paths per job (default 1)")
    ap.add_argument("--json", default=None, help="also write the figures to this file")
    ap.add_argument("--verilator-arg", action="append", default=[], metavar="ARG",
                    help="add ARG to both Verilator builds (repeat it; e.g. --verilator-arg=-O3)")
    args = ap.parse_args(argv)
    if args.repeat < 1:
        ap.error("--repeat must be at least 1")
    if args.verilator_arg:
        print(f"added to both Verilator builds: {' '.join(args.verilator_arg)}")
    load0 = os.getloadavg()
    results = [j for m in args.slots for j in bench_slots(args, m)]
    load1 = os.getloadavg()

    print(f"\nsummary ({len(results[0]['runs'])} run(s) of each path per M; load average "
          f"{load0[0]:.1f} before, {load1[0]:.1f} after, {os.cpu_count()} CPUs)")
    print(f"{'M':>3} {'clock':>5} {'samples':>11} {'clocks':>12} | {'cocotb M samples/s':>18} {'M clocks/s':>10} | "
          f"{'bare M samples/s':>16} {'M clocks/s':>10} | {'bare/cocotb':>11} {'cocotb % of bare':>16} "
          f"{'CPU s ratio':>11} | same")
    for res in results:
        rs = res["runs"]
        print(f"{res['slots']:>3} {res['clock']:>5} {res['samples']:>11,} {res['cycles']:>12,} | "
              f"{_rng([r['cosim_samples_per_s'] for r in rs], 1e6, '{:.3f}'):>18} "
              f"{_rng([r['cosim_cycles_per_s'] for r in rs], 1e6):>10} | "
              f"{_rng([r['bare_samples_per_s'] for r in rs], 1e6, '{:.3f}'):>16} "
              f"{_rng([r['bare_cycles_per_s'] for r in rs], 1e6):>10} | "
              f"{_rng([r['ratio'] for r in rs]):>11} "
              f"{_rng([100 / r['ratio'] for r in rs], fmt='{:.0f}'):>16} "
              f"{_rng([r['ratio_cpu'] for r in rs]):>11} | {res['identical']}")
    by = {(r["slots"], r["clock"]): r for r in results}
    for m in args.slots:
        if (m, "burst") in by and (m, "clk") in by:
            now, before = by[m, "burst"]["runs"], by[m, "clk"]["runs"]
            print(f"M = {m:>2}: the burst clock (now) against a cycle per period (before): cocotb path "
                  f"{_rng([a['cosim_samples_per_s'] / b['cosim_samples_per_s'] for a, b in zip(now, before)])} "
                  f"times as fast, bare harness "
                  f"{_rng([a['bare_samples_per_s'] / b['bare_samples_per_s'] for a, b in zip(now, before)])}; "
                  f"cocotb now against the faster bare harness: "
                  f"{_rng([100 * a['cosim_samples_per_s'] / max(a['bare_samples_per_s'], b['bare_samples_per_s']) for a, b in zip(now, before)], fmt='{:.0f}')} %")
    if args.json:
        Path(args.json).write_text(json.dumps(dict(config=Path(args.config).name, seconds=args.seconds,
                                                   load_before=load0, load_after=load1,
                                                   verilator_args=args.verilator_arg, cpus=os.cpu_count(),
                                                   jobs=results), indent=2))
    return 0 if all(r["identical"] for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())
