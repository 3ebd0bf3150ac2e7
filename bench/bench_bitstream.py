"""The fmax / resource ladder of the replay block on the LFE5U-85F-6 (ULX3S).

Builds each configuration with the open toolchain (one nextpnr at a time)
into ``build/bench_bitstream/<label>/`` and prints one row per build:
requested clock, achieved fmax, timing met, LUTs, FFs, DSPs, block RAMs, and
what limits it (the critical path's end points). ``--reuse`` reads reports
already built instead of building again; ``--only LABEL`` builds one rung.

    .venv/bin/python bench/bench_bitstream.py [--reuse] [--only n8_100]
"""

import argparse
import json
import time
from pathlib import Path

from rast.gateware.build import BuildConfig, build
from rast.model.fixedpoint import ReplayContract

#: label -> (what it answers, BuildConfig keyword arguments)
LADDER = {
    "n8_20": ("default: 8 FIR channels at the examples' 20 MS/s, 65536-word pool", dict()),
    "n4_100": ("wide band: 4 FIR channels at 100 MS/s, delays 4094 + 1022 (6.1 + 1.5 km)",
               dict(channels=4, clock_mhz=100, max_delay=4094, max_tap=1022)),
    "n4_100_d": ("4 FIR channels at 100 MS/s, delays 8190 + 2046",
                 dict(channels=4, clock_mhz=100, max_delay=8190, max_tap=2046)),
    "n8_20_61k": ("the default build with delays 8190 + 2046 (61 + 15 km at 20 MS/s)",
                  dict(max_delay=8190, max_tap=2046)),
    "n8_100": ("8 FIR channels at 100 MS/s", dict(channels=8, clock_mhz=100)),
    "n8_20_80k": ("8 FIR channels, the largest pool beside them (81920 words)",
                  dict(pool_words=81920)),
}

ROOT = Path(__file__).resolve().parent.parent / "build" / "bench_bitstream"


def row(label, what, rep):
    t, r = rep["timing"], rep["resources"]
    cp = t.get("critical_path") or {}
    lim = f"{cp.get('from', '?')} -> {cp.get('to', '?')} ({cp.get('routing_ns', 0):.1f} of " \
          f"{cp.get('delay_ns', 0):.1f} ns routing)"
    return (f"{label:<10} {rep['config']['channels']:>3} {rep['config']['pool_words']:>6} "
            f"{rep['config']['clock_mhz']:>6.0f} {t['fmax_mhz']:>7.1f} {'yes' if t['met'] else 'NO':>4} "
            f"{r['luts']['used']:>6} {r['ffs']['used']:>6} {r['dsps']['used']:>4}/{r['dsps']['available']} "
            f"{r['block_rams']['used']:>4}/{r['block_rams']['available']}  {lim}\n"
            f"{'':<10} {what}")


def seed_capacity():
    """Turbines of the seed's section 4.3 scenarios one LFE5U-85F holds at once
    (stream rate 4 x max Doppler, C band, FIR), from the block RAM budget: all
    in the pool, with room to reload one while all play."""
    from rast.gateware.capacity import turbines_per_device
    from rast.model.config import load_config
    from rast.model.stream import build_farm_streams
    examples = Path(__file__).resolve().parent.parent / "examples"
    windows = (ReplayContract.max_tap, 2046)      # the default window, and the 15 km one
    print("\nturbines per LFE5U-85F (stream pool, one stream's room to reload, 4x max Doppler, FIR;"
          f" common delay {ReplayContract.max_delay}; each channel's delay window {windows[0]} "
          f"(default) or {windows[1]} samples deep):")
    for name in ("sec4_3_3_three_blades", "sec4_3_3_realistic", "sec4_3_4_four_windmills",
                 "two_windmills"):
        farm = load_config(examples / f"{name}.toml")
        for s in build_farm_streams(farm).streams:
            words = s.plan.length
            cells = []
            for window in windows:
                n, pool, lim = turbines_per_device(words, max_tap=window)
                cells.append(f"window {window}: {n:>2}, pool {pool} words (next one: {lim})")
            print(f"  {name:<24} {s.windmill.name:<5} {s.windmill.rpm:>3g} rpm "
                  f"{s.windmill.num_blades} blade(s) {s.plan.max_doppler_hz:>6.0f} Hz "
                  f"{words:>6} words; " + "; ".join(cells))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reuse", action="store_true", help="print reports already built")
    ap.add_argument("--only", action="append", choices=sorted(LADDER), help="build only these rungs")
    ap.add_argument("--capacity", action="store_true", help="only print the turbines-per-device table")
    args = ap.parse_args()
    if args.capacity:
        seed_capacity()
        return
    print(f"{'label':<10} {'N':>3} {'pool':>6} {'asked':>6} {'fmax':>7} {'met':>4} {'LUTs':>6} "
          f"{'FFs':>6} {'DSPs':>8} {'BRAMs':>8}  critical path")
    for label, (what, kw) in LADDER.items():
        if args.only and label not in args.only:
            continue
        out = ROOT / label
        rp = out / "report.json"
        if not (args.reuse and rp.exists()):
            t0 = time.monotonic()
            build(BuildConfig(**kw), out, quiet=True)
            what += f" (built in {time.monotonic() - t0:.0f} s)"
        print(row(label, what, json.loads(rp.read_text())), flush=True)
    seed_capacity()


if __name__ == "__main__":
    main()
