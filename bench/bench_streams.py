"""Stream generation speed: prints streams/s and samples/s.

Two workloads, each timed for RAST's vectorised model (``modulation``, and for
the farm the whole ``build_farm_streams``) and, in the same run, for a
per-blade, per-scatterer loop over the same equations (``modulation_loop``
below), written as a careful numpy user would: everything that does not
depend on the scatterer (β, sin β, the blade-flash weights, the tower's
shadow) computed once per blade, the same float32 trigonometry after the same
exact float64 phase reduction as the code under test, in chunks of
``LOOP_CHUNK`` samples (its fastest size here; RAST's 4096 made it 10 to 15 %
slower). Its output is checked against RAST's (equal to 1e-9 of the peak, far below
the 16-bit stream word's 3e-5), so the speed-up is the vectorisation's alone.

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
from rast.model.turbine import blade_angles, modulation, point_weights, shadow_factor, wire_return

#: Largest deviation of the loop from RAST, relative to the peak |m(t)|.
AGREEMENT = 1e-9
#: Samples per chunk of the loop (its fastest of 2**12 ... 2**18 on a 2-core x86 machine).
LOOP_CHUNK = 1 << 14


def modulation_loop(windmill, t_s, wavelength_m, chunk=LOOP_CHUNK):
    """m(t) of eq. 2.15–2.19, one blade and one scatterer at a time, the
    scatterer-independent work hoisted out of the scatterer loop."""
    t_s = np.asarray(t_s, dtype=float)
    out = np.empty(t_s.shape, dtype=complex)
    k_turns = 2 / wavelength_m * np.cos(np.deg2rad(windmill.rotor_angle_deg))
    radius_turns = k_turns * windmill.radius_m                 # phase in turns per unit sin β
    amplitude = np.sqrt(windmill.rcs_m2) * np.exp(1j * np.deg2rad(windmill.phase_start_deg))
    a_re, a_im = amplitude.real, amplitude.imag
    tower = 0j
    if windmill.tower is not None and windmill.tower.rcs_m2 > 0:
        tower = np.sqrt(windmill.tower.rcs_m2) * np.exp(1j * np.deg2rad(windmill.tower.phase_deg))
    for start in range(0, t_s.size, chunk):
        t = t_s[start:start + chunk]
        total = np.full(t.shape, tower, dtype=complex)
        for beta in blade_angles(windmill, t):
            sin_beta = np.sin(beta)
            weights = point_weights(windmill.weighting, beta)
            per_scatterer = weights is not None and weights.shape[0] > 1
            if per_scatterer:
                weights = weights.astype(np.float32)
            shadow = shadow_factor(windmill, beta)
            re = np.zeros(t.shape)
            im = np.zeros(t.shape)
            for k in range(windmill.num_rcs):
                turns = radius_turns[k] * sin_beta
                angle = ((turns - np.rint(turns)) * (2 * np.pi)).astype(np.float32)
                c, s = np.cos(angle), np.sin(angle)
                if per_scatterer:
                    c, s = c * weights[k], s * weights[k]
                re += a_re[k] * c - a_im[k] * s
                im += a_im[k] * c + a_re[k] * s
            blade = re + 1j * im
            if weights is not None and not per_scatterer:
                blade *= weights[0]
            if windmill.wire is not None:
                blade += wire_return(windmill, beta, wavelength_m)
            total += blade if shadow is None else blade * shadow
        out[start:start + chunk] = total
    return out


def check_agreement(fast, loop, what):
    """Raise unless the loop reproduces RAST's m(t); returns the deviation / peak."""
    deviation = float(np.max(np.abs(fast - loop)) / np.max(np.abs(fast)))
    if not deviation <= AGREEMENT:
        raise SystemExit(f"{what}: the per-scatterer loop differs from rast by {deviation:.2e} of the peak")
    return deviation


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
    times = [stream_times(plan_stream(w, farm), w) for w in farm.windmills]
    lam = farm.radar.wavelength_m
    modulation_seconds, fast = timed(lambda: [modulation(w, t, lam) for w, t in zip(farm.windmills, times)],
                                     repeat)
    loop_seconds, loop = timed(lambda: [modulation_loop(w, t, lam) for w, t in zip(farm.windmills, times)],
                               repeat)
    deviation = max(check_agreement(a, b, w.name) for a, b, w in zip(fast, loop, farm.windmills))
    return len(farm.windmills), samples, seconds, modulation_seconds, loop_seconds, deviation


def seed_mode(quick):
    rng = np.random.default_rng(2)
    farm = parse_config({"sample_rate": 20, "radar_frequency": 5350, "ram_depth": 1 << 26,
                         "interpolation": "hold", "windmill": [windmill("wm15", 15, 2.0, rng, "rts")]})
    w = farm.windmills[0]
    plan = plan_stream(w, farm)
    t = stream_times(plan, w)
    if quick:
        t = t[: len(t) // 20]
    seconds, fast = timed(lambda: modulation(w, t, farm.radar.wavelength_m), 1)
    loop_seconds, loop = timed(lambda: modulation_loop(w, t, farm.radar.wavelength_m), 1)
    deviation = check_agreement(fast, loop, w.name)
    return plan.length, t.size, seconds, loop_seconds, deviation


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="time 1/20 of the seed-mode period")
    parser.add_argument("--repeat", type=int, default=3, help="best of N for the farm")
    args = parser.parse_args()

    count, samples, seconds, modulation_seconds, loop_seconds, deviation = large_farm(args.repeat)
    print("large farm: 8 windmills × (3 blades × 15 scatterers + wire + tower), automatic stream rate")
    print(f"  {samples} stream samples in all")
    print(f"  rast      : {seconds:8.3f} s  {count / seconds:10.1f} streams/s  {samples / seconds / 1e6:8.3f} M samples/s"
          " (build_farm_streams: modulation, quantisation, gains, taps)")
    print(f"  rast m(t) : {modulation_seconds:8.3f} s  {count / modulation_seconds:10.1f} streams/s  "
          f"{samples / modulation_seconds / 1e6:8.3f} M samples/s (modulation only)")
    print(f"  loop m(t) : {loop_seconds:8.3f} s  {count / loop_seconds:10.1f} streams/s  "
          f"{samples / loop_seconds / 1e6:8.3f} M samples/s (per-scatterer loop, same precision)")
    print(f"  speed-up  : {loop_seconds / modulation_seconds:.2f}× (modulation against modulation); "
          f"outputs agree to {deviation:.1e} of the peak")

    length, timed_samples, seconds, loop_seconds, deviation = seed_mode(args.quick)
    print(f"seed mode: one word per RTS sample, 15 rpm, 20 MHz: {length} words per period"
          + (f" (timed: the first {timed_samples})" if timed_samples != length else ""))
    print(f"  rast m(t) : {seconds:8.3f} s  {timed_samples / length / seconds:10.3f} streams/s  "
          f"{timed_samples / seconds / 1e6:8.3f} M samples/s")
    print(f"  loop m(t) : {loop_seconds:8.3f} s  {timed_samples / length / loop_seconds:10.3f} streams/s  "
          f"{timed_samples / loop_seconds / 1e6:8.3f} M samples/s")
    print(f"  speed-up  : {loop_seconds / seconds:.2f}×; outputs agree to {deviation:.1e} of the peak")


if __name__ == "__main__":
    main()
