"""Wind farms from turbine layouts: a table of turbine positions, the radar and the wind in,
one ``[[windmill]]`` per turbine out (see ``docs/farm_layouts.md``).

Geometry, per turbine, in the turbine's own local East-North-Up frame at its hub:

* positions: geodetic layouts (WGS 84 longitude/latitude, heights above the
  ellipsoid) go through PROJ (``pyproj``): geodetic → geocentric (``cart``) →
  topocentric at the hub (``topocentric``); local metric layouts (x east, y
  north, metres) are a flat frame. The slant range is the straight line from
  the radar's antenna to the hub (no refraction);
* the rotor faces the wind: its axis points to where the wind comes from,
  tilted up by the class's shaft tilt; real turbines turn clockwise seen from
  upwind. A blade at physical angle β (0 up, clockwise seen from upwind) points
  along ``b(β) = sin β·x̂ + cos β·ŷ`` (x̂ the rotor plane's horizontal seen from
  upwind to the right, ŷ its "up"). A scatterer at radius r is
  ``ΔR = r·(b·û)`` nearer to the radar (û: unit vector hub → radar);
* with ``a = x̂·û`` and ``c = ŷ·û``, ``ΔR = −r·A·sin(β + φ₀)``, ``A = √(a² + c²)``,
  ``A·cos φ₀ = −a``, ``A·sin φ₀ = −c``: exactly the model's
  ``ΔR = −r·cos(rotor_angle)·sin β`` (seed eq. 2.17) with
  ``rotor_angle = arccos A`` — the angle between the line of sight and the rotor
  plane, elevation included — and the blade angle moved by φ₀ (added to
  ``start_angle``). So the radar's elevation both changes the rotor angle and
  turns the angle at which the blades look perpendicular to the line of sight.

Every problem of a layout (missing column, non-numeric cell, a turbine beyond
the radar's maximum range, ...) is collected and reported at once in a
:class:`~rast.model.physics.config.ConfigError` naming the line and the column.
"""

from __future__ import annotations

import csv
import io
import math
import re
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from rast.model.physics.config import SPEED_OF_LIGHT_M_S, ConfigError

__all__ = ["make_farm", "TurbineClass", "TURBINE_CLASSES", "RadarSite", "FarmSettings", "Turbine", "Layout",
           "PlacedTurbine", "read_layout", "parse_layout", "place_turbines", "farm_toml",
           "unambiguous_range_km", "azimuth_spread_deg", "MISSING_MARKERS"]


# ---------------------------------------------------------------------------
# Turbine classes

@dataclass(frozen=True)
class TurbineClass:
    """A generic turbine: geometry, rotor-speed curve and a blade scatterer profile.

    The rotor speed follows the usual variable-speed control: below rated, the
    rotor keeps its optimal tip-speed ratio ``tsr`` (rpm = tsr·v·60/(2π·R)),
    never slower than ``min_rpm``; from there up to cut-out it holds
    ``rated_rpm``. Outside [``cut_in_m_s``, ``cut_out_m_s``] the rotor is parked.
    A turbine of another rotor diameter D keeps the class's tip speeds (its
    rpm limits scale with D_class/D).

    The blade profile (``points_per_blade`` point scatterers from the hub to the
    tip, ``point_rcs_m2`` each, and a straight-wire blade of ``wire_reflectivity``
    for the flash of seed eq. 2.20) is generic, not measured: edit the written
    config to use measured values.
    """
    name: str
    rotor_diameter_m: float
    hub_height_m: float
    hub_diameter_m: float
    num_blades: int
    rated_rpm: float
    min_rpm: float
    tsr: float                  # optimal tip-speed ratio below rated
    cut_in_m_s: float
    cut_out_m_s: float
    shaft_tilt_deg: float       # rotor axis tilted up at the front
    source: str
    points_per_blade: int = 8
    point_rcs_m2: float = 0.5
    wire_reflectivity: float = 0.01   # m²/m

    def rpm(self, wind_m_s: float | None, rotor_diameter_m: float | None = None) -> float:
        """Rotor speed at hub-height wind speed ``wind_m_s`` (None: rated) for a rotor of
        ``rotor_diameter_m`` (None: the class's). Raises ValueError when parked."""
        scale = self.rotor_diameter_m / (rotor_diameter_m or self.rotor_diameter_m)
        rated, low = self.rated_rpm * scale, self.min_rpm * scale
        if wind_m_s is None:
            return rated
        if not self.cut_in_m_s <= wind_m_s <= self.cut_out_m_s:
            raise ValueError(f"a wind speed of {wind_m_s:g} m/s is outside the {self.name}'s "
                             f"operating range {self.cut_in_m_s:g}-{self.cut_out_m_s:g} m/s "
                             "(cut-in to cut-out): its rotors are parked and show no micro-Doppler")
        radius = (rotor_diameter_m or self.rotor_diameter_m) / 2
        optimal = self.tsr * wind_m_s * 60 / (2 * math.pi * radius)
        return min(rated, max(low, optimal))


#: Public reference turbines (sources in docs/farm_layouts.md and in ``source``).
TURBINE_CLASSES = {
    "nrel-5mw": TurbineClass(
        "nrel-5mw", rotor_diameter_m=126.0, hub_height_m=90.0, hub_diameter_m=3.0, num_blades=3,
        rated_rpm=12.1, min_rpm=6.9, tsr=7.55, cut_in_m_s=3.0, cut_out_m_s=25.0, shaft_tilt_deg=5.0,
        source="Jonkman, Butterfield, Musial, Scott: Definition of a 5-MW Reference Wind Turbine "
               "for Offshore System Development, NREL/TP-500-38060 (2009), Table 1-1 and section 7"),
    "iea-15mw": TurbineClass(
        "iea-15mw", rotor_diameter_m=240.0, hub_height_m=150.0, hub_diameter_m=7.94, num_blades=3,
        rated_rpm=7.56, min_rpm=5.0, tsr=9.0, cut_in_m_s=3.0, cut_out_m_s=25.0, shaft_tilt_deg=6.0,
        source="Gaertner et al.: Definition of the IEA 15-Megawatt Offshore Reference Wind "
               "Turbine, NREL/TP-5000-75698 (2020), Table 1-1"),
}


# ---------------------------------------------------------------------------
# Inputs

@dataclass(frozen=True)
class RadarSite:
    """The radar antenna: (longitude, latitude) in degrees for a geodetic layout, or
    (x, y) in metres (east, north) for a local one; ``height_m`` above the ground
    the turbines stand on (the WGS 84 ellipsoid for geodetic layouts)."""
    x: float
    y: float
    height_m: float

    @classmethod
    def from_option(cls, values, geodetic: bool) -> "RadarSite":
        """From ``--radar``: LAT,LON,HEIGHT_M for a geodetic layout, X,Y,HEIGHT_M for a local one."""
        a, b, h = values
        return cls(b, a, h) if geodetic else cls(a, b, h)


@dataclass(frozen=True)
class FarmSettings:
    """The farm-level keys written at the top of the config (config.py's units)."""
    sample_rate_mhz: float = 20.0
    radar_frequency_mhz: float = 5350.0
    prf_hz: float = 20_000.0
    pulse_width_us: float = 2.0
    cpi_ms: float = 100.0
    ram_depth: int | None = None     # words of the build's stream pool; None: not written (no limit)
    output_gain_db: float | None = None   # dB; None: not written (0, the loudest echo at full scale)
    stream_oversampling: float | None = None   # × max Doppler; None: not written (the parser's 4)
    share_aspect_deg: float | None = None   # deg; None: no sharing written; else share_streams = true
    #                                          and this tolerance (docs/stream_sharing.md)
    scan_rpm: float | None = None          # rpm; None: staring; else scan_mode = "free" at this rate
    beamwidth_deg: float | None = None     # deg, 3-dB one way; None: not written (the parser's 1.4)
    sidelobe_db: float | None = None       # dB, the two-way floor; None: not written (the parser's -50)


@dataclass(frozen=True)
class Turbine:
    """One layout row. ``hub_height_m``/``rotor_diameter_m`` None: the class's."""
    line: int                   # line in the file (1 = the header), for messages
    name: str
    x: float                    # longitude (deg) or east (m)
    y: float                    # latitude (deg) or north (m)
    base_m: float               # ground under the turbine relative to the radar's ground, m
    hub_height_m: float | None
    rotor_diameter_m: float | None
    model: str = ""


@dataclass(frozen=True)
class Layout:
    turbines: tuple[Turbine, ...]
    geodetic: bool              # lon/lat in degrees, else x/y in metres
    columns: tuple[str, str]    # the position columns used
    source: str = ""


#: Cells that mean "no value" in a numeric column other than a position
#: (USWTDB marks missing hub heights and rotor diameters with -9999 or leaves them empty).
MISSING_MARKERS = {"", "na", "n/a", "nan", "-9999"}

_POSITION_COLUMNS = (("xlong", "ylat", True), ("lon", "lat", True), ("longitude", "latitude", True),
                     ("x", "y", False), ("x_m", "y_m", False))
_HUB_COLUMNS = ("t_hh", "hub_height", "hub_height_m")
_ROTOR_COLUMNS = ("t_rd", "rotor_diameter", "rotor_diameter_m")
_BASE_COLUMNS = ("base_m", "ground_m")
_NAME_COLUMNS = ("name", "case_id", "id")
_SAFE = re.compile(r"[^A-Za-z0-9_.-]")


def _number(text: str, line: int, column: str, problems: list[str]) -> float | None:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not math.isfinite(value):
        problems.append(f"line {line}, column '{column}': {text!r} is not a number")
        return None
    return value


def parse_layout(text: str, source: str = "") -> Layout:
    """Read a layout CSV: a header row, one turbine per row; lines starting with ``#``
    are comments. Position columns: ``xlong``/``ylat`` (USWTDB), ``lon``/``lat``,
    ``longitude``/``latitude`` (degrees, WGS 84) or ``x``/``y`` (metres east/north).
    Optional: hub height ``t_hh``, rotor diameter ``t_rd`` (m; empty, NA or -9999:
    the class's), ``base_m`` (ground under the turbine above the radar's ground, m),
    ``name``/``case_id``/``id`` and ``t_model``. Other columns are ignored."""
    problems: list[str] = []
    # lines end at \n (and \r\n) only: str.splitlines would also break at a
    # vertical tab, a form feed or a file separator inside a cell
    lines = [line.removesuffix("\r") for line in text.split("\n")]
    rows = [(n, line) for n, line in enumerate(lines, 1) if line.strip() and not line.lstrip().startswith("#")]
    if not rows:
        raise ConfigError(["has no header row (the column names) and no turbines"], source)
    header_line = rows[0][0]
    reader = csv.reader(io.StringIO("\n".join(line for _, line in rows)))
    records = []
    try:
        for record in reader:
            if any("\n" in c or "\r" in c for c in record):
                raise ConfigError([f"line {rows[len(records)][0]}: a quoted cell runs over several lines; "
                                   "a layout has one turbine per line"], source)
            records.append(record)
    except csv.Error as error:          # e.g. a cell over csv.field_size_limit() characters
        at = rows[min(len(records), len(rows) - 1)][0]
        raise ConfigError([f"line {at}: is not a CSV row RAST reads: {error}"], source) from None
    header = [h.strip().lower() for h in records[0]]
    index = {h: k for k, h in enumerate(header)}
    position = next(((xc, yc, geo) for xc, yc, geo in _POSITION_COLUMNS if xc in index and yc in index), None)
    if position is None:
        raise ConfigError([f"line {header_line}: has no position columns: give 'xlong' and 'ylat' "
                           "(USWTDB, degrees), 'lon' and 'lat', or 'x' and 'y' (metres east and "
                           f"north); the header has {', '.join(repr(h) for h in header)}"], source)
    xc, yc, geodetic = position

    def first(columns):
        return next((c for c in columns if c in index), None)
    hub_c, rotor_c, base_c, name_c = (first(_HUB_COLUMNS), first(_ROTOR_COLUMNS), first(_BASE_COLUMNS),
                                      first(_NAME_COLUMNS))
    turbines = []
    if len(records) == 1:
        problems.append(f"line {header_line}: the header is followed by no turbine rows")
    for (line, _), record in zip(rows[1:], records[1:]):
        if len(record) != len(header):
            problems.append(f"line {line}: has {len(record)} cells, the header has {len(header)} columns")
            continue

        def cell(column):
            return record[index[column]].strip()
        before = len(problems)
        x = _number(cell(xc), line, xc, problems)
        y = _number(cell(yc), line, yc, problems)
        if geodetic and x is not None and y is not None:
            if not -180 <= x <= 180:
                problems.append(f"line {line}, column '{xc}': longitude {x:g} is not in [-180, 180] degrees")
            if not -90 <= y <= 90:
                problems.append(f"line {line}, column '{yc}': latitude {y:g} is not in [-90, 90] degrees")
        optional = {}
        for key, column in (("hub", hub_c), ("rotor", rotor_c)):
            if column is None or cell(column).lower() in MISSING_MARKERS:
                optional[key] = None
                continue
            value = _number(cell(column), line, column, problems)
            if value is not None and not value > 0:
                problems.append(f"line {line}, column '{column}': must be positive (m), not {cell(column)}")
            optional[key] = value
        base = 0.0
        if base_c is not None and cell(base_c) != "":
            base = _number(cell(base_c), line, base_c, problems) or 0.0
        name = cell(name_c) if name_c else ""
        name = _SAFE.sub("_", name)
        if name and not name[0].isalpha():
            name = "t" + name
        name = name or f"t{len(turbines) + 1:03d}"
        if len(problems) > before:
            continue
        turbines.append(Turbine(line, name, x, y, base, optional["hub"], optional["rotor"],
                                cell("t_model") if "t_model" in index else ""))
    names = [t.name for t in turbines]
    for name in sorted({n for n in names if names.count(n) > 1}):
        lines_of = [str(t.line) for t in turbines if t.name == name]
        problems.append(f"lines {', '.join(lines_of)}: the turbine name {name!r} is used more than once "
                        f"(column '{name_c}'); names must be unique (they name the stream files)")
    if problems:
        raise ConfigError(problems, source)
    return Layout(tuple(turbines), geodetic, (xc, yc), source)


def read_layout(path) -> Layout:
    """Read a layout CSV file (see :func:`parse_layout`)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except OSError as error:
        raise ConfigError([f"cannot read the layout: {error.strerror or error}"], str(path)) from None
    except UnicodeDecodeError:
        raise ConfigError(["is not a UTF-8 text (CSV) file"], str(path)) from None
    return parse_layout(text, str(path))


# ---------------------------------------------------------------------------
# Geometry

def unambiguous_range_km(prf_hz: float) -> float:
    """c/(2·PRF): the farthest range whose echo returns before the next pulse."""
    return SPEED_OF_LIGHT_M_S / (2 * prf_hz) / 1e3


def _radar_in_turbine_frames(layout: Layout, radar: RadarSite, hub_alt_m: np.ndarray) -> np.ndarray:
    """The radar antenna in each turbine's East-North-Up frame at its hub, (n, 3) metres."""
    xs = np.array([t.x for t in layout.turbines])
    ys = np.array([t.y for t in layout.turbines])
    if not layout.geodetic:
        return np.stack([radar.x - xs, radar.y - ys, radar.height_m - hub_alt_m], axis=1)
    from pyproj import Transformer
    out = np.empty((xs.size, 3))
    for k in range(xs.size):
        to_enu = Transformer.from_pipeline(
            "+proj=pipeline +step +proj=cart +ellps=WGS84 "
            f"+step +proj=topocentric +ellps=WGS84 +lon_0={float(xs[k])!r} +lat_0={float(ys[k])!r} +h_0={float(hub_alt_m[k])!r}")
        out[k] = to_enu.transform(radar.x, radar.y, radar.height_m)
    return out


def _bearings_from_radar_deg(layout: Layout, radar: RadarSite) -> np.ndarray:
    """Azimuth of each turbine seen from the radar, degrees clockwise from north."""
    xs = np.array([t.x for t in layout.turbines])
    ys = np.array([t.y for t in layout.turbines])
    if not layout.geodetic:
        return np.degrees(np.arctan2(xs - radar.x, ys - radar.y)) % 360
    from pyproj import Geod
    azimuth, _, _ = Geod(ellps="WGS84").inv(np.full(xs.size, radar.x), np.full(xs.size, radar.y), xs, ys)
    return np.asarray(azimuth) % 360


def azimuth_spread_deg(bearings_deg) -> tuple[float, float, float]:
    """The smallest arc holding every bearing: (start, end, width) in degrees, clockwise."""
    b = np.sort(np.asarray(bearings_deg, dtype=float) % 360)
    if b.size == 1:
        return float(b[0]), float(b[0]), 0.0
    gaps = np.diff(np.concatenate([b, [b[0] + 360]]))
    k = int(np.argmax(gaps))            # the arc starts after the largest empty gap
    start, end = b[(k + 1) % b.size], b[k]
    return float(start), float(end), float(360 - gaps[k])


@dataclass(frozen=True)
class PlacedTurbine:
    """A turbine as the radar sees it: what one ``[[windmill]]`` needs, and what is lost."""
    turbine: Turbine
    turbine_class: TurbineClass
    hub_height_m: float
    rotor_diameter_m: float
    range_km: float             # slant range, radar antenna to hub
    rotor_angle_deg: float      # between the line of sight and the rotor plane, [0, 90]
    blade_offset_deg: float     # φ₀: added to the physical blade angle
    start_angle_deg: float      # the model's start angle: physical start + φ₀
    rpm: float
    bearing_deg: float          # azimuth from the radar (not kept by one RTS)
    elevation_deg: float        # of the hub above the radar's horizontal, seen from the radar

    @property
    def blade_length_m(self) -> float:
        return self.rotor_diameter_m / 2


def rotor_projection(los_enu: np.ndarray, wind_from_deg: float, tilt_deg: float):
    """Rotor angle and blade-angle offset for unit lines of sight ``los_enu`` (n, 3)
    from hub to radar in the hub's ENU frame (see the module docstring).

    Returns ``(rotor_angle_deg, offset_deg)``: ``rotor_angle = arccos √(a² + c²)``
    and φ₀ = atan2(−c, −a) with ``a = x̂·û``, ``c = ŷ·û``.
    """
    w, t = np.radians(wind_from_deg), np.radians(tilt_deg)
    upwind = np.array([np.sin(w), np.cos(w), 0.0])
    zenith = np.array([0.0, 0.0, 1.0])
    axis = np.cos(t) * upwind + np.sin(t) * zenith          # rotor axis, towards the wind
    up = -np.sin(t) * upwind + np.cos(t) * zenith           # the rotor plane's "up"
    right = np.cross(-axis, up)                             # to the right, seen from upwind
    a, c = los_enu @ right, los_enu @ up
    amplitude = np.minimum(1.0, np.hypot(a, c))
    return np.degrees(np.arccos(amplitude)), np.degrees(np.arctan2(-c, -a))


def _elevations_from_radar_deg(layout: Layout, radar: RadarSite, hub_alt_m: np.ndarray) -> np.ndarray:
    """Elevation of each hub seen from the radar: above the radar's own horizontal, degrees."""
    xs = np.array([t.x for t in layout.turbines])
    ys = np.array([t.y for t in layout.turbines])
    if layout.geodetic:
        from pyproj import Transformer
        to_enu = Transformer.from_pipeline(
            "+proj=pipeline +step +proj=cart +ellps=WGS84 +step +proj=topocentric +ellps=WGS84 "
            f"+lon_0={float(radar.x)!r} +lat_0={float(radar.y)!r} +h_0={float(radar.height_m)!r}")
        e, n, u = to_enu.transform(xs, ys, hub_alt_m)
    else:
        e, n, u = xs - radar.x, ys - radar.y, hub_alt_m - radar.height_m
    return np.degrees(np.arctan2(np.asarray(u), np.hypot(e, n)))


#: Earth's mean radius and the effective-radius factor of standard refraction
#: (the 4/3 Earth of radar propagation).
EARTH_RADIUS_M = 6_371_000.0
REFRACTION_K = 4 / 3


def radar_horizon_m(antenna_m, target_m):
    """Farthest distance (m) at which a target ``target_m`` above the ground
    is above the horizon of an antenna ``antenna_m`` above it, over a smooth
    4/3 Earth: sqrt(2 k R h_a) + sqrt(2 k R h_t) (heights below 0 count as 0)."""
    kr = 2 * REFRACTION_K * EARTH_RADIUS_M
    return np.sqrt(kr * np.maximum(antenna_m, 0.0)) + np.sqrt(kr * np.maximum(target_m, 0.0))


def place_turbines(layout: Layout, radar: RadarSite, wind_from_deg: float, *,
                   turbine_class: TurbineClass, wind_speed_m_s: float | None = None,
                   max_range_km: float) -> list[PlacedTurbine]:
    """Range, rotor angle, blade offset and rpm of every turbine, as seen from ``radar``.

    Raises :class:`ConfigError` naming the line of each turbine beyond
    ``max_range_km``, within its own blade length of the antenna or below the
    radar's horizon (:func:`radar_horizon_m`), or a wind speed at which the
    class's rotors are parked.
    """
    problems = []
    if layout.geodetic and not (-90 <= radar.y <= 90 and -180 <= radar.x <= 180):
        problems.append(f"--radar: latitude {radar.y:g} and longitude {radar.x:g} are not a place "
                        "on Earth (give LAT,LON,HEIGHT_M in degrees and metres)")
    try:
        turbine_class.rpm(wind_speed_m_s)
    except ValueError as error:
        problems.append(f"--wind-speed: {error}")
    if problems:
        raise ConfigError(problems)
    turbines = layout.turbines
    hub = np.array([t.hub_height_m or turbine_class.hub_height_m for t in turbines])
    rotor = np.array([t.rotor_diameter_m or turbine_class.rotor_diameter_m for t in turbines])
    hub_alt = np.array([t.base_m for t in turbines]) + hub
    to_radar = _radar_in_turbine_frames(layout, radar, hub_alt)
    slant_m = np.linalg.norm(to_radar, axis=1)
    horizon_m = radar_horizon_m(radar.height_m, hub_alt + rotor / 2)
    for t, r_m, d, h_m in zip(turbines, slant_m, rotor, horizon_m):
        if r_m > max_range_km * 1e3:
            problems.append(f"line {t.line} (turbine '{t.name}'): its slant range {r_m / 1e3:.3f} km is "
                            f"beyond the radar's maximum range {max_range_km:.3f} km")
        elif r_m <= d / 2:
            problems.append(f"line {t.line} (turbine '{t.name}'): its hub is {r_m:.1f} m from the "
                            f"radar, within its own blade length ({d / 2:g} m)")
        elif r_m > h_m:
            problems.append(f"line {t.line} (turbine '{t.name}'): it lies below the radar's horizon: its "
                            f"blade tips at {t.base_m + (t.hub_height_m or turbine_class.hub_height_m) + d / 2:g} "
                            f"m are seen over a 4/3 Earth only up to {h_m / 1e3:.1f} km from an antenna at "
                            f"{radar.height_m:g} m, and it is {r_m / 1e3:.1f} km away")
    if problems:
        raise ConfigError(problems, layout.source or None)
    los = to_radar / slant_m[:, None]
    rotor_angle, offset = rotor_projection(los, wind_from_deg, turbine_class.shaft_tilt_deg)
    bearings = _bearings_from_radar_deg(layout, radar)
    elevation = _elevations_from_radar_deg(layout, radar, hub_alt)
    placed = []
    for k, t in enumerate(turbines):
        physical_start = (137.508 * k) % 360         # golden angle: rotors not in step
        placed.append(PlacedTurbine(
            t, turbine_class, float(hub[k]), float(rotor[k]), float(slant_m[k] / 1e3),
            float(rotor_angle[k]), float(offset[k]), float((physical_start + offset[k]) % 360),
            turbine_class.rpm(wind_speed_m_s, float(rotor[k])), float(bearings[k]), float(elevation[k])))
    return placed


# ---------------------------------------------------------------------------
# Output

def _comment(text: str, limit: int = 200) -> str:
    """``text`` safe inside one TOML comment line: every character that is
    not printable (a line break, a control character) written as its Python
    escape, and at most ``limit`` characters. Layout cells are the user's
    text; a line break in one would end the comment and start a key."""
    text = "".join(ch if ch.isprintable() else repr(ch)[1:-1] for ch in str(text))
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _windmill_table(p: PlacedTurbine, tower_rcs_m2: float | None = None) -> list[str]:
    c = p.turbine_class
    scale = p.rotor_diameter_m / c.rotor_diameter_m
    r_hub, r_tip = c.hub_diameter_m / 2 * scale, p.blade_length_m
    k = c.points_per_blade
    radii = [r_hub + (r_tip - r_hub) * (j + 1) / k for j in range(k)]
    phases = [(137 * j) % 360 for j in range(k)]        # scatterers of one blade not in phase
    t = p.turbine
    model = f", t_model {_comment(t.model)}" if t.model else ""
    return [
        "",
        f"# line {t.line}{model}: bearing {p.bearing_deg:.2f} deg, elevation {p.elevation_deg:.3f} deg, "
        f"hub {p.hub_height_m:g} m, rotor {p.rotor_diameter_m:g} m, blade offset {p.blade_offset_deg:.3f} deg",
        "[[windmill]]",
        f'name = "{t.name}"',
        f"range = {p.range_km:.6f}",
        f"num_blades = {c.num_blades}",
        f"rpm = {p.rpm:.4f}",
        f"rotor_angle = {p.rotor_angle_deg:.4f}",
        f"start_angle = {p.start_angle_deg:.4f}",
        f"azimuth = {p.bearing_deg:.4f}",
        f"num_rcs = {k}",
        "radius = [" + ", ".join(f"{r:.3f}" for r in radii) + "]",
        "rsc = [" + ", ".join(f"{c.point_rcs_m2:g}" for _ in radii) + "]",
        "phase_start = [" + ", ".join(str(ph) for ph in phases) + "]",
        "wire_enable = true",
        f"wire_radius_min = {r_hub:.3f}",
        f"wire_radius_max = {r_tip:.3f}",
        f"wire_reflectivity = {c.wire_reflectivity:g}",
        *([f"tower_rcs = {tower_rcs_m2:g}"] if tower_rcs_m2 else []),
    ]


def farm_toml(placed: list[PlacedTurbine], settings: FarmSettings, *, header: list[str],
              tower_rcs_m2: float | None = None) -> str:
    """The farm config (``docs/farm_layouts.md``): the settings, then one
    ``[[windmill]]`` per turbine in layout order; ``header`` lines become comments.
    ``tower_rcs_m2``: every turbine's static return (tower and nacelle), m²."""
    lines = [f"# {_comment(h)}" if h else "#" for h in header]
    lines += [
        f"sample_rate = {settings.sample_rate_mhz:g}          # MHz, the RTS sample rate",
        f"radar_frequency = {settings.radar_frequency_mhz:g}    # MHz",
        f"prf = {settings.prf_hz:g}               # Hz",
        f"pulse_width = {settings.pulse_width_us:g}           # µs",
        f"cpi = {settings.cpi_ms:g}                 # ms",
        *([f"ram_depth = {settings.ram_depth}         # words: the stream pool of the build to load"]
          if settings.ram_depth is not None else []),
        *([f"output_gain_db = {settings.output_gain_db:g}    # dB: the loudest sum of echoes within one pulse "
           "at full scale"] if settings.output_gain_db is not None else []),
        *([f"stream_oversampling = {settings.stream_oversampling:g}   # each stream's rate: this × its "
           "maximum Doppler"] if settings.stream_oversampling is not None else []),
        *(["share_streams = true      # alike turbines play one stream (docs/stream_sharing.md)",
           f"share_aspect_deg = {settings.share_aspect_deg:g}    # deg: rotor angles this close may share, "
           "each where its replay SFDR holds"] if settings.share_aspect_deg is not None else []),
        *(['scan_mode = "free"        # the RTS turns the beam (docs/antenna_scan.md)',
           f"scan_rpm = {settings.scan_rpm:g}           # rpm, clockwise seen from above"]
          if settings.scan_rpm is not None else []),
        *([f"beamwidth_deg = {settings.beamwidth_deg:g}      # deg, 3-dB one way"]
          if settings.beamwidth_deg is not None else []),
        *([f"sidelobe_db = {settings.sidelobe_db:g}        # dB, the two-way floor"]
          if settings.sidelobe_db is not None else []),
    ]
    for p in placed:
        lines += _windmill_table(p, tower_rcs_m2)
    return "\n".join(lines) + "\n"


def make_farm(layout: Layout, radar: RadarSite, wind_from_deg: float, *, turbine_class: TurbineClass,
              settings: FarmSettings, wind_speed_m_s: float | None = None,
              max_range_km: float | None = None, layout_name: str = "",
              tower_rcs_m2: float | None = None) -> tuple[str, list[str]]:
    """The farm config text for ``layout`` and a summary of what it keeps and loses.

    ``max_range_km`` None: the unambiguous range of ``settings.prf_hz``.
    ``tower_rcs_m2``: a static return (tower and nacelle, the zero-Doppler line
    of seed Fig. 4.6) of that RCS on every turbine; None or 0: none. The
    summary's lines head the config as comments and are what ``rast farm`` prints.
    """
    limit = unambiguous_range_km(settings.prf_hz) if max_range_km is None else max_range_km
    placed = place_turbines(layout, radar, wind_from_deg, turbine_class=turbine_class,
                            wind_speed_m_s=wind_speed_m_s, max_range_km=limit)
    start, end, width = azimuth_spread_deg([p.bearing_deg for p in placed])
    ranges = [p.range_km for p in placed]
    angles = [p.rotor_angle_deg for p in placed]
    where = (f"lat, lon = {radar.y:g}, {radar.x:g}" if layout.geodetic
             else f"x, y = {radar.x:g}, {radar.y:g} m")
    defaulted = sum(1 for p in placed if p.turbine.hub_height_m is None or p.turbine.rotor_diameter_m is None)
    summary = [
        f"{len(placed)} turbines from {layout_name or 'a layout'} ({', '.join(layout.columns)}), "
        f"radar at {where}, antenna {radar.height_m:g} m",
        f"wind from {wind_from_deg:g} deg" + (f" at {wind_speed_m_s:g} m/s" if wind_speed_m_s is not None
                                             else " (no speed given: rated rotor speed)"),
        f"turbine class {turbine_class.name}: {turbine_class.source}",
        *([f"{defaulted} turbine(s) without hub height or rotor diameter take the class's "
           f"({turbine_class.hub_height_m:g} m, {turbine_class.rotor_diameter_m:g} m)"] if defaulted else []),
        f"slant ranges {min(ranges):.3f}-{max(ranges):.3f} km (maximum {limit:.3f} km), "
        f"rotor angles {min(angles):.1f}-{max(angles):.1f} deg, "
        f"rpm {min(p.rpm for p in placed):.2f}-{max(p.rpm for p in placed):.2f}",
        *([f"tower and nacelle: a static return of {tower_rcs_m2:g} m2 per turbine (--tower-rcs; generic, "
           "not measured)"] if tower_rcs_m2 else []),
        f"bearings from the radar {start:.2f}-{end:.2f} deg: an azimuth spread of {width:.2f} deg",
        "each turbine's bearing is its azimuth: a turning antenna (scan_mode, docs/antenna_scan.md) "
        "lights it as its beam passes; staring, every turbine is lit on every pulse",
    ]
    # Echoes within one pulse of each other add up in the RTS's output: keep
    # their loudest sum at full scale, so that a full-scale pulse never clips.
    level = _echo_sum(farm_toml(placed, settings, header=[], tower_rcs_m2=tower_rcs_m2))
    if isinstance(level, str):
        summary.append(f"the echoes' loudest sum is not known ({level}): `rast stream` says more")
    elif level.clips:
        settings = replace(settings, output_gain_db=-math.ceil(level.level_dbfs * 10) / 10)
        summary.append(f"output_gain_db = {settings.output_gain_db:g} dB: the echoes of {len(level.windmills)} "
                       f"turbines within one {settings.pulse_width_us:g} us pulse add up to "
                       f"{level.level_dbfs:+.1f} dBFS for a full-scale pulse at 0 dB; this keeps them under "
                       "full scale")
    header = ["Wind farm written by `rast farm` from a turbine layout (docs/farm_layouts.md).", *summary]
    return farm_toml(placed, settings, header=header, tower_rcs_m2=tower_rcs_m2), summary


def _echo_sum(text: str):
    """The loudest echo sum (``stream.FarmStreams.echo_sum``) of a farm config's
    text, whatever stream pool it names (the sum does not depend on it); the
    reason as a string when its streams cannot be made."""
    from rast.model.physics.config import ConfigError
    from rast.model.physics.farm import parse_config
    from rast.model.physics.stream import build_farm_streams
    farm = replace(parse_config(tomllib.loads(text), "the farm config"), ram_depth=None)
    try:
        return build_farm_streams(farm).echo_sum()
    except ConfigError as error:
        return str(error)
