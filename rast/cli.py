"""The ``rast`` command: streams, previews and, from the gateware side, Verilog."""

from __future__ import annotations

import argparse
import os
import re
import sys
from pathlib import Path

# Before numpy is imported: no transparent-hugepage advice for large arrays.
# Under the common "defrag = madvise" kernel setting every fresh hugepage is
# compacted synchronously; touching seed mode's ~1 GB of new arrays took 2 to
# 3 s more that way (docs/stream_synthesis.md). A value the user set wins.
os.environ.setdefault("NUMPY_MADVISE_HUGEPAGE", "0")

from rast.model.physics.config import ConfigError
from rast.model.physics.farm import load_config  # noqa: E402
from rast.errors import UserError, check_output, positive_hz  # noqa: E402


def _print_streams(farm_streams) -> None:
    header = f"{'windmill':<14}{'range km':>9}{'rpm':>8}{'words':>9}{'rate Hz':>11}{'fmax Hz':>9}{'delay':>7}{'gain':>8}{'SNR dB':>8}"
    print(header)
    for s in farm_streams.streams:
        w = s.windmill
        print(f"{w.name:<14}{w.range_km:>9.3f}{w.rpm:>8.5g}{s.plan.length:>9}{s.plan.stream_rate_hz:>11.1f}"
              f"{s.plan.max_doppler_hz:>9.0f}{s.delay_samples:>7}{s.gain:>8.4f}{s.snr_db:>8.1f}")


class _StreamProgress:
    """``[rast stream]`` lines on stderr, at most one a second and only once the
    work has taken a second: seed-mode streams take seconds, most farms do not."""

    def __init__(self, farm):
        import threading
        import time
        from rast.model.physics.stream import plan_stream
        self.total = sum(plan_stream(w, farm).length for w in farm.windmills)
        self.clock = time.monotonic
        self.start = self.last = self.clock()
        self.done = {w.name: 0 for w in farm.windmills}
        self.lock = threading.Lock()

    def __call__(self, name, done, total):
        with self.lock:
            self.done[name] = done
            now = self.clock()
            if now - self.start >= 1.0 and now - self.last >= 1.0 and self.total:
                self.last = now
                count = sum(self.done.values())
                print(f"[rast stream] {count / self.total:6.1%}  {count:>11,d}/{self.total:,d} "
                      f"samples  {now - self.start:5.1f} s", file=sys.stderr, flush=True)


def _print_synthesis(farm_streams) -> None:
    """How each period was made, where it was not plain direct evaluation
    (docs/stream_synthesis.md)."""
    for s in farm_streams.streams:
        syn = s.synthesis
        if syn is None or syn.check_error_dbc is None:
            continue
        if syn.method == "grid":
            print(f"{s.windmill.name}: synthesised from every {syn.grid_step}th sample, "
                  f"midpoint check {syn.check_error_dbc:.1f} dBc RMS")
        else:
            print(f"{s.windmill.name}: evaluated directly: {syn.reason}")


def _default_build_fit(farm_streams) -> str:
    """Whether the streams load into the default bitstream (``make bitstream``),
    or the first thing that does not fit."""
    import dataclasses
    from rast.gateware.build import BuildConfig
    from rast.model.contract.loadplan import channel_regions, manifest_to_register_writes, pool_layout
    cfg = BuildConfig()
    c = dataclasses.replace(cfg.contract(), sample_rate_hz=round(cfg.sample_rate_mhz * 1e6))
    what = (f"the default bitstream ({c.channels} channels, {cfg.sample_rate_mhz:g} MS/s, a stream pool "
            f"of {c.pool_words} words, common delay {c.max_delay} + window {c.max_tap} samples)")
    manifest = farm_streams.manifest()
    try:
        manifest_to_register_writes(manifest, c, target="board")
        channels = manifest["registers"]["channels"]
        pool_layout([ch["length"] for ch in channels], c.pool_words, channel_regions(channels))
    except ValueError as error:
        return f"does not fit {what}: {error}"
    return f"fits {what}"


def cmd_stream(args) -> int:
    from rast.errors import read_build
    from rast.model.physics.beam_window import farm_follow_plan
    from rast.model.files.ramfiles import make_farm_files
    from rast.model.contract.loadplan import follow_load, manifest_to_register_writes
    from rast.model.physics.stream import farm_for_build

    check_output(args.out, folder=True, option="--out")
    farm = load_config(args.config)
    contract = read_build(args.build) if args.build else None
    if contract is not None:
        farm = farm_for_build(farm, contract)
        if contract.follow_rows:        # the channels the scene needs at once, before any stream is made
            try:
                farm_follow_plan(farm, contract, channels=contract.channels)
            except ValueError as error:
                raise UserError(f"the scene does not fit the build {args.build}: {error}") from None
    progress = _StreamProgress(farm)

    def fits_the_build(farm_streams):       # before any file is moved into --out
        if contract is not None:
            try:
                if contract.follow_rows:
                    follow_load(farm_streams.manifest(), contract,
                                streams=[s.words_u32() for s in farm_streams.streams])
                else:
                    manifest_to_register_writes(farm_streams.manifest(), contract, target="board")
            except ValueError as error:
                raise UserError(f"the streams do not fit the build {args.build}: {error}") from None

    # The files are written while the streams are computed (rast.model.files.ramfiles).
    try:
        farm_streams, written = make_farm_files(farm, args.out, build=contract, formats=args.format,
                                                progress=progress, check=fits_the_build)
    except OSError as error:        # e.g. a full disk; nothing was moved into place
        raise UserError(f"cannot write into {args.out}: {error.strerror or error}") from None
    _print_streams(farm_streams)
    _print_synthesis(farm_streams)
    sharing = farm_streams.sharing_summary()
    if sharing:
        print(sharing)
    for warning in farm_streams.warnings:
        print(f"rast stream: warning: {warning}", file=sys.stderr)
    if farm.scan.turning:
        print(f"antenna scan {farm.scan.mode!r}: the streams are those of a staring antenna; the manifest "
              "carries each turbine's azimuth and the pattern, which a bitstream built with --scan applies "
              "(one without it refuses this manifest)")
        print(farm_follow_plan(farm, contract or default_contract(farm)))    # (timed on the build's)
    print(farm_streams.echo_sum().describe())
    try:
        need = farm_streams.smallest_contract()
    except ValueError as error:     # e.g. seed mode's millions of words: no replay block holds them
        print(f"no replay build holds these streams: {error}")
    else:
        print(f"needs a build with at least {need.channels} channel(s), a stream pool of "
              f"{need.pool_words} words, common delay {need.max_delay}, delay window "
              f"{need.max_tap}, {need.interpolation} interpolation, {farm.sample_rate_mhz:g} MHz"
              + (f"; sized for {args.build}" if contract is not None else ""))
        if contract is None:
            print(_default_build_fit(farm_streams))
    print(f"wrote {len(written)} files to {Path(args.out).resolve()}:")
    for name in sorted(written):
        print(f"  {written[name]}")
    return 0


def cmd_preview(args) -> int:
    from rast.model.files.outputs import atomic_file
    from rast.model.radar.plot import MAX_PANELS, save_preview, save_range_doppler
    from rast.model.radar.receiver import MAX_PREVIEW_SAMPLES, range_bins, receive, spectrogram
    from rast.model.radar.sfdr import farm_sfdr
    from rast.model.physics.stream import build_farm_streams

    check_output(args.out, folder=False, option="--out")
    farm = load_config(args.config)
    if args.ppi:
        return _preview_ppi(args, farm)
    if args.mti is not None:
        raise UserError("--mti is a PPI option: give --ppi as well")
    args.seconds = 10.0 if args.seconds is None else args.seconds
    prf = farm.radar.prf_hz
    pulses, cpi_pulses = round(args.seconds * prf), round(farm.radar.cpi_ms * 1e-3 * prf)
    samples = pulses * len(range_bins(farm))
    if samples > MAX_PREVIEW_SAMPLES:
        raise UserError(f"--seconds {args.seconds:g} asks for {pulses:,} pulses at {prf:g} Hz in "
                        f"{len(range_bins(farm))} range bin(s), {samples:.3g} samples, more than the "
                        f"{MAX_PREVIEW_SAMPLES:,} a preview draws: give at most "
                        f"{MAX_PREVIEW_SAMPLES / len(range_bins(farm)) / prf:.4g} s")
    if pulses < max(2, cpi_pulses):
        raise UserError(f"--seconds {args.seconds:g} gives {pulses} pulses at {prf:g} Hz, "
                        f"less than one CPI of {farm.radar.cpi_ms:g} ms ({cpi_pulses} pulses)")
    farm_streams = build_farm_streams(farm) if args.replay else None
    t, bins, samples = receive(farm, args.seconds, farm_streams)
    cpi_s = farm.radar.cpi_ms * 1e-3
    spectra = [spectrogram(row, farm.radar.prf_hz, cpi_s, overlap=args.overlap) for row in samples]
    try:
        measured, unmeasured = farm_sfdr(farm, samples, bins), None
    except ValueError as error:      # e.g. a maximum Doppler beyond PRF/2 leaves no band outside
        measured, unmeasured = None, str(error)
    map_view = args.range_doppler or len(bins) > MAX_PANELS
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    try:                  # the PNG appears whole or not at all (rast.model.files.outputs)
        with atomic_file(out) as png:
            if map_view:
                save_range_doppler(farm, bins, spectra, png, dynamic_range_db=args.dynamic_range,
                                   zoom_hz=args.zoom)
            else:
                save_preview(farm, bins, spectra, png, dynamic_range_db=args.dynamic_range,
                             zoom_hz=args.zoom, sfdr=measured)
    except OSError as error:
        raise UserError(f"cannot write {out}: {error.strerror or error}") from None
    res = spectra[0].resolution_hz
    print(f"{len(bins)} range bin(s), {t.size} pulses, {spectra[0].times_s.size} CPIs, "
          f"Doppler resolution {res:g} Hz{' (replayed stream words)' if args.replay else ''}")
    if measured is None:
        print(f"SFDR not measured: {unmeasured}")
    else:
        print(f"SFDR over the whole band ±{farm.radar.prf_hz / 2:g} Hz outside each bin's ±max Doppler "
              f"+ 6 bins, worst of {measured[0].per_cpi_db.size} CPI(s), Blackman-Harris window:")
        for b, r in zip(bins, measured):
            print(f"  SFDR range bin {b.range_km:g} km: {r.sfdr_db:.1f} dB (highest spur {r.spur_hz:+.0f} Hz "
                  f"in CPI {r.cpi_index})")
        k = min(range(len(measured)), key=lambda i: measured[i].sfdr_db)
        print(f"worst SFDR {measured[k].sfdr_db:.1f} dB (range bin {bins[k].range_km:g} km)")
    if map_view:
        print(f"drew the range-Doppler map (peak over {spectra[0].times_s.size} CPIs per range bin)"
              + ("" if args.range_doppler else f": more than {MAX_PANELS} range bins"))
    print(f"wrote {out.resolve()}")
    return 0


def default_contract(farm):
    """The default following build at ``farm``'s sample rate (the largest
    turbine table): what the guard of a board following the beam is timed on
    when no build is named."""
    import dataclasses
    from rast.gateware.build import BuildConfig
    from rast.model.contract.fixedpoint import ReplayContract
    contract = BuildConfig(sample_rate_mhz=farm.sample_rate_mhz, pool="sdram", scan=True,
                           follow_rows=ReplayContract.MAX_FOLLOW_ROWS).contract()
    return dataclasses.replace(contract, sample_rate_hz=round(farm.sample_rate_hz))


def _follow_panel(farm) -> dict:
    """The PPI's second panel for a scene round the radar: the channels a
    board following the beam holds at each beam azimuth (none where the
    pattern's floor lies above ``assign_below_db``)."""
    from rast.model.physics.beam_window import follow_rows_held
    held = follow_rows_held(farm, default_contract(farm))
    if held is None:
        return {}
    peak = int(held.argmax())
    return {"held": held, "held_caption": f"channels held by a board following the beam (docs/beam_following.md): "
            f"at most {int(held.max())}, beam at {peak * 360 / held.size:.1f}°"}


def _preview_ppi(args, farm) -> int:
    """``rast preview --ppi``: one revolution (or ``--seconds``) as the radar's PPI."""
    from rast.model.files.outputs import atomic_file
    from rast.model.radar.assess import AssessConfig, simulate
    import numpy as np
    from rast.model.radar.ppi import dwell_image, save_ppi

    scan = farm.scan
    for given, option in ((args.zoom, "--zoom"), (args.range_doppler, "--range-doppler"), (args.overlap, "--overlap")):
        if given:
            raise UserError(f"{option} is a spectrogram option; --ppi draws dwells of the beam")
    if not scan.turning:
        raise UserError(f"--ppi draws a turning antenna's revolution, but {args.config} stares "
                        "(scan_mode = \"stare\"): set scan_mode = \"free\" or \"acp\" and scan_rpm")
    radar = farm.radar
    mti = f", {args.mti}-pulse MTI" if args.mti else ""
    if args.gates:
        if args.replay or args.seconds is not None:
            raise UserError("--gates draws the cosimulation's own pulses: leave out --replay and --seconds")
        samples, times_s, edges, noise_dbfs = _cosim_gates(args.gates, radar.prf_hz)
        seconds = float(times_s[-1] + 1 / radar.prf_hz) if times_s.size else 0.0
        what = f"RTL samples of the cosimulation in {args.gates}, no noise"
    else:
        seconds = scan.revolution_s if args.seconds is None else args.seconds
        try:
            scene = simulate(farm, AssessConfig(seconds=seconds, physics=not args.replay))
        except ValueError as error:
            raise UserError(str(error)) from None
        samples, times_s, noise_dbfs = scene.samples, scene.times_s, scene.noise_dbfs
        grid = scene.grid
        edges = (grid.first + np.arange(grid.count + 1)) * grid.spacing_km
        what = f"{'replayed stream words' if args.replay else 'physics'}, noise {noise_dbfs:g} dBFS"
    try:
        image = dwell_image(samples, scan.beam_azimuth_deg(times_s), scan.beamwidth_deg, args.mti or 0)
    except ValueError as error:
        raise UserError(str(error)) from None
    title = (f"{Path(args.config).name}: {seconds:g} s at {scan.rpm:g} rpm, {scan.beamwidth_deg:g}° beam, "
             f"{scan.dwell_pulses(radar.prf_hz):.1f} pulses per dwell{mti}\n"
             f"{what}, {radar.frequency_mhz / 1e3:g} GHz, PRF {radar.prf_hz:g} Hz")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    try:
        with atomic_file(out) as png:
            save_ppi(png, image, edges, turbines=[(w.azimuth_deg, w.range_km) for w in farm.windmills],
                     dynamic_range_db=args.dynamic_range,
                     floor_db=None if noise_dbfs is None else noise_dbfs - 5, title=title,
                     **_follow_panel(farm))
    except OSError as error:
        raise UserError(f"cannot write {out}: {error.strerror or error}") from None
    looked = image.pulses > 0
    lit = np.where(looked, np.nanmax(np.where(looked[:, None], image.power_db(), 0.0), axis=1), -np.inf)
    print(f"{times_s.size} pulses over {seconds:g} s, {int(looked.sum())} of {image.cells} dwells of "
          f"{scan.beamwidth_deg:g}° looked at, {image.pulses[looked].mean():.1f} pulses each{mti}")
    strongest = int(np.nanargmax(lit))
    print(f"strongest dwell {strongest * scan.beamwidth_deg:g}-{(strongest + 1) * scan.beamwidth_deg:g}°: "
          f"{lit[strongest]:.1f} dBFS mean power"
          + ("" if noise_dbfs is None else f"; noise {noise_dbfs:g} dBFS"))
    print(f"wrote {out.resolve()}")
    return 0


def _cosim_gates(folder, prf_hz):
    """A `rast cosim` folder's gates as a PPI's input: ``(samples (gates,
    pulses) in full-scale units, pulse times, range edges, None)``; each gate
    a ring 100 m deep, the ranges between them empty."""
    import json
    import numpy as np
    from rast.model.contract.fixedpoint import OUTPUT_WIDTH
    folder = Path(folder)
    try:
        gates = np.load(folder / "gates.npy")
        report = json.loads((folder / "report.json").read_text())
        ranges = [float(r) for r in report["gates_km"]]
    except (OSError, ValueError, KeyError) as error:
        raise UserError(f"--gates {folder}: not a `rast cosim` output folder (gates.npy, report.json): "
                        f"{error}") from None
    if gates.ndim != 2 or gates.shape[1] != len(ranges):
        raise UserError(f"--gates {folder}: gates.npy has shape {gates.shape}, report.json {len(ranges)} gates")
    if abs(float(report.get("prf_hz", prf_hz)) - prf_hz) > 1e-6 * prf_hz:
        raise UserError(f"--gates {folder} was cosimulated at a PRF of {report['prf_hz']:g} Hz, the config's "
                        f"is {prf_hz:g} Hz: not this config's cosimulation")
    half = 0.05
    edges, rows = [], []
    for g, r in enumerate(ranges):               # ascending: the gates of `rast cosim`
        if edges and r - half > edges[-1]:
            rows.append(None)                     # the gap to this gate: empty
        if not edges or r - half > edges[-1]:
            edges.append(r - half)
        edges.append(r + half)
        rows.append(g)
    full_scale = float(1 << (OUTPUT_WIDTH - 1))
    samples = np.array([gates[:, g] / full_scale if g is not None else np.full(gates.shape[0], np.nan)
                        for g in rows])
    return samples, np.arange(gates.shape[0]) / prf_hz, np.array(edges), None


def _formats(text: str) -> tuple[str, ...]:
    """argparse type of --format: a comma-separated list of RAM file formats."""
    from rast.model.files.ramfiles import FORMATS
    chosen = tuple(f.strip().lower() for f in text.split(",") if f.strip())
    bad = [f for f in chosen if f not in FORMATS]
    if not chosen or bad:
        raise argparse.ArgumentTypeError(f"must be a comma-separated list of {', '.join(FORMATS)}, not {text}")
    return chosen


def cmd_import(args) -> int:
    from rast.model.physics.config import Radar
    from rast.model.contract.fixedpoint import min_stream_length
    from rast.model.files.ramfiles import write_farm_files
    from rast.model.physics import recording as rec
    from rast.model.radar.receiver import spectrogram_correlation

    check_output(args.out, folder=True, option="--out")
    if args.blades < 1:
        raise UserError(f"--blades must be at least 1, not {args.blades}")
    try:
        recording = rec.read_recording(args.recording)
        prf = args.prf or recording.sample_rate_hz
        if prf is None:
            raise UserError("give the recording's pulse repetition frequency with --prf HZ")
        cpi_pulses = round(args.cpi * 1e-3 * prf)
        if cpi_pulses < 2:
            raise UserError(f"a CPI of {args.cpi:g} ms at a PRF of {prf:g} Hz holds {cpi_pulses} pulse(s); "
                            f"the correlation check's spectrograms need at least 2: give --cpi "
                            f"{2e3 / prf:g} or more")
        if cpi_pulses > recording.samples.size:
            raise UserError(f"the recording holds {recording.samples.size} pulses, less than one CPI of "
                            f"{cpi_pulses} ({args.cpi:g} ms at {prf:g} Hz): give a shorter --cpi")
        if args.period is not None and args.period * prf < 2:
            raise UserError(f"--period {args.period:g} s is shorter than two pulse intervals at {prf:g} Hz: "
                            f"a period must hold at least two pulses")
        if args.prf and recording.sample_rate_hz and abs(args.prf - recording.sample_rate_hz) > 1e-9 * prf:
            raise UserError(f"--prf {args.prf:g} Hz contradicts the recording's core:sample_rate "
                            f"({recording.sample_rate_hz:g} Hz)")
        if args.period is not None:
            period_s, how = args.period, "given"
        else:
            estimate = rec.estimate_period(recording.samples, prf)
            period_s = estimate.period_s
            how = (f"estimated {estimate.method}ly at {estimate.multiple} periods, "
                   f"correlation {estimate.correlation:.3f}")
        rate = args.rate or prf
        rec.stream_increment(rate, args.sample_rate, args.interpolation)   # before the work
        length = max(2, round(rate * period_s))
        shortest = min_stream_length(args.interpolation)
        if length < shortest:
            raise UserError(f"one period of {period_s:.4g} s at {rate:g} words/s is {length} words; "
                            f"{args.interpolation} interpolation plays streams of at least {shortest}: "
                            f"give --rate {shortest / period_s:.6g} or more")
        loop = rec.make_loop(recording.samples, prf, period_s, length, min(prf, length / period_s))
        frequency_mhz = args.radar_frequency or (recording.frequency_hz or 5350e6) / 1e6
        stem = Path(args.recording).name.split(".")[0]
        name = args.name or re.sub(r"[^A-Za-z0-9_.-]", "_", stem) or "recording"
        if not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9_.-]*", name):
            raise UserError(f"--name must be a file-name-safe string (letters, digits, _ . -), not {name!r}")
        farm_streams = rec.recording_streams(
            loop, name=name, range_km=args.range, num_blades=args.blades,
            sample_rate_mhz=args.sample_rate, radar=Radar(frequency_mhz, prf, cpi_ms=args.cpi),
            interpolation=args.interpolation)
        correlation = spectrogram_correlation(recording.samples, loop, farm_streams)
    except rec.RecordingError as error:
        raise UserError(f"{args.recording}: {error}") from None
    try:
        written = write_farm_files(farm_streams, args.out)
    except OSError as error:
        raise UserError(f"cannot write into {args.out}: {error.strerror or error}") from None
    w = farm_streams.streams[0].windmill
    print(f"period {period_s:.6g} s ({how}): {w.rpm:.5g} rpm with {w.num_blades} blade(s); "
          f"{loop.periods} whole period(s) averaged into {length} words")
    print(f"spectrogram correlation, replayed stream vs recording (dB, 40 dB range): {correlation:.4f}")
    _print_streams(farm_streams)
    print(f"wrote {len(written)} files to {Path(args.out).resolve()}:")
    for file in sorted(written):
        print(f"  {written[file]}")
    return 0


def _number(what: str, low: float = 0.0, high: float = float("inf"), *, low_inclusive=False):
    """An argparse type: a float in (low, high) ([low, high) with ``low_inclusive``)."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = float("nan")
        if not ((low <= value if low_inclusive else low < value) and value < high):
            raise argparse.ArgumentTypeError(f"must be {what}, not {text}")
        return value
    return parse


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="rast", description="RAdar Simulation of wind Turbines")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("stream", help="write the modulation streams, RAM files and manifest")
    p.add_argument("config", help="TOML config (one windmill or a farm)")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--build", metavar="REPORT",
                   help="report.json of the bitstream to load: streams sized for its stream pool, "
                        "interpolation and channels; refused if its sample rate is not the config's")
    p.add_argument("--format", type=_formats, default=None, metavar="LIST",
                   help="RAM files to write, comma-separated from hex, bin, npy, coe (Xilinx), mif (Intel); "
                        "default hex,bin,npy; .hex is always written (rast load reads it)")
    p.set_defaults(func=cmd_stream)

    p = sub.add_parser("preview", help="draw the micro-Doppler spectrogram the radar will see")
    p.add_argument("config", help="TOML config (one windmill or a farm)")
    p.add_argument("--out", required=True, help="PNG file to write")
    p.add_argument("--seconds", type=_number("a positive number of seconds"), default=None,
                   help="radar time to simulate (default 10; with --ppi one revolution)")
    p.add_argument("--overlap", type=_number("a fraction in [0, 1)", 0.0, 1.0, low_inclusive=True),
                   default=0.0,
                   help="fraction of a CPI shared by consecutive frames (default 0, as a radar)")
    p.add_argument("--dynamic-range", type=_number("a positive number of dB"), default=90.0,
                   help="colour scale depth in dB (default 90: spurs down to the SFDR a replay should reach; "
                        "with --ppi, down to the noise at most)")
    p.add_argument("--zoom", type=positive_hz, default=None, metavar="HZ",
                   help="draw only Doppler ±HZ (default: the whole band ±PRF/2)")
    p.add_argument("--replay", action="store_true",
                   help="show the quantised stream words as the RTS replays them, not the physics")
    p.add_argument("--range-doppler", action="store_true",
                   help="one range-Doppler map (each range bin's peak over the CPIs) instead of a "
                        "spectrogram per range bin; the default beyond 8 range bins")
    p.add_argument("--ppi", action="store_true",
                   help="a turning antenna's PPI instead: each range gate's power over each dwell")
    p.add_argument("--mti", type=int, choices=(2, 3), default=None,
                   help="with --ppi: a 2- or 3-pulse MTI canceller before the integration")
    p.add_argument("--gates", metavar="DIR", default=None,
                   help="with --ppi: draw the RTL's samples of a `rast cosim` of this config (its --out "
                        "folder: gates.npy, report.json) instead of the model's")
    p.set_defaults(func=cmd_preview)

    p = sub.add_parser("import", help="make a recorded slow-time I/Q series into a stream")
    p.add_argument("recording", help=".npy (complex), .sigmf-meta/.sigmf-data, or .csv (I, Q)")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--prf", type=positive_hz, help="the recording's pulse repetition frequency "
                   "(default: the SigMF core:sample_rate)")
    p.add_argument("--rate", type=positive_hz, help="stream words per second (default: the PRF)")
    p.add_argument("--period", type=_number("a positive number of seconds"),
                   help="the repeat period in seconds instead of estimating it")
    p.add_argument("--blades", type=int, default=3, help="blades, to turn the period into rpm (default 3)")
    p.add_argument("--range", type=_number("a positive range in km"), default=2.0,
                   help="the turbine's range in km: its delay (default 2)")
    p.add_argument("--sample-rate", type=_number("a positive rate in MHz"), default=20.0,
                   help="the RTS sample rate in MHz (default 20)")
    p.add_argument("--radar-frequency", type=_number("a positive frequency in MHz"),
                   help="MHz, for the manifest (default: SigMF core:frequency, else 5350)")
    p.add_argument("--cpi", type=_number("a positive number of ms"), default=100.0,
                   help="CPI of the correlation check's spectrograms in ms (default 100)")
    p.add_argument("--interpolation", choices=("fir", "linear", "hold"), default="fir",
                   help="the replay block's interpolation (default fir)")
    p.add_argument("--name", help="stream name (default: the recording's file name)")
    p.set_defaults(func=cmd_import)

    for module_name in ("verilog", "cosim", "build", "load", "farm", "assess"):
        try:
            module = __import__(f"rast.{module_name}", fromlist=["add_arguments", "run"])
        except ImportError:
            continue
        summary = (module.__doc__ or "").strip().splitlines()[0]
        summary = re.sub(r"^``rast \w+``:\s*", "", summary).rstrip(".")
        p = sub.add_parser(module_name, help=summary)
        module.add_arguments(p)
        p.set_defaults(func=module.run)
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args) or 0
    except (ConfigError, UserError) as error:     # user mistakes; anything else is a bug
        print(f"rast {args.command}: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
