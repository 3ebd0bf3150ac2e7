"""Spur-free dynamic range of the replayed streams over the radar's whole band.

Usage: python bench/bench_interpolation.py [--seconds 1] [CONFIG ...]

For each config (default: the default example and seed 4.3.3's realistic
turbines) and each interpolation (hold, linear, fir) at 4x and 8x
oversampling: the bit-exact model's stream words at every pulse for
``--seconds`` of radar time, the worst-CPI SFDR over ±PRF/2
(Blackman-Harris, outside every turbine's ±(max Doppler + 6 bins),
``rast.model.radar.sfdr``), the highest spur's frequency and the stream words the
farm needs.
"""

import argparse
import dataclasses
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rast.model.physics.farm import load_config           # noqa: E402
from rast.model.radar.receiver import receive                # noqa: E402
from rast.model.radar.sfdr import farm_sfdr, worst        # noqa: E402
from rast.model.physics.stream import build_farm_streams    # noqa: E402

DEFAULT = [ROOT / "examples" / "two_windmills.toml", ROOT / "examples" / "sec4_3_3_realistic.toml"]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("configs", nargs="*", type=Path, default=DEFAULT)
    ap.add_argument("--seconds", type=float, default=1.0)
    ap.add_argument("--oversampling", type=float, nargs="+", default=[4.0, 8.0])
    args = ap.parse_args(argv)
    print(f"SFDR over ±PRF/2, worst CPI of {args.seconds:g} s (bit-exact stream words)")
    print("| config | oversampling | words | hold dB | linear dB | fir dB | fir spur Hz |")
    print("|---|---|---|---|---|---|---|")
    t0 = time.time()
    for path in args.configs:
        base = load_config(path)
        for ovs in args.oversampling:
            row, words, spur = [], 0, 0.0
            for mode in ("hold", "linear", "fir"):
                farm = dataclasses.replace(base, interpolation=mode, stream_oversampling=ovs)
                streams = build_farm_streams(farm, check_ram_depth=False)
                words = sum(s.plan.length for s in streams.streams)
                _, bins, samples = receive(farm, args.seconds, streams)
                r = worst(farm_sfdr(farm, samples, bins))
                row.append(r.sfdr_db)
                spur = r.spur_hz
            print(f"| {path.name} | {ovs:g} | {words} | " + " | ".join(f"{v:.1f}" for v in row)
                  + f" | {spur:+.0f} |", flush=True)
    print(f"({time.time() - t0:.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
