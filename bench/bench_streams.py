"""Stream generation speed and memory, against a per-scatterer float64 reference.

Three workloads, each timed in the same run for RAST and for the reference, a
per-blade, per-scatterer loop over the same equations in float64
(``modulation_loop`` below), written as a careful numpy user would: everything
that does not depend on the scatterer (β, sin β, the blade-flash weights, the
tower's shadow) computed once per blade, in chunks of ``LOOP_CHUNK`` samples.
The reference only computes m(t) (no quantisation, no files), so the
speed-ups are conservative. Its output is checked against
:func:`rast.model.physics.turbine.modulation_reference` (the equations as read) and
RAST's against the same, as an RMS error in dBc (relative to the RMS of m).

1. seed mode: one word per RTS sample, one 3-blade × 15-scatterer 15 rpm
   windmill with wire, tower and flashes at 20 MS/s (26.7 M words), timed as
   ``rast stream`` runs: ``make_farm_files``, streams computed and their
   .hex/.bin/.npy files and manifest written (773 MB); issue 12 asks ≥ 20×
   the reference and ≤ 4 s on 2 cores, and at most about 2 GB;
2. the 64-turbine farm example (``examples/farm_layout.toml``) at its
   automatic stream rate (4 × max Doppler), ``build_farm_streams``; issue 12
   asks ≤ 1 s;
3. a heavier 64-windmill farm made here (15 scatterers, wire, tower and
   flashes each, 6 to 24 rpm), also at the automatic rate.

Every job runs in a subprocess of its own, which reports its peak resident
memory (``ru_maxrss``), with ``NUMPY_MADVISE_HUGEPAGE=0`` as ``rast`` sets it
(unless the environment sets it). The seed-mode job runs ``--repeat`` times,
before and after its reference, and the range is printed; the farms take the
best of ``--repeat`` in one process. The reference reports its progress on
stderr.

Run: ``.venv/bin/python bench/bench_streams.py [--quick] [--repeat N]``
(``make bench``); ``--quick`` times the seed-mode reference on 1/20 of the
period and scales it.
"""

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from rast.model.physics.farm import load_config, parse_config
from rast.model.files.ramfiles import make_farm_files
from rast.model.physics.stream import build_farm_streams, plan_stream, stream_times
from rast.model.physics.synthesis import synthesise_period
from rast.model.physics.turbine import (blade_angles, modulation_reference, point_weights, shadow_factor,
                                        wire_return)

#: Samples per chunk of the loop (its fastest of 2**12 ... 2**18 on a 2-core x86 machine).
LOOP_CHUNK = 1 << 14
ROOT = Path(__file__).resolve().parents[1]
FARM_EXAMPLE = ROOT / "examples" / "farm_layout.toml"


def modulation_loop(windmill, t_s, wavelength_m, chunk=LOOP_CHUNK, dtype=np.float64, progress=None):
    """m(t) of eq. 2.15–2.19, one blade and one scatterer at a time, the
    scatterer-independent work hoisted out of the scatterer loop; the
    trigonometry in ``dtype`` after an exact float64 phase reduction.
    ``progress(done, total)`` is called after every chunk."""
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
                angle = ((turns - np.rint(turns)) * (2 * np.pi)).astype(dtype)
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
        if progress:
            progress(start + t.size, t_s.size)
    return out


class Progress:
    """A line on stderr every few seconds: how far a long job is."""

    def __init__(self, what, every_s=5.0):
        self.what, self.every_s = what, every_s
        self.start = self.last = time.perf_counter()

    def __call__(self, done, total):
        now = time.perf_counter()
        if now - self.last >= self.every_s:
            self.last = now
            print(f"  [{self.what}] {done / total:6.1%}  {now - self.start:5.1f} s", file=sys.stderr, flush=True)


def rms_error_dbc(values, reference):
    """RMS of (values − reference) relative to the RMS of reference, dB."""
    return float(10 * np.log10(np.mean(np.abs(values - reference) ** 2) / np.mean(np.abs(reference) ** 2)))


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


def seed_farm():
    rng = np.random.default_rng(2)
    return parse_config({"sample_rate": 20, "radar_frequency": 5350, "ram_depth": 1 << 26,
                         "interpolation": "hold", "windmill": [windmill("wm15", 15, 2.0, rng, "rts")]})


def farm_example():
    return load_config(FARM_EXAMPLE)


def farm64():
    rng = np.random.default_rng(1)
    rpms = np.linspace(6.0, 24.0, 64)
    return parse_config({"sample_rate": 20, "radar_frequency": 5350, "windmill": [
        windmill(f"wm{i:02d}", float(rpm), 2.0 + 0.1 * i, rng) for i, rpm in enumerate(rpms)]})


def peak_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def spot_check(farm, streams, count=20000):
    """RAST's periods against modulation_reference at ``count`` random samples of every stream."""
    rng = np.random.default_rng(3)
    got, want = [], []
    for s in streams.streams:
        n = rng.integers(0, s.plan.length, min(count, s.plan.length))
        t = n * (s.windmill.period_s / s.plan.length)
        got.append(s.period[n])
        want.append(modulation_reference(s.windmill, t, farm.radar.wavelength_m))
    return max(rms_error_dbc(g, w) for g, w in zip(got, want))


def job_seed(args):
    farm = seed_farm()
    w = farm.windmills[0]
    with tempfile.TemporaryDirectory(dir=args.tmp) as out:
        start = time.perf_counter()
        streams, written = make_farm_files(farm, out)         # as `rast stream` does
        end = time.perf_counter()
        size = sum(f.stat().st_size for f in written.values())
        peak = peak_mb()                  # of the job itself, before the breakdown below
        s = streams.streams[0]
        result = {"seconds": end - start, "peak_mb": peak, "words": s.plan.length, "bytes": size,
                  "method": s.synthesis.method, "grid_step": s.synthesis.grid_step,
                  "check_dbc": s.synthesis.check_error_dbc, "error_dbc": spot_check(farm, streams)}
    del streams, s
    start = time.perf_counter()           # without files, and the synthesis alone (m(t) against m(t))
    build_farm_streams(farm)
    result["build_seconds"] = time.perf_counter() - start
    start = time.perf_counter()
    synthesise_period(w, result["words"], farm.radar.wavelength_m)
    result["synthesis_seconds"] = time.perf_counter() - start
    return result


def job_seed_reference(args):
    farm = seed_farm()
    w = farm.windmills[0]
    t = stream_times(plan_stream(w, farm), w)
    if args.quick:
        t = t[: len(t) // 20]
    start = time.perf_counter()
    loop = modulation_loop(w, t, farm.radar.wavelength_m, progress=Progress("reference, seed mode"))
    seconds = time.perf_counter() - start
    n = np.random.default_rng(4).integers(0, t.size, 20000)
    return {"seconds": seconds, "peak_mb": peak_mb(), "samples": t.size,
            "error_dbc": rms_error_dbc(loop[n], modulation_reference(w, t[n], farm.radar.wavelength_m))}


def job_farm(args, make=farm64):
    farm = make()
    best = float("inf")
    for _ in range(args.repeat):
        start = time.perf_counter()
        streams = build_farm_streams(farm)
        best = min(best, time.perf_counter() - start)
    return {"seconds": best, "peak_mb": peak_mb(), "samples": sum(s.plan.length for s in streams.streams),
            "error_dbc": spot_check(farm, streams, 2000)}


def job_farm_reference(args, make=farm64):
    farm = make()
    times = [stream_times(plan_stream(w, farm), w) for w in farm.windmills]
    start = time.perf_counter()
    loops = [modulation_loop(w, t, farm.radar.wavelength_m) for w, t in zip(farm.windmills, times)]
    seconds = time.perf_counter() - start
    errors = [rms_error_dbc(m[:500], modulation_reference(w, t[:500], farm.radar.wavelength_m))
              for w, t, m in zip(farm.windmills, times, loops)]
    return {"seconds": seconds, "peak_mb": peak_mb(), "error_dbc": max(errors)}


JOBS = {"seed": job_seed, "seed-reference": job_seed_reference,
        "example": lambda args: job_farm(args, farm_example),
        "example-reference": lambda args: job_farm_reference(args, farm_example),
        "farm": job_farm, "farm-reference": job_farm_reference}


def run(job, args):
    print(f"[bench_streams] {job} …", file=sys.stderr, flush=True)
    command = [sys.executable, __file__, "--job", job, "--repeat", str(args.repeat)]
    command += ["--quick"] if args.quick else []
    command += ["--tmp", args.tmp] if args.tmp else []
    # As `rast stream` runs (rast/cli.py): no hugepage advice for numpy's arrays.
    env = {**os.environ, "NUMPY_MADVISE_HUGEPAGE": os.environ.get("NUMPY_MADVISE_HUGEPAGE", "0")}
    done = subprocess.run(command, check=True, stdout=subprocess.PIPE, text=True, env=env)
    return json.loads(done.stdout.splitlines()[-1])


def span(values, fmt="{:.3f}"):
    """'a' or 'a … b' for the smallest and largest of ``values``."""
    low, high = min(values), max(values)
    return fmt.format(low) if fmt.format(low) == fmt.format(high) else f"{fmt.format(low)} … {fmt.format(high)}"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="time the seed-mode reference on 1/20 of the period")
    parser.add_argument("--repeat", type=int, default=3, help="seed-mode runs; best of N for the farms")
    parser.add_argument("--tmp", help="folder for the seed-mode files (default: the system's temporary folder)")
    parser.add_argument("--job", choices=JOBS, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.job:
        print(json.dumps(JOBS[args.job](args)))
        return

    print(f"{time.strftime('%Y-%m-%d %H:%M:%S %Z')}, {os.cpu_count()} cores, load average "
          f"{' '.join(f'{x:.1f}' for x in os.getloadavg())}")
    before = max(1, args.repeat // 2)
    fast = [run("seed", args) for _ in range(before)]
    ref = run("seed-reference", args)
    fast += [run("seed", args) for _ in range(args.repeat - before)]
    ref_seconds = ref["seconds"] * fast[0]["words"] / ref["samples"]
    f = fast[0]
    seconds = [r["seconds"] for r in fast]
    print(f"seed mode: one word per RTS sample, 3 blades × 15 scatterers + wire + tower + flashes, "
          f"15 rpm, 20 MS/s: {f['words']} words")
    print(f"  rast      : {span(seconds)} s ({len(fast)} runs)  {f['words'] / min(seconds) / 1e6:.2f} M words/s at best  "
          f"peak {span([r['peak_mb'] for r in fast], '{:.0f}')} MB  (make_farm_files as `rast stream`: "
          f"{f['bytes'] / 1e6:.0f} MB of files; {f['method']}, grid step {f['grid_step']}, "
          f"midpoint check {f['check_dbc']:.1f} dBc)")
    print(f"  reference : {ref_seconds:8.3f} s  {f['words'] / ref_seconds / 1e6:8.2f} M words/s  "
          f"peak {ref['peak_mb']:6.0f} MB  (per-scatterer float64 loop, m(t) only"
          + (f"; timed on {ref['samples']} samples and scaled)" if ref["samples"] != f["words"] else ")"))
    print(f"  without files (build_farm_streams, again after the job): "
          f"{span([r['build_seconds'] for r in fast])} s; the synthesis alone: "
          f"{span([r['synthesis_seconds'] for r in fast])} s")
    print(f"  speed-up  : {span([ref_seconds / x for x in seconds], '{:.1f}')}× (whole job, files written, "
          f"against the reference's m(t) alone; issue 12: ≥ 20×, ≤ 4 s, ~2 GB); m(t) against m(t): "
          f"{span([ref_seconds / r['synthesis_seconds'] for r in fast], '{:.1f}')}×")
    print(f"  error vs modulation_reference: rast {max(r['error_dbc'] for r in fast):.1f} dBc RMS, "
          f"reference loop {ref['error_dbc']:.1f} dBc RMS (limit −100 dBc)")

    for job, title in (("example", f"64-turbine farm example ({FARM_EXAMPLE.name}), automatic stream rate"),
                       ("farm", "64-windmill farm made here (15 scatterers, wire, tower, flashes; 6 … 24 rpm), "
                                "automatic stream rate")):
        fast, ref = run(job, args), run(f"{job}-reference", args)
        print(f"{title}: {fast['samples']} words")
        print(f"  rast      : {fast['seconds']:8.3f} s  {fast['samples'] / fast['seconds'] / 1e6:8.2f} M words/s  "
              f"peak {fast['peak_mb']:6.0f} MB  (build_farm_streams, best of {args.repeat}; issue 12: ≤ 1 s)")
        print(f"  reference : {ref['seconds']:8.3f} s  {fast['samples'] / ref['seconds'] / 1e6:8.2f} M words/s  "
              f"peak {ref['peak_mb']:6.0f} MB  (per-scatterer float64 loop, m(t) only)")
        print(f"  speed-up  : {ref['seconds'] / fast['seconds']:.1f}×; error vs modulation_reference: rast "
              f"{fast['error_dbc']:.1f} dBc RMS, reference loop {ref['error_dbc']:.1f} dBc RMS")
    print(f"load average at the end {' '.join(f'{x:.1f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
