"""Cosimulation speed: simulated RTS samples per wall-clock second for the 4-channel top.

Runs the same job twice on the same Verilog (replay top inside the bulk
wrapper, ``rast.sim.bulk``), in one invocation:

1. under cocotb + Verilator (``rast.sim.tb_e2e.bench``): Python writes the
   stimulus files, raises ``start`` and waits for ``done``; cocotb's GPI clock
   (C++) drives the wrapper's ``clk``, no Python runs per sample
   (``docs/cosim_speed.md``: where the rest of the time goes);
2. in a bare Verilator C++ harness (``sim/harness/main.cpp``): no Python, no
   VPI, the clock toggled from C++.

Both runs must end with identical output checksums (same computation). The
job is the end-to-end one: ``--seconds`` of radar time of sampled pulses
(seed Table 4.1 chirp) for the config's farm, every RTS sample through the DUT.

    .venv/bin/python bench/bench_cosim.py [--config C] [--seconds 1] [--channels 4]
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


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", default=str(ROOT / "examples" / "sec4_3_4_four_windmills.toml"))
    ap.add_argument("--seconds", type=float, default=1.0)
    ap.add_argument("--channels", type=int, default=4)
    ap.add_argument("--json", default=None, help="also write the figures to this file")
    ap.add_argument("--verilator-arg", action="append", default=[], metavar="ARG",
                    help="add ARG to both Verilator builds (repeat it; e.g. --verilator-arg=-O3)")
    args = ap.parse_args(argv)

    from rast.sim import bulk, runner
    from rast.sim.e2e import prepare
    from rast.sim.harness.build import build_harness
    from rast.sim.top import top_sources

    config = str(Path(args.config).resolve())
    e = prepare(config, args.seconds, channels=args.channels)
    c = e.scenario.contract
    sources, top = top_sources(c.channels, pool_words=c.pool_words, max_delay=c.max_delay,
                               max_tap=c.max_tap)
    if args.verilator_arg:
        print(f"added to both Verilator builds: {' '.join(args.verilator_arg)}")
    print(f"job: {Path(config).name}, {c.channels} channels, {e.pulse.n_pulses} pulses = "
          f"{args.seconds:g} s of radar time, {e.info['samples']:,} RTS samples at "
          f"{e.farm.sample_rate_mhz:g} MHz", flush=True)

    t = time.monotonic()
    b = runner.build(sources, top, simulator="verilator", waves=False, label=f"bench{c.channels}", bulk=True,
                     build_args=tuple(args.verilator_arg))
    cocotb_build = time.monotonic() - t
    t = time.monotonic()
    params = dict(config=config, seconds=args.seconds, channels=args.channels)
    run_dir = runner.run(b, "rast.sim.tb_e2e", name=f"bench-{c.channels}ch-{args.seconds:g}s",
                         testcase="bench", extra_env={"RAST_TB_PARAMS": json.dumps(params)}, quiet=True)
    cocotb_process = time.monotonic() - t
    cb = json.loads((run_dir / "bench.json").read_text())

    t = time.monotonic()
    exe = build_harness(sources, top, extra_args=tuple(args.verilator_arg))
    harness_build = time.monotonic() - t
    hdir = exe.parent.parent / "run"
    if hdir.exists():
        shutil.rmtree(hdir)
    hdir.mkdir()
    bulk.write_job(e.scenario.job, hdir)      # the same job files the cocotb run wrote
    t = time.monotonic()
    out = subprocess.run([str(exe)], cwd=hdir, capture_output=True, text=True, check=True)
    harness_process = time.monotonic() - t
    hb = json.loads(out.stdout.strip().splitlines()[-1])
    hs = bulk.read_summary(hdir)
    same = all(hs[k] == cb[k] for k in ("in", "out", "s1_i", "s2_i", "s1_q", "s2_q"))

    cosim_rate = cb["in"] / cb["wall_s"]
    bare_rate = hb["samples_per_s"]
    res = dict(config=Path(config).name, channels=c.channels, seconds=args.seconds,
               samples=cb["in"], cycles=cb["cycles"],
               cosim_samples_per_s=cosim_rate, cosim_run_s=cb["wall_s"],
               cosim_process_s=cocotb_process, cosim_build_s=cocotb_build,
               bare_samples_per_s=bare_rate, bare_run_s=hb["wall_s"],
               bare_process_s=harness_process, bare_build_s=harness_build,
               ratio_bare_over_cosim=bare_rate / cosim_rate, outputs_identical=same,
               verilator_args=args.verilator_arg, cpus=os.cpu_count())
    print(f"cocotb + Verilator : {cosim_rate / 1e6:6.2f} M samples/s  ({cb['wall_s']:.1f} s for "
          f"{args.seconds:g} s of radar time; process incl. start-up {cocotb_process:.1f} s; build "
          f"{'cached' if b.build_seconds == 0 else f'{b.build_seconds:.0f} s'})")
    print(f"bare C++ harness   : {bare_rate / 1e6:6.2f} M samples/s  ({hb['wall_s']:.1f} s; build "
          f"{harness_build:.0f} s incl. cache check)")
    print(f"ratio bare/cosim   : {bare_rate / cosim_rate:6.2f}")
    print(f"identical outputs  : {same} (sample counts and checksums of all outputs)")
    if args.json:
        Path(args.json).write_text(json.dumps(res, indent=2))
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
