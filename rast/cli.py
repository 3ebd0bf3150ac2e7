"""The ``rast`` command: streams, previews and, from the gateware side, Verilog."""

from __future__ import annotations

import argparse
import os
import re
import sys
import tempfile
from pathlib import Path

from rast.model.config import ConfigError, load_config
from rast.errors import UserError, check_output, positive_hz


def _print_streams(farm_streams) -> None:
    header = f"{'windmill':<14}{'range km':>9}{'rpm':>6}{'words':>9}{'rate Hz':>11}{'fmax Hz':>9}{'delay':>7}{'gain':>8}{'SNR dB':>8}"
    print(header)
    for s in farm_streams.streams:
        w = s.windmill
        print(f"{w.name:<14}{w.range_km:>9.3f}{w.rpm:>6g}{s.plan.length:>9}{s.plan.stream_rate_hz:>11.1f}"
              f"{s.plan.max_doppler_hz:>9.0f}{s.delay_samples:>7}{s.gain:>8.4f}{s.snr_db:>8.1f}")


def cmd_stream(args) -> int:
    from rast.errors import read_build
    from rast.model.ramfiles import write_farm_files
    from rast.model.regmap import manifest_to_register_writes
    from rast.model.stream import build_farm_streams, farm_for_build

    check_output(args.out, folder=True, option="--out")
    farm = load_config(args.config)
    contract = read_build(args.build) if args.build else None
    if contract is not None:
        farm = farm_for_build(farm, contract)
    farm_streams = build_farm_streams(farm)
    if contract is not None:
        try:
            manifest_to_register_writes(farm_streams.manifest(), contract, target="board")
        except ValueError as error:
            raise UserError(f"the streams do not fit the build {args.build}: {error}") from None
    try:
        written = write_farm_files(farm_streams, args.out, build=contract)
    except OSError as error:        # e.g. a full disk; nothing was moved into place
        raise UserError(f"cannot write into {args.out}: {error.strerror or error}") from None
    _print_streams(farm_streams)
    need = farm_streams.smallest_contract()
    print(f"needs a build with at least {need.channels} channel(s), stream depth {need.stream_depth} "
          f"words, common delay {need.max_delay}, delay increment {need.max_increment}, "
          f"{need.interpolation} interpolation, {farm.sample_rate_mhz:g} MHz"
          + (f"; sized for {args.build}" if contract is not None else ""))
    print(f"wrote {len(written)} files to {Path(args.out).resolve()}:")
    for name in sorted(written):
        print(f"  {written[name]}")
    return 0


def cmd_preview(args) -> int:
    from rast.model.plot import save_preview
    from rast.model.radar import receive, spectrogram
    from rast.model.sfdr import farm_sfdr
    from rast.model.stream import build_farm_streams

    check_output(args.out, folder=False, option="--out")
    farm = load_config(args.config)
    prf = farm.radar.prf_hz
    pulses, cpi_pulses = round(args.seconds * prf), round(farm.radar.cpi_ms * 1e-3 * prf)
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
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    # Draw into a temporary file and move it into place: the PNG appears whole or not at all.
    fd, tmp = tempfile.mkstemp(suffix=".png", dir=out.parent)
    os.close(fd)
    try:
        save_preview(farm, bins, spectra, tmp, dynamic_range_db=args.dynamic_range, zoom_hz=args.zoom,
                     sfdr=measured)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)   # mkstemp made it private
        os.replace(tmp, out)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
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
    print(f"wrote {out.resolve()}")
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
                   help="report.json of the bitstream to load: streams sized for its stream depth, "
                        "interpolation and channels; refused if its sample rate is not the config's")
    p.set_defaults(func=cmd_stream)

    p = sub.add_parser("preview", help="draw the micro-Doppler spectrogram the radar will see")
    p.add_argument("config", help="TOML config (one windmill or a farm)")
    p.add_argument("--out", required=True, help="PNG file to write")
    p.add_argument("--seconds", type=_number("a positive number of seconds"), default=10.0,
                   help="radar time to simulate (default 10)")
    p.add_argument("--overlap", type=_number("a fraction in [0, 1)", 0.0, 1.0, low_inclusive=True),
                   default=0.0,
                   help="fraction of a CPI shared by consecutive frames (default 0, as a radar)")
    p.add_argument("--dynamic-range", type=_number("a positive number of dB"), default=90.0,
                   help="colour scale depth in dB (default 90: spurs down to the SFDR a replay should reach)")
    p.add_argument("--zoom", type=positive_hz, default=None, metavar="HZ",
                   help="draw only Doppler ±HZ (default: the whole band ±PRF/2)")
    p.add_argument("--replay", action="store_true",
                   help="show the quantised stream words as the RTS replays them, not the physics")
    p.set_defaults(func=cmd_preview)

    for module_name in ("verilog", "cosim", "build", "load"):
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
