"""Stream generation speed: prints streams/s and samples/s.

Two workloads, each timed for RAST's vectorised model and, in the same run,
for a plain per-blade, per-scatterer numpy implementation of the same
equations (``modulation_reference``):

1. a large farm: 8 windmills, 3 blades × 15 point scatterers plus a wire
   each, streams at the automatic rate (4 × max Doppler);
2. the seed's one-word-per-RTS-sample mode: one 15 rpm windmill of the same
   kind at a 20 MHz RTS sample rate (one period, 26.7 M samples).

Run: ``.venv/bin/python bench/bench_streams.py [--quick]`` (``make bench``).
"""

import argparse
import time

import numpy as np

from rast.model.config import parse_config
from rast.model.stream import build_farm_streams, plan_stream, stream_times
from rast.model.turbine import modulation, modulation_reference


def windmill(name, rpm, range_km, rng, stream_rate=None):
    table = {"name": name, "range": range_km, "num_blades": 3, "rpm": rpm, "num_rcs": 15,
             "radius": list(np.linspace(4.0, 50.0, 15)), "rsc": list(rng.uniform(0.2, 1.5, 15)),
             "phase_start": list(rng.uniform(0, 360, 15)),
             "rsc_weighting": {"angle": [0, 180], "width": 6, "gain_db": 10},
             "wire_enable": True, "wire_radius_min": 3.0, "wire_radius_max": 50.0,
             "wire_reflectivity": 0.02, "tower_rcs": 20.0}
    if stream_rate:
        table["stream_rate"] = stream_rate
    return table


def timed(function, repeat):
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        result = function()
        best = min(best, time.perf_counter() - start)
    return best, result


def large_farm(repeat):
    rng = np.random.default_rng(1)
    farm = parse_config({"sample_rate": 20, "radar_frequency": 5350, "ram_depth": 1 << 20, "windmill": [
        windmill(f"wm{i}", rpm, 2.0 + 0.4 * i, rng) for i, rpm in enumerate([8, 10, 12, 13, 15, 16, 18, 20])]})
    seconds, streams = timed(lambda: build_farm_streams(farm), repeat)
    samples = sum(s.plan.length for s in streams.streams)

    def naive():
        for w in farm.windmills:
            plan = plan_stream(w, farm)
            modulation_reference(w, stream_times(plan, w), farm.radar.wavelength_m)
    naive_seconds, _ = timed(naive, repeat)
    return len(farm.windmills), samples, seconds, naive_seconds


def seed_mode(quick):
    rng = np.random.default_rng(2)
    farm = parse_config({"sample_rate": 20, "radar_frequency": 5350, "ram_depth": 1 << 26,
                         "windmill": [windmill("wm15", 15, 2.0, rng, "rts")]})
    w = farm.windmills[0]
    plan = plan_stream(w, farm)
    t = stream_times(plan, w)
    if quick:
        t = t[: len(t) // 20]
    seconds, _ = timed(lambda: modulation(w, t, farm.radar.wavelength_m), 1)
    naive_seconds, _ = timed(lambda: modulation_reference(w, t, farm.radar.wavelength_m), 1)
    return plan.length, t.size, seconds, naive_seconds


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="time 1/20 of the seed-mode period")
    parser.add_argument("--repeat", type=int, default=3, help="best of N for the farm")
    args = parser.parse_args()

    count, samples, seconds, naive_seconds = large_farm(args.repeat)
    print("large farm: 8 windmills × (3 blades × 15 scatterers + wire + tower), automatic stream rate")
    print(f"  {samples} stream samples in all")
    print(f"  rast      : {seconds:8.3f} s  {count / seconds:10.1f} streams/s  {samples / seconds / 1e6:8.3f} M samples/s"
          " (including quantisation, gains, taps)")
    print(f"  naive     : {naive_seconds:8.3f} s  {count / naive_seconds:10.1f} streams/s  "
          f"{samples / naive_seconds / 1e6:8.3f} M samples/s (modulation only)")
    print(f"  speed-up  : {naive_seconds / seconds:.1f}×")

    length, timed_samples, seconds, naive_seconds = seed_mode(args.quick)
    print(f"seed mode: one word per RTS sample, 15 rpm, 20 MHz: {length} words per period"
          + (f" (timed: the first {timed_samples})" if timed_samples != length else ""))
    print(f"  rast      : {seconds:8.3f} s  {timed_samples / length / seconds:10.3f} streams/s  "
          f"{timed_samples / seconds / 1e6:8.3f} M samples/s")
    print(f"  naive     : {naive_seconds:8.3f} s  {timed_samples / length / naive_seconds:10.3f} streams/s  "
          f"{timed_samples / naive_seconds / 1e6:8.3f} M samples/s")
    print(f"  speed-up  : {naive_seconds / seconds:.1f}×")


if __name__ == "__main__":
    main()
