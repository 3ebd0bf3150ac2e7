"""A farm from a layout, end to end: prints the time of each step and the sizes.

The example layout (``examples/farm_layout_uswtdb.csv``, 64 synthetic
turbines in USWTDB columns) through ``rast farm``'s model (reading the CSV,
PROJ's geodetic → topocentric transforms per turbine, the config text),
``build_farm_streams`` (64 streams, quantised) and the RAM files of every
format (hex, bin, npy, coe, mif), each timed as the best of ``--repeat`` runs.

Run: ``.venv/bin/python bench/bench_farm.py [--repeat N]``.
"""

import argparse
import tempfile
import time
import tomllib
from pathlib import Path

from rast.model.physics.farm import parse_config
from rast.model.physics.layout import TURBINE_CLASSES, FarmSettings, RadarSite, make_farm, read_layout
from rast.model.files.ramfiles import FORMATS, write_farm_files
from rast.model.physics.stream import build_farm_streams

LAYOUT = Path(__file__).resolve().parents[1] / "examples" / "farm_layout_uswtdb.csv"


def best(repeat, step):
    times, result = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        result = step()
        times.append(time.perf_counter() - start)
    return min(times), result


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()

    def farm_text():
        layout = read_layout(LAYOUT)
        return make_farm(layout, RadarSite.from_option((32.40, -100.40, 25.0), layout.geodetic), 200.0,
                         turbine_class=TURBINE_CLASSES["nrel-5mw"], wind_speed_m_s=9.0,
                         settings=FarmSettings(prf_hz=12_000.0))[0]
    t_farm, text = best(args.repeat, farm_text)
    farm = parse_config(tomllib.loads(text))
    t_streams, streams = best(args.repeat, lambda: build_farm_streams(farm))
    words = sum(s.plan.length for s in streams.streams)
    with tempfile.TemporaryDirectory() as out:
        t_files, written = best(args.repeat, lambda: write_farm_files(streams, out, formats=FORMATS))
        size = sum(p.stat().st_size for p in written.values())
    n = len(farm.windmills)
    print(f"layout: {LAYOUT.name}, {n} turbines; best of {args.repeat}")
    print(f"rast farm (CSV, PROJ, echo sum, text):    {t_farm * 1e3:8.1f} ms  ({t_farm / n * 1e3:.2f} ms per turbine)")
    print(f"build_farm_streams:                       {t_streams * 1e3:8.1f} ms  ({words} stream words, "
          f"{words / t_streams / 1e6:.2f} M words/s)")
    print(f"RAM files, all {len(FORMATS)} formats:                {t_files * 1e3:8.1f} ms  "
          f"({len(written)} files, {size / 1e6:.1f} MB)")


if __name__ == "__main__":
    main()
