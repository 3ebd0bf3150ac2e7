"""``rast farm``: write a farm config from a turbine layout, the radar and the wind.

``rast farm LAYOUT.csv --radar LAT,LON,HEIGHT_M --wind-from DEG --out farm.toml``
reads the layout (USWTDB columns, lon/lat or x/y in metres), places every
turbine as the radar sees it (``rast.model.physics.layout``) and writes one
``[[windmill]]`` per turbine, ready for ``rast stream``; see
``docs/farm_layouts.md``. This module only parses the arguments and calls the model.
"""

from __future__ import annotations

import argparse
import math
import tomllib
from pathlib import Path

from rast.errors import UserError, check_output, positive_hz
from rast.model.files.outputs import write_text

__all__ = ["add_arguments", "run"]


def _triple(text: str) -> tuple[float, float, float]:
    """argparse type of --radar: three numbers A,B,HEIGHT_M."""
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 3 or not all(map(math.isfinite, values)):
        raise argparse.ArgumentTypeError(f"must be three numbers LAT,LON,HEIGHT_M (or X,Y,HEIGHT_M "
                                         f"in metres for an x/y layout), not {text}")
    return values


def _real(what: str, accept):
    """An argparse type: a number for which ``accept`` holds (NaN for none)."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = float("nan")
        if not accept(value):
            raise argparse.ArgumentTypeError(f"must be {what}, not {text}")
        return value
    return parse


def _number(what: str):
    """An argparse type: a positive finite number."""
    return _real(what, lambda v: 0 < v < float("inf"))


def _words(text: str) -> int:
    """An argparse type: a positive whole number of words."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive whole number of words, not {text}")
    return value


#: argparse types: a bearing in [0, 360) degrees, an angle in [0, 180] degrees
_bearing = _real("a bearing in [0, 360) degrees", lambda v: 0 <= v < 360)
_angle = _real("an angle in [0, 180] degrees", lambda v: 0 <= v <= 180)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from rast.model.physics.layout import FarmSettings, TURBINE_CLASSES
    d = FarmSettings()
    parser.add_argument("layout", help="CSV: USWTDB columns (xlong, ylat, t_hh, t_rd, ...), lon/lat or x/y in m")
    parser.add_argument("--radar", required=True, type=_triple, metavar="LAT,LON,HEIGHT_M",
                        help="the radar antenna (X,Y,HEIGHT_M in metres for an x/y layout); "
                        "a negative first number needs the = form: --radar=-33.9,151.2,20")
    parser.add_argument("--wind-from", required=True, type=_bearing,
                        metavar="DEG", help="where the wind blows from, degrees clockwise from north")
    parser.add_argument("--wind-speed", type=_number("a positive speed in m/s"), metavar="M_S",
                        help="hub-height wind speed: rotor speed from the class's curve (default: rated)")
    parser.add_argument("--turbine-model", choices=sorted(TURBINE_CLASSES), default="nrel-5mw",
                        help="generic turbine class (default nrel-5mw; docs/farm_layouts.md)")
    parser.add_argument("--max-range-km", type=_number("a positive number of km"),
                        help="farthest turbine allowed (default: the unambiguous range c/(2 PRF))")
    parser.add_argument("--tower-rcs", type=_number("a positive RCS in m²"), metavar="M2",
                        help="a static return (tower and nacelle: the zero-Doppler line) of this RCS on "
                        "every turbine (default: none)")
    parser.add_argument("--radar-frequency", type=_number("a positive frequency in MHz"),
                        default=d.radar_frequency_mhz, metavar="MHZ", help=f"default {d.radar_frequency_mhz:g}")
    parser.add_argument("--prf", type=positive_hz, default=d.prf_hz, metavar="HZ", help=f"default {d.prf_hz:g}")
    parser.add_argument("--sample-rate", type=_number("a positive rate in MHz"), default=d.sample_rate_mhz,
                        metavar="MHZ", help=f"RTS sample rate, default {d.sample_rate_mhz:g}")
    parser.add_argument("--pulse-width", type=_number("a positive number of µs"), default=d.pulse_width_us,
                        metavar="US", help=f"default {d.pulse_width_us:g}")
    parser.add_argument("--cpi", type=_number("a positive number of ms"), default=d.cpi_ms, metavar="MS",
                        help=f"default {d.cpi_ms:g}")
    parser.add_argument("--ram-depth", type=_words, metavar="WORDS",
                        help="the stream pool of the build to load, written as ram_depth (default: none)")
    parser.add_argument("--stream-oversampling", type=_number("a stream rate over the maximum Doppler, at least 2"),
                        metavar="X", help="each stream's rate as a multiple of its turbine's maximum Doppler, "
                        "written as stream_oversampling (default: not written, the config's 4)")
    parser.add_argument("--share-aspect-deg", type=_angle, metavar="DEG",
                        help="alike turbines share streams (share_streams = true), rotor angles this "
                        "close too where the replay SFDR holds (docs/stream_sharing.md; default: no sharing)")
    parser.add_argument("--scan-rpm", type=_real("a non-zero number of rpm", lambda v: v != 0 and math.isfinite(v)),
                        metavar="RPM", help="the antenna turns (scan_mode = \"free\", scan_rpm; positive "
                        "clockwise; docs/antenna_scan.md; default: staring)")
    parser.add_argument("--beamwidth-deg", type=_number("a positive beamwidth in degrees"), metavar="DEG",
                        help="3-dB one-way beamwidth, written as beamwidth_deg (default: not written, 1.4)")
    parser.add_argument("--sidelobe-db", type=_real("a two-way floor in dB, at most 0", lambda v: v <= 0),
                        metavar="DB", help="the two-way pattern's floor, written as sidelobe_db (default: "
                        "not written, -50)")
    parser.add_argument("--out", required=True, help="farm config (TOML) to write")


def run(args) -> int:
    from rast.model.physics.farm import parse_config
    from rast.model.physics.layout import FarmSettings, RadarSite, TURBINE_CLASSES, make_farm, read_layout

    check_output(args.out, folder=False, option="--out")
    layout = read_layout(args.layout)
    settings = FarmSettings(args.sample_rate, args.radar_frequency, args.prf, args.pulse_width, args.cpi,
                            args.ram_depth, stream_oversampling=args.stream_oversampling,
                            share_aspect_deg=args.share_aspect_deg, scan_rpm=args.scan_rpm,
                            beamwidth_deg=args.beamwidth_deg, sidelobe_db=args.sidelobe_db)
    text, summary = make_farm(layout, RadarSite.from_option(args.radar, layout.geodetic), args.wind_from,
                              turbine_class=TURBINE_CLASSES[args.turbine_model], settings=settings,
                              wind_speed_m_s=args.wind_speed, max_range_km=args.max_range_km,
                              layout_name=Path(args.layout).name, tower_rcs_m2=args.tower_rcs)
    # The config parser's own checks (e.g. the pulse width against the PRI) before anything is written.
    parse_config(tomllib.loads(text), "the farm config")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    try:
        write_text(out, text)
    except OSError as error:
        raise UserError(f"cannot write {out}: {error.strerror or error}") from None
    print("\n".join(summary))
    print(f"wrote {out.resolve()}")
    return 0
