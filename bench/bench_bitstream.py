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

#: label -> (what it answers, BuildConfig keyword arguments)
LADDER = {
    "n8_100": ("default: 8 channels at 100 MHz", dict(channels=8, clock_mhz=100)),
    "n8_150": ("8 channels asked for 150 MHz: how fast does it go", dict(channels=8, clock_mhz=150)),
    "n8_200": ("8 channels asked for 200 MHz", dict(channels=8, clock_mhz=200)),
    "n9_100": ("9 channels at 100 MHz", dict(channels=9, clock_mhz=100)),
    "n10_100": ("10 channels at 100 MHz", dict(channels=10, clock_mhz=100)),
    "n11_100": ("most channels that fit with 4096-word streams (block RAM bound)",
                dict(channels=11, clock_mhz=100)),
    "n5_8k_100": ("seed 4.3.3 turbines: 8192-word streams (<= 7775 words at 4x Doppler)",
                  dict(channels=5, clock_mhz=100, stream_depth=8192)),
}

ROOT = Path(__file__).resolve().parent.parent / "build" / "bench_bitstream"


def row(label, what, rep):
    t, r = rep["timing"], rep["resources"]
    cp = t.get("critical_path") or {}
    lim = f"{cp.get('from', '?')} -> {cp.get('to', '?')} ({cp.get('routing_ns', 0):.1f} of " \
          f"{cp.get('delay_ns', 0):.1f} ns routing)"
    return (f"{label:<10} {rep['config']['channels']:>3} {rep['config']['stream_depth']:>6} "
            f"{rep['config']['clock_mhz']:>6.0f} {t['fmax_mhz']:>7.1f} {'yes' if t['met'] else 'NO':>4} "
            f"{r['luts']['used']:>6} {r['ffs']['used']:>6} {r['dsps']['used']:>4}/{r['dsps']['available']} "
            f"{r['block_rams']['used']:>4}/{r['block_rams']['available']}  {lim}\n"
            f"{'':<10} {what}")


def seed_capacity():
    """Turbines of the seed's section 4.3 scenarios one LFE5U-85F holds at once
    (stream rate 4 x max Doppler, C band), from the block RAM budget."""
    from rast.gateware.capacity import max_channels
    from rast.model.config import load_config
    from rast.model.stream import build_farm_streams
    examples = Path(__file__).resolve().parent.parent / "examples"
    print("\nturbines per LFE5U-85F (two 32-bit banks per stream, 4x max Doppler):")
    for name in ("sec4_3_3_three_blades", "sec4_3_3_realistic", "sec4_3_4_four_windmills"):
        farm = load_config(examples / f"{name}.toml")
        for s in build_farm_streams(farm).streams:
            words = s.plan.length
            depth = 1 << (words - 1).bit_length()
            n, lim = max_channels(stream_depth=max(depth, 2))
            print(f"  {name:<24} {s.windmill.name:<5} {s.windmill.rpm:>3g} rpm "
                  f"{s.windmill.num_blades} blade(s) {s.plan.max_doppler_hz:>6.0f} Hz "
                  f"{words:>6} words -> depth {depth:>5}: {n:>2} per device ({lim})")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reuse", action="store_true", help="print reports already built")
    ap.add_argument("--only", action="append", choices=sorted(LADDER), help="build only these rungs")
    ap.add_argument("--capacity", action="store_true", help="only print the turbines-per-device table")
    args = ap.parse_args()
    if args.capacity:
        seed_capacity()
        return
    print(f"{'label':<10} {'N':>3} {'depth':>6} {'asked':>6} {'fmax':>7} {'met':>4} {'LUTs':>6} "
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
