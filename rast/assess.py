"""``rast assess``: what the radar will report: MTD plots, CFAR, clutter map and weather moments.

Runs a reference processor (:mod:`rast.model.radar.assess`) on the model
radar's range-gate samples of a config (what the RTS plays, quantised;
``--physics``: the physics itself) or on a cosimulation's ``gates.npy``
(``--gates``: the RTL's own output), with the receiver's noise
(``noise_dbfs``). Writes to ``--out``:

* ``plots.csv``: one row per plot (time_s, range_km, azimuth_deg, doppler_hz,
  snr_db, scan, channel);
* ``summary.json``: false plots per scan, each turbine's detection fraction,
  the velocity bias and spectrum width per turbine gate, the parameters;
* ``range_doppler.png`` (a stare radar) or ``ppi.png`` (a turning antenna: the config's scan, or ``--azimuth``).

``--sweep NAME=START:STOP:STEP`` (``wind_from``, ``rpm``, ``scan_start_deg``;
several make a grid) runs every case as a task on Dask (a local cluster, or
``--scheduler ADDRESS``) and writes ``sweep.csv``, ``sweep.png`` and each
case's summary under ``cases/``. See docs/assess.md.
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import sys
import time
from pathlib import Path

__all__ = ["add_arguments", "run"]


def _positive(what: str, cast=float):
    def parse(text: str):
        try:
            value = cast(text)
        except ValueError:
            value = None
        if value is None or not value > 0 or value != value or value == float("inf"):
            raise argparse.ArgumentTypeError(f"must be {what}, not {text}")
        return value
    return parse


def _dbfs(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not -300 <= value <= 0:
        raise argparse.ArgumentTypeError(f"must be a noise level in dBFS, at most 0, not {text}")
    return value


def _pfa(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0 < value < 1:
        raise argparse.ArgumentTypeError(f"must be a probability in (0, 1), not {text}")
    return value


def _whole(what: str, low: int):
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = low - 1
        if value < low:
            raise argparse.ArgumentTypeError(f"must be {what}, not {text}")
        return value
    return parse


def add_arguments(p: argparse.ArgumentParser) -> None:
    from rast.model.radar import moments as mo
    from rast.model.radar import mtd as mt
    from rast.model.radar.assess import DEFAULT_NOISE_DBFS
    from rast.model.radar.sweep import AXES
    p.add_argument("config", help="TOML config (one windmill or a farm)")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--gates", metavar="FILE_OR_DIR",
                   help="a cosimulation's gates.npy (or the folder `rast cosim` wrote, with report.json): "
                        "assess the RTL's samples instead of the model's")
    p.add_argument("--physics", action="store_true",
                   help="the physics' samples, unquantised, instead of what the RTS plays")
    p.add_argument("--seconds", type=_positive("a positive number of seconds"), default=10.0,
                   help="radar time to simulate (default 10)")
    p.add_argument("--noise-dbfs", type=_dbfs, metavar="DBFS",
                   help=f"receiver noise per complex sample (default: the config's noise_dbfs, else "
                        f"{DEFAULT_NOISE_DBFS:g})")
    p.add_argument("--noise-seed", type=int, default=None, help="seed of the noise (default: fixed)")
    g = p.add_argument_group("MTD (air traffic)")
    g.add_argument("--cpi-pulses", type=_whole("a whole number of at least 2", 2), default=10,
                   help="pulses per CPI (default 10, as an ASR's MTD)")
    g.add_argument("--canceller", type=int, choices=(0, 2, 3), default=3,
                   help="MTI canceller pulses: 2, 3 (default) or 0 for none")
    g.add_argument("--nfft", type=_whole("a whole number of at least 2", 2), default=None,
                   help="Doppler filters (default: the pulses the canceller leaves, 8 of 10)")
    g.add_argument("--window", choices=mt.WINDOWS, default="hann", help="Doppler filter taper (default hann)")
    g.add_argument("--stagger-prf", type=_positive("a positive PRF in Hz"), metavar="HZ",
                   help="a second PRF for every other CPI (default: none)")
    g.add_argument("--reference-cells", type=_whole("an even whole number of at least 2", 2), default=16,
                   help="CA-CFAR reference cells, half on each side (default 16)")
    g.add_argument("--guard-cells", type=_whole("a whole number of at least 0", 0), default=1,
                   help="CA-CFAR guard cells on each side (default 1)")
    g.add_argument("--pfa", type=_pfa, default=1e-6, help="CFAR false-alarm probability per cell (default 1e-6)")
    g.add_argument("--map-weight", type=_pfa, default=0.125,
                   help="clutter map: weight of the newest scan (default 1/8)")
    g.add_argument("--map-pfa", type=_pfa, default=1e-6,
                   help="clutter map: false-alarm probability (default 1e-6)")
    g.add_argument("--scan-cpis", type=_whole("a positive whole number of CPIs", 1), default=None,
                   help="a stare radar's scan in CPIs (default: the whole run)")
    g.add_argument("--azimuth", metavar="FILE.npy",
                   help="the antenna's azimuth per pulse (degrees, one per pulse): dwells, revolutions, a PPI")
    g.add_argument("--beamwidth-deg", type=_positive("a positive number of degrees"), default=None,
                   help="3-dB beamwidth: the dwell of a turning antenna (default: the config's "
                        "beamwidth_deg, 1.4 when it has none)")
    g.add_argument("--gate-m", type=_positive("a positive number of metres"), default=None,
                   help="range gate spacing (default: the pulse's resolution c·τ/2)")
    w = p.add_argument_group("weather moments")
    w.add_argument("--moments-pulses", type=_whole("a whole number of at least 2", 2), default=64,
                   help="pulses per radial of a stare radar (default 64)")
    w.add_argument("--moments-filter", choices=mo.CLUTTER_FILTERS, default="mean",
                   help="clutter filter before the moments: mean (default: removes zero Doppler) or none")
    w.add_argument("--moments-engine", choices=mo.ENGINES, default="auto",
                   help="pulse-pair estimators: pyart (MeteoSwiss Py-ART, rast[weather]), numpy, or auto "
                        "(default: pyart when installed)")
    s = p.add_argument_group("sweeps")
    s.add_argument("--sweep", action="append", default=[], metavar="NAME=START:STOP:STEP",
                   help=f"sweep {', '.join(AXES)} (stop excluded, or V1,V2,...; rpm: values or factors "
                        "with x); repeat for a grid")
    s.add_argument("--layout", metavar="LAYOUT.csv", help="the farm's layout for wind_from (default: the one "
                   "the config's header names)")
    s.add_argument("--radar", metavar="LAT,LON,HEIGHT_M", help="the radar for --layout (default: the header's)")
    s.add_argument("--scheduler", metavar="ADDRESS", help="a running Dask scheduler (default: a local cluster)")
    s.add_argument("--workers", type=_whole("a whole number of at least 1", 1), default=None,
                   help="local cluster workers (default: the usable cores, at most 2)")
    s.add_argument("--threads", action="store_true", help="local cluster of threads instead of processes")


class _Progress:
    """``[rast assess]`` lines on stderr, at most one a second and only once
    the work has taken a second (as ``rast stream``'s)."""

    def __init__(self, what: str):
        self.what, self.start = what, time.monotonic()
        self.last = self.start

    def __call__(self, done: int, total: int) -> None:
        now = time.monotonic()
        if (now - self.start >= 1.0 and now - self.last >= 1.0) or (done == total and now - self.start >= 1.0):
            self.last = now
            print(f"[rast assess] {done / total:6.1%}  {done:>7,d}/{total:,d} {self.what}  "
                  f"{now - self.start:5.1f} s", file=sys.stderr, flush=True)


def _config(args, farm):
    from rast.errors import UserError
    from rast.model.radar import cfar as cf
    from rast.model.radar import moments as mo
    from rast.model.radar import mtd as mt
    from rast.model.radar.assess import AssessConfig
    from rast.model.radar.receiver import NOISE_SEED
    try:
        return AssessConfig(
            seconds=args.seconds,
            mtd=mt.MtdConfig(args.cpi_pulses, args.canceller, args.nfft, args.window, args.stagger_prf),
            cfar=cf.CfarConfig(args.reference_cells, args.guard_cells, args.pfa),
            clutter_map=cf.ClutterMapConfig(args.map_weight, args.map_pfa),
            moments=mo.MomentsConfig(args.moments_pulses, args.moments_filter, args.moments_engine),
            noise_dbfs=args.noise_dbfs, noise_seed=NOISE_SEED if args.noise_seed is None else args.noise_seed,
            physics=args.physics, gate_km=args.gate_m / 1e3 if args.gate_m else None,
            scan_cpis=args.scan_cpis,
            beamwidth_deg=args.beamwidth_deg if args.beamwidth_deg is not None else farm.scan.beamwidth_deg)
    except ValueError as error:
        option = {"cpi_pulses": "--cpi-pulses", "nfft": "--nfft", "reference_cells": "--reference-cells",
                  "pulses": "--moments-pulses"}
        text = str(error)
        for key, name in option.items():
            if text.startswith(key):
                text = name + text[len(key):]
        raise UserError(text) from None


def _print_summary(summary: dict) -> None:
    """One line per figure."""
    print(f"source              {summary['source']} samples, {summary['parameters']['pulses']:,} pulses, "
          f"{summary['parameters']['gates']} range gates of {summary['parameters']['gate_km'] * 1e3:.0f} m, "
          f"noise {summary['parameters']['noise_dbfs']:g} dBFS")
    print(f"CPIs and scans      {summary['cpis']} CPIs of {summary['parameters']['mtd']['cpi_pulses']} pulses "
          f"in {summary['scans']} scan(s)")
    print(f"false plots / scan  {summary['false_plots_per_scan_mean']:g} "
          f"(at turbine gates {summary['turbine_plots_per_scan_mean']:g}, elsewhere "
          f"{summary['other_plots_per_scan_mean']:g}; noise alone expects "
          f"{summary['noise_plots_per_scan_expected']:.3g}, 99.9 % within "
          f"{summary['noise_plots_per_scan_interval_99_9'][0]}-{summary['noise_plots_per_scan_interval_99_9'][1]})")
    print(f"detection fraction  {summary['detection_fraction_mean']:.3f} of the looks, mean over "
          f"{len(summary['turbines'])} turbines")
    for t in summary["turbines"]:
        frac = "n/a" if t["detection_fraction"] is None else f"{t['detection_fraction']:.3f}"
        print(f"  turbine {t['name']:<14} {t['range_km']:9.3f} km  detected in {frac} of {t['looks']} looks, "
              f"{t['plots']} plots")
    engine = summary["parameters"]["moments"]["engine_used"]
    print(f"weather moments     pulse pair ({engine}), "
          f"{summary['parameters']['moments']['clutter_filter']} clutter filter; per turbine gate:")
    fmt = lambda v, f: "n/a" if v is None else format(v, f)  # noqa: E731
    for g in summary["gates"]:
        print(f"  gate {g['range_km']:9.3f} km  reflectivity {fmt(g['reflectivity_db'], '6.1f')} dB  "
              f"velocity bias {fmt(g['velocity_bias_m_s'], '+.3f')} m/s  width {fmt(g['width_m_s'], '.3f')} m/s "
              f"(blades' spread {fmt(g['expected_width_m_s'], '.3f')} m/s)  {len(g['windmills'])} turbine(s)")
    print(f"velocity bias       at most {fmt(summary['velocity_bias_max_m_s'], '.3f')} m/s over the turbine gates")
    print(f"spectrum width      {fmt(summary['width_mean_m_s'], '.3f')} m/s, mean over the turbine gates")


def _read_azimuth(path):
    import numpy as np
    from rast.errors import UserError
    try:
        az = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as error:
        raise UserError(f"cannot read --azimuth {path}: {getattr(error, 'strerror', None) or error}") from None
    if az.ndim != 1 or not np.issubdtype(az.dtype, np.number) or np.iscomplexobj(az) or not np.isfinite(az).all():
        raise UserError(f"--azimuth {path} must hold one finite azimuth in degrees per pulse (a 1-D array), "
                        f"not {az.dtype} of shape {az.shape}")
    return az


def run(args) -> int:
    from rast.errors import UserError, check_output
    from rast.model.physics.config import ConfigError
    from rast.model.physics.farm import load_config

    check_output(args.out, folder=True, option="--out")
    farm = load_config(args.config)
    cfg = _config(args, farm)
    if args.sweep:
        return _run_sweep(args, farm, cfg)
    if args.layout or args.radar or args.scheduler or args.workers or args.threads:
        raise UserError("--layout, --radar, --scheduler, --workers and --threads go with --sweep")
    if args.gates and args.physics:
        raise UserError("--gates assesses the RTL's samples; --physics the model's physics: give one")
    from rast.model.radar.assess import assess, read_gates, write_outputs
    gates = report = None
    if args.gates:
        try:
            gates, report, _ = read_gates(args.gates)
        except ValueError as error:
            raise UserError(f"--gates: {error}") from None
    azimuth = _read_azimuth(args.azimuth) if args.azimuth else None
    try:
        scene, result, summary = assess(farm, cfg, gates=gates, report=report, azimuth_deg=azimuth,
                                        progress=_Progress("CPIs"))
    except ConfigError:
        raise
    except ValueError as error:
        raise UserError(str(error)) from None
    try:
        written = write_outputs(args.out, scene, result, summary, title=f"rast assess {Path(args.config).name}")
    except OSError as error:
        raise UserError(f"cannot write into {args.out}: {error.strerror or error}") from None
    _print_summary(summary)
    for path in written:
        print(f"wrote {Path(path).resolve()}")
    return 0


def _run_sweep(args, farm, cfg) -> int:
    from rast.errors import UserError
    from rast.model.files.outputs import write_text
    from rast.model.physics.config import read_config_file
    from rast.model.physics.synthesis import usable_cores
    from rast.model.radar import sweep as sw
    from rast.model.radar.assess_plot import draw_sweep
    from rast.model.files.outputs import atomic_file
    if args.gates or args.azimuth:
        raise UserError("--sweep makes the samples of every case from the model: it takes no --gates or --azimuth")
    try:
        axes = [sw.parse_axis(text) for text in args.sweep]
        values = sw.grid(axes)
    except sw.SweepError as error:
        raise UserError(str(error)) from None
    by_name = {a.name: a for a in axes}
    text = Path(args.config).read_text(encoding="utf-8-sig")
    base = read_config_file(args.config)
    radar = None
    if args.radar:
        try:
            radar = tuple(float(v) for v in args.radar.split(","))
        except ValueError:
            radar = ()
        if len(radar) != 3:
            raise UserError(f"--radar must be LAT,LON,HEIGHT_M (three numbers), not {args.radar}")
    if args.radar and not args.layout:
        raise UserError("--radar goes with --layout")
    try:
        recipe = sw.recipe_from_header(text, args.config, layout=args.layout, radar=radar)
    except sw.SweepError as error:
        raise UserError(str(error)) from None
    if "wind_from" in by_name:
        if recipe is None:
            raise UserError("--sweep wind_from needs the farm's turbine layout: a config written by `rast farm` "
                            "(its header names the layout), or --layout LAYOUT.csv --radar LAT,LON,HEIGHT_M")
        if not recipe.layout_path.is_file():
            raise UserError(f"the layout {recipe.layout_path} is not there: give --layout LAYOUT.csv")
        from rast.model.physics.layout import read_layout
        read_layout(recipe.layout_path)          # its problems before any case runs
    workers = args.workers or max(1, min(2, usable_cores()))
    if args.scheduler is None and workers > max(1, usable_cores()):
        raise UserError(f"--workers {workers} is more than the {usable_cores()} usable core(s)")
    tasks = []
    try:
        for case in values:
            data, notes = sw.case_data(base, case, by_name, recipe)
            tasks.append((data, cfg, case, notes))
    except sw.SweepError as error:
        raise UserError(str(error)) from None
    print(f"sweep of {len(tasks)} case(s) over {', '.join(a.name for a in axes)} on "
          + (f"the Dask scheduler {args.scheduler}" if args.scheduler else
             f"a local Dask cluster of {workers} {'thread' if args.threads else 'process'}(es)"), flush=True)
    try:
        results = sw.run_sweep(tasks, scheduler=args.scheduler, workers=workers, processes=not args.threads,
                               progress=_Progress("cases"))
    except sw.SweepError as error:
        raise UserError(str(error)) from None
    out = Path(args.out)
    (out / "cases").mkdir(parents=True, exist_ok=True)
    names = [a.name for a in axes]
    rows = []
    for k, res in enumerate(results):
        row = {a.name: res["values"][a.name] for a in axes}
        row.update({key: res.get(key) for key in sw.ROW_FIGURES})
        row["error"] = res.get("error", "")
        row["notes"] = "; ".join(res.get("notes", []))
        rows.append(row)
        write_text(out / "cases" / f"case_{k:04d}.json", json.dumps(res, indent=2) + "\n")
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=[*names, *sw.ROW_FIGURES, "error", "notes"], lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: ("" if v is None else v) for k, v in row.items()})
    write_text(out / "sweep.csv", buf.getvalue())
    with atomic_file(out / "sweep.png") as png:
        draw_sweep(png, [r for r in rows if not r["error"]], names, title=f"rast assess {Path(args.config).name}")
    for row in rows:
        case = ", ".join(f"{n} {by_name[n].label(row[n])}" for n in names)
        if row["error"]:
            print(f"  {case}: refused: {row['error']}")
        else:
            print(f"  {case}: {row['false_plots_per_scan_mean']:g} false plots/scan, detection fraction "
                  f"{row['detection_fraction_mean']:.3f}, velocity bias {row['velocity_bias_max_m_s']} m/s, "
                  f"width {row['width_mean_m_s']} m/s")
    failed = sum(1 for r in rows if r["error"])
    print(f"{len(rows) - failed} case(s) assessed" + (f", {failed} refused" if failed else ""))
    for name in ("sweep.csv", "sweep.png"):
        print(f"wrote {(out / name).resolve()}")
    print(f"wrote {len(rows)} case summaries to {(out / 'cases').resolve()}")
    return 0
