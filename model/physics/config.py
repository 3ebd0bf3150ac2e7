"""Configuration: the seed's parameter names and units (Table 2.1, 2.2), read from TOML.

Two file shapes are accepted:

* a *flat* file: the windmill keys at the top level beside ``sample_rate``,
  ``radar_frequency`` and ``output_file`` (what users of the original tool have);
* a *farm* file: ``sample_rate``, ``radar_frequency`` and the radar and replay
  settings at the top, and one ``[[windmill]]`` table per turbine with a ``name``.

Every problem found is reported at once, each naming the windmill and the key,
in a :class:`ConfigError`; nothing is written when a config is bad.
"""

from __future__ import annotations

import difflib
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rast.model.physics.antenna import ACP_COUNTS, SCAN_MODES, AntennaScan, read_pattern_csv

__all__ = ["ConfigError", "BladeFlash", "WeightTable", "Wire", "Tower", "Radar", "RangeCell",
           "Windmill", "StreamSharing", "Farm", "read_config_file", "validate_config", "SPEED_OF_LIGHT_M_S", "LIMITS"]

SPEED_OF_LIGHT_M_S = 299_792_458.0


class ConfigError(ValueError):
    """A configuration is invalid; ``problems`` lists every problem found."""

    def __init__(self, problems: list[str], source: str | None = None):
        self.problems = list(problems)
        head = f"{source}: " if source else ""
        if len(self.problems) == 1:
            super().__init__(head + self.problems[0])
        else:
            super().__init__(head + f"{len(self.problems)} problems:\n" +
                             "\n".join("  - " + p for p in self.problems))


@dataclass(frozen=True)
class BladeFlash:
    """Parametric blade flash: a Gaussian bump of the RCS around given blade angles.

    ``angle_deg``: blade angles of the flash centres (0° = blade pointing up,
    perpendicular to the line of sight); ``width_deg``: full width at half
    maximum; ``gain_db``: RCS gain at the peak (amplitude gain 10^(gain_db/20)).
    """
    angle_deg: tuple[float, ...]
    width_deg: float
    gain_db: float


@dataclass(frozen=True)
class WeightTable:
    """Amplitude weights w_k(β) of eq. 2.19 sampled evenly over one revolution.

    ``weights`` has one row per scatterer (or one row for all), column j at
    blade angle 360°·j/columns; values in between are interpolated linearly
    and periodically.
    """
    weights: np.ndarray


@dataclass(frozen=True)
class Wire:
    """A straight wire blade of seed Table 2.2 (eq. 2.20–2.23)."""
    radius_min_m: float
    radius_max_m: float
    reflectivity: float          # α of eq. 2.20, m²/m; the flash amplitude is α·L
    phase_offset_deg: float = 0.0
    view_angle_deg: float = 0.0  # added to rotor_angle for the wire's projection


@dataclass(frozen=True)
class Tower:
    """The mast: a static scatterer (zero Doppler) and the shadow it casts on the blades."""
    rcs_m2: float = 0.0
    phase_deg: float = 0.0
    shadow_width_deg: float = 0.0   # blade-angle width around 180° (blade down) that is shadowed
    shadow_depth_db: float = 20.0   # attenuation of the blade's RCS in the middle of the shadow


@dataclass(frozen=True)
class Radar:
    """The radar the farm is seen by (defaults: seed Table 3.1)."""
    frequency_mhz: float
    prf_hz: float = 20_000.0
    pulse_width_us: float = 2.0
    cpi_ms: float = 100.0

    @property
    def wavelength_m(self) -> float:
        return SPEED_OF_LIGHT_M_S / (self.frequency_mhz * 1e6)


@dataclass(frozen=True)
class RangeCell:
    """Marks a windmill as one delay tap of a range-extended turbine (``rast.model.physics.extended``).

    The tap's stream is the turbine's echo weighted, scatterer by scatterer,
    by the range-cell weight of the tap at ``delay_samples`` (RTS samples of
    round-trip delay); the turbine's hub is at ``hub_range_km``.
    """
    turbine: str              # the turbine's name in the config
    hub_range_km: float
    delay_samples: int        # this tap's round-trip delay, RTS samples
    sample_rate_hz: float     # the RTS sample rate the taps are spaced by
    index: int                # 0 for the nearest tap
    count: int                # taps of this turbine


@dataclass(frozen=True)
class Windmill:
    """One turbine. Angles in degrees, lengths in metres, RCS in m², range in km."""
    name: str
    range_km: float
    num_blades: int
    rpm: float
    rotor_angle_deg: float = 0.0
    start_angle_deg: float = 0.0
    radius_m: np.ndarray = field(default_factory=lambda: np.zeros(0))
    rcs_m2: np.ndarray = field(default_factory=lambda: np.zeros(0))
    phase_start_deg: np.ndarray = field(default_factory=lambda: np.zeros(0))
    weighting: BladeFlash | WeightTable | None = None
    wire: Wire | None = None
    tower: Tower | None = None
    #: None: automatic (oversampling × max Doppler); "rts": one word per RTS
    #: sample (the seed's mode); a number: requested stream rate in Hz.
    stream_rate: float | str | None = None
    output_file: str | None = None
    #: ``range_extended`` of the config: True/False forces the split over delay
    #: taps on or off, None leaves it to the farm's ``range_extend_above``.
    range_extended: bool | None = None
    #: Set on the taps a range-extended turbine is split into (never in a config).
    range_cell: RangeCell | None = None
    #: Bearing from the radar, degrees clockwise from north (``azimuth``): where
    #: a turning antenna's beam finds the turbine (``rast.model.physics.antenna``).
    azimuth_deg: float = 0.0

    @property
    def echo_range_km(self) -> float:
        """The range whose 1/R² sets the echo's amplitude: the hub's, also for a tap."""
        return self.range_cell.hub_range_km if self.range_cell is not None else self.range_km

    @property
    def num_rcs(self) -> int:
        return len(self.radius_m)

    @property
    def period_s(self) -> float:
        """T_sim of eq. 2.13: the modulation repeats every 1/num_blades revolution."""
        return 60.0 / (self.rpm * self.num_blades)


@dataclass(frozen=True)
class StreamSharing:
    """Streams shared between alike turbines (``rast.model.physics.sharing``):
    turbines whose echoes differ only by the blades' start angle play one
    stream from their own start word; with ``aspect_tolerance_deg`` also
    those whose rotor angle is that close to the stream's, each only if its
    replay SFDR, measured, is at least ``min_sfdr_db``."""
    enabled: bool = False               # ``share_streams``
    aspect_tolerance_deg: float = 0.0   # ``share_aspect_deg``: rotor angles this close may share (degrees)
    min_sfdr_db: float = 70.0           # ``share_min_sfdr_db``: the replay SFDR an aspect-shared turbine keeps


@dataclass(frozen=True)
class Farm:
    """A wind farm seen by one radar and replayed by one RTS."""
    sample_rate_mhz: float
    radar: Radar
    windmills: tuple[Windmill, ...]
    ram_depth: int | None = None        # stream pool words of the target gateware (all streams together); None: no limit
    stream_oversampling: float = 4.0    # stream rate ≥ this × max Doppler
    output_gain_db: float = 0.0         # level of the loudest windmill's peak
    interpolation: str = "fir"          # the replay block's stream interpolation: fir, linear or hold
    adc_latency: int = 0                # RTS samples from the ADC's analogue input to its data pins
    dac_latency: int = 0                # RTS samples from the DAC's data pins to its analogue output
    #: Split every turbine whose blades sweep more than this many RTS samples of
    #: round-trip delay (peak to peak) over delay taps; None: only those with
    #: ``range_extended = true``.
    range_extend_above: float | None = None
    #: Receiver noise of the model radar (``rast.model.radar.receiver.receive``): the
    #: power of one complex I/Q sample in dB relative to full scale (a full-scale
    #: complex tone has power 1, 0 dBFS); None: no noise.
    noise_dbfs: float | None = None
    #: The antenna's scan and pattern (``scan_mode`` and the keys beside it);
    #: the default stares: every turbine lit on every pulse.
    scan: AntennaScan = field(default_factory=AntennaScan)
    #: Streams shared between alike turbines (``share_streams`` and the keys beside it).
    sharing: StreamSharing = field(default_factory=StreamSharing)

    @property
    def sample_rate_hz(self) -> float:
        return self.sample_rate_mhz * 1e6


# ---------------------------------------------------------------------------
# Parsing

_RADAR_KEYS = {"radar_frequency", "prf", "pulse_width", "cpi"}
_SCAN_KEYS = {"scan_mode", "scan_rpm", "scan_start_deg", "acp_per_rev", "beamwidth_deg", "sidelobe_db",
              "pattern_file", "assign_below_db"}
_SHARE_KEYS = {"share_streams", "share_aspect_deg", "share_min_sfdr_db"}
_FARM_KEYS = {"sample_rate", "ram_depth", "stream_oversampling", "output_gain_db", "stream_rate",
              "interpolation", "adc_latency", "dac_latency", "range_extend_above",
              "noise_dbfs"} | _RADAR_KEYS | _SCAN_KEYS | _SHARE_KEYS
_INTERPOLATIONS = ("fir", "linear", "hold")
_WINDMILL_KEYS = {
    "name", "range", "num_blades", "rpm", "rotor_angle", "start_angle", "num_rcs",
    "radius", "rsc", "rcs", "phase_start", "rsc_weighting",
    "wire_enable", "wire_radius_min", "wire_radius_max", "wire_reflectivity",
    "wire_phase_offset", "wire_view_angle",
    "tower_rcs", "tower_phase", "tower_shadow_width", "tower_shadow_depth",
    "stream_rate", "output_file", "range_extended", "azimuth",
}
_FLASH_KEYS = {"angle", "width", "gain_db"}
_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")


#: Largest magnitude of a key's value, and its unit: beyond every radar and
#: turbine RAST serves, and far from where the arithmetic loses its meaning
#: (10**(gain_db / 20) overflows near 6000 dB; a range of 1e300 km has no
#: delay in samples).
LIMITS = {
    "range": (1e5, "km"), "rpm": (1e4, "rpm"), "rotor_angle": (1e6, "deg"), "start_angle": (1e6, "deg"),
    "radius": (1e4, "m"), "rsc": (1e12, "m²"), "rcs": (1e12, "m²"), "phase_start": (1e6, "deg"),
    "angle": (1e6, "deg"), "width": (360.0, "deg"), "gain_db": (300.0, "dB"),
    "wire_radius_min": (1e4, "m"), "wire_radius_max": (1e4, "m"), "wire_reflectivity": (1e12, "m²/m"),
    "wire_phase_offset": (1e6, "deg"), "wire_view_angle": (1e6, "deg"), "tower_rcs": (1e12, "m²"),
    "tower_phase": (1e6, "deg"), "tower_shadow_depth": (300.0, "dB"), "stream_rate": (1e12, "Hz"),
    "sample_rate": (1e5, "MHz"), "radar_frequency": (1e7, "MHz"), "prf": (1e8, "Hz"),
    "pulse_width": (1e7, "µs"), "cpi": (1e7, "ms"), "stream_oversampling": (1e6, "× max Doppler"),
    "output_gain_db": (300.0, "dB"), "range_extend_above": (1e12, "RTS samples"),
    "noise_dbfs": (300.0, "dBFS"), "azimuth": (1e6, "deg"), "scan_rpm": (600.0, "rpm"),
    "scan_start_deg": (1e6, "deg"), "beamwidth_deg": (180.0, "deg"),
    "share_aspect_deg": (180.0, "deg"), "share_min_sfdr_db": (300.0, "dB"),
    # integers
    "num_blades": (1000, ""), "num_rcs": (100_000, ""), "ram_depth": (1 << 32, ""),
    "adc_latency": (1 << 20, ""), "dac_latency": (1 << 20, ""),
}


def _finite(value) -> bool:
    """A TOML number that is finite (TOML integers may be too large for a float)."""
    try:
        return math.isfinite(value)
    except OverflowError:
        return False


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and _finite(v)


def _short(value, limit=60) -> str:
    """``repr(value)``, cut to ``limit`` characters (a config may hold huge lists)."""
    text = repr(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _did_you_mean(key: str, allowed) -> str:
    close = difflib.get_close_matches(key, sorted(allowed), n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ""


class _Reader:
    """Reads typed values from one TOML table, collecting problems instead of raising."""

    def __init__(self, table: dict, where: str, problems: list[str]):
        self.table, self.where, self.problems = table, where, problems

    def problem(self, key: str | None, message: str):
        prefix = f"{self.where}: " if self.where else ""
        self.problems.append(prefix + (f"'{key}' " if key else "") + message)

    def unknown(self, allowed):
        for key in self.table:
            if key not in allowed:
                self.problem(key, "is not a known key" + _did_you_mean(key, allowed))

    def number(self, key, default=None, *, required=False, positive=False,
               non_negative=False, unit="", limit=None):
        """A finite number; ``limit`` bounds its magnitude (default: the key's
        entry in LIMITS, else none)."""
        if key not in self.table:
            if required:
                self.problem(key, "is required" + (f" ({unit})" if unit else ""))
            return default
        value = self.table[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not _finite(value):
            self.problem(key, f"must be a number, not {_short(value)}")
            return default
        if positive and not value > 0:
            self.problem(key, f"must be positive, not {value!r}")
            return default
        if non_negative and value < 0:
            self.problem(key, f"must not be negative, not {value!r}")
            return default
        limit = LIMITS.get(key) if limit is None else limit
        if limit is not None and abs(value) > limit[0]:
            self.problem(key, f"must be at most {limit[0]:g} {limit[1]} in magnitude, not {value!r}")
            return default
        return float(value)

    def integer(self, key, default=None, *, required=False, minimum=None, unit=""):
        what = f" ({unit})" if unit else ""
        if key not in self.table:
            if required:
                self.problem(key, "is required" + what)
            return default
        value = self.table[key]
        if isinstance(value, bool) or not isinstance(value, int):
            self.problem(key, f"must be an integer{what}, not {_short(value)}")
            return default
        if minimum is not None and value < minimum:
            self.problem(key, f"must be at least {minimum}{what}, not {_short(value)}")
            return default
        if key in LIMITS and value > LIMITS[key][0]:
            self.problem(key, f"must be at most {LIMITS[key][0]:g}{what}, not {_short(value)}")
            return default
        return value

    def vector(self, key, length, default=None, *, non_negative=False):
        """A per-scatterer vector: a list of num_rcs numbers (a bare number when
        num_rcs = 1), each within the key's LIMITS."""
        if key not in self.table:
            return default
        value = self.table[key]
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            value = [value]
        if not isinstance(value, list) or not all(_is_number(v) for v in value):
            self.problem(key, f"must be a list of numbers, not {_short(value)}")
            return default
        limit = LIMITS.get(key)
        if limit is not None and any(abs(v) > limit[0] for v in value):
            self.problem(key, f"must hold values of at most {limit[0]:g} {limit[1]} in magnitude, "
                         f"not {_short(value)}")
            return default
        if length is not None and len(value) != length:
            self.problem(key, f"has {len(value)} values but num_rcs = {length}")
            return default
        array = np.asarray(value, dtype=float)
        if non_negative and np.any(array < 0):
            self.problem(key, f"must not hold negative values, not {value!r}")
            return default
        return array


#: Largest amplitude weight of an ``rsc_weighting`` table.
MAX_WEIGHT = 1e6


def _parse_weighting(r: _Reader, num_rcs: int):
    if "rsc_weighting" not in r.table:
        return None
    value = r.table["rsc_weighting"]
    if isinstance(value, dict):
        sub = _Reader(value, (r.where + ": " if r.where else "") + "rsc_weighting", r.problems)
        sub.unknown(_FLASH_KEYS)
        angle = value.get("angle", 0.0)
        angles = angle if isinstance(angle, list) else [angle]
        if not angles or not all(_is_number(a) and abs(a) <= LIMITS["angle"][0] for a in angles):
            sub.problem("angle", f"must be a number or a list of numbers of at most "
                        f"{LIMITS['angle'][0]:g} deg in magnitude, not {_short(angle)}")
            angles = [0.0]
        width = sub.number("width", required=True, positive=True, unit="deg")
        gain_db = sub.number("gain_db", required=True, unit="dB")
        if width is None or gain_db is None:
            return None
        return BladeFlash(tuple(float(a) for a in angles), width, gain_db)
    if isinstance(value, list) and value and not isinstance(value[0], list):
        value = [value]
    ok = (isinstance(value, list) and value and
          all(isinstance(row, list) and row and
              all(_is_number(v) and abs(v) <= MAX_WEIGHT for v in row) for row in value))
    if not ok:
        r.problem("rsc_weighting", "must be a table of weights (a list of rows of numbers up to "
                  f"{MAX_WEIGHT:g}, one row per scatterer) or a flash {{angle = …, width = …, "
                  f"gain_db = …}}, not {_short(value)}")
        return None
    if len({len(row) for row in value}) != 1:
        r.problem("rsc_weighting", "rows must all have the same number of columns")
        return None
    if len(value) not in (1, num_rcs):
        r.problem("rsc_weighting", f"has {len(value)} rows but num_rcs = {num_rcs} "
                  "(give one row per scatterer, or one row for all)")
        return None
    weights = np.asarray(value, dtype=float)
    if np.any(weights < 0):
        r.problem("rsc_weighting", "weights must not be negative")
        return None
    return WeightTable(weights)


def _parse_stream_rate(r: _Reader, default):
    if "stream_rate" not in r.table:
        return default
    value = r.table["stream_rate"]
    if value == "rts" or value == "auto":
        return None if value == "auto" else "rts"
    return r.number("stream_rate", default, positive=True, unit="Hz")


def _parse_windmill(table: dict, where: str, problems: list[str], default_rate) -> Windmill | None:
    r = _Reader(table, where, problems)
    before = len(problems)
    name = table.get("name", "windmill")
    if not isinstance(name, str) or not _NAME_RE.match(name):
        r.problem("name", f"must be a file-name-safe string (letters, digits, _ . -), not {name!r}")
    range_km = r.number("range", required=True, positive=True, unit="km")
    num_blades = r.integer("num_blades", required=True, minimum=1)
    rpm = r.number("rpm", required=True, positive=True, unit="revolutions per minute")
    rotor_angle = r.number("rotor_angle", 0.0)
    start_angle = r.number("start_angle", 0.0)
    azimuth = r.number("azimuth", 0.0, unit="deg")

    if "rsc" in table and "rcs" in table:
        r.problem("rcs", "and 'rsc' are the same parameter; give only one")
    rcs_key = "rcs" if "rcs" in table else "rsc"
    num_rcs = r.integer("num_rcs", None, minimum=0)
    if num_rcs is None and "num_rcs" not in table:
        radius_given = table.get("radius")
        num_rcs = (len(radius_given) if isinstance(radius_given, list)
                   else 1 if isinstance(radius_given, (int, float)) else 0)
    radius = r.vector("radius", num_rcs, non_negative=True)
    rcs = r.vector(rcs_key, num_rcs, non_negative=True)
    phase = r.vector("phase_start", num_rcs, np.zeros(num_rcs or 0))
    if num_rcs:
        for key, value in (("radius", radius), ("rsc", rcs)):
            if key not in table and not (key == "rsc" and rcs_key in table):
                r.problem(key, f"is required when num_rcs = {num_rcs}")
    weighting = _parse_weighting(r, num_rcs or 0)

    wire = None
    wire_enable = table.get("wire_enable", False)
    if not isinstance(wire_enable, bool):
        r.problem("wire_enable", f"must be true or false, not {wire_enable!r}")
        wire_enable = False
    wire_keys = [k for k in table if k.startswith("wire_") and k != "wire_enable"]
    if wire_enable:
        rmin = r.number("wire_radius_min", 0.0, non_negative=True, unit="m")
        rmax = r.number("wire_radius_max", required=True, positive=True, unit="m")
        alpha = r.number("wire_reflectivity", required=True, non_negative=True, unit="m²/m")
        if rmin is not None and rmax is not None and not rmin < rmax:
            r.problem("wire_radius_min", f"({rmin} m) must be less than 'wire_radius_max' ({rmax} m)")
        wire = Wire(rmin, rmax, alpha, r.number("wire_phase_offset", 0.0),
                    r.number("wire_view_angle", 0.0))
    elif wire_keys:
        r.problem(wire_keys[0], "is set but 'wire_enable' is not true")

    tower = None
    tower_rcs = r.number("tower_rcs", 0.0, non_negative=True, unit="m²")
    shadow_width = r.number("tower_shadow_width", 0.0, non_negative=True, unit="deg")
    if shadow_width is not None and shadow_width >= 360:
        r.problem("tower_shadow_width", f"must be less than 360 deg, not {shadow_width!r}")
    shadow_depth = r.number("tower_shadow_depth", 20.0, non_negative=True, unit="dB")
    if tower_rcs or shadow_width or "tower_phase" in table:
        tower = Tower(tower_rcs or 0.0, r.number("tower_phase", 0.0),
                      shadow_width or 0.0, shadow_depth if shadow_depth is not None else 20.0)

    stream_rate = _parse_stream_rate(r, default_rate)
    output_file = table.get("output_file")
    if output_file is not None and not isinstance(output_file, str):
        r.problem("output_file", f"must be a file name, not {output_file!r}")
        output_file = None
    range_extended = table.get("range_extended")
    if range_extended is not None and not isinstance(range_extended, bool):
        r.problem("range_extended", f"must be true or false, not {range_extended!r}")
        range_extended = None

    if len(problems) > before:
        return None
    if not num_rcs and wire is None and (tower is None or tower.rcs_m2 == 0):
        r.problem(None, "has nothing that reflects: give point scatterers (num_rcs > 0), "
                  "a wire (wire_enable = true) or a tower (tower_rcs > 0)")
        return None
    return Windmill(name=name, range_km=range_km, num_blades=num_blades, rpm=rpm,
                    rotor_angle_deg=rotor_angle, start_angle_deg=start_angle,
                    radius_m=radius if radius is not None else np.zeros(0),
                    rcs_m2=rcs if rcs is not None else np.zeros(0),
                    phase_start_deg=phase if phase is not None else np.zeros(0),
                    weighting=weighting, wire=wire, tower=tower,
                    stream_rate=stream_rate, output_file=output_file,
                    range_extended=range_extended, azimuth_deg=float(azimuth % 360.0))


#: The lowest two-way floor: the pattern table's smallest step is 2**-15 of
#: the peak (rast.model.contract.scan), about -90 dB.
MIN_SIDELOBE_DB = -90.0


def _parse_scan(top: _Reader, source: str | None) -> AntennaScan | None:
    """The farm's antenna scan; keys other than ``scan_mode`` may stay in a
    staring config (ignored there), so that one key switches the scan off."""
    data = top.table
    mode = data.get("scan_mode", "stare")
    if mode not in SCAN_MODES:
        top.problem("scan_mode", f"must be one of {', '.join(map(repr, SCAN_MODES))}, not {_short(mode)}")
        return None
    rpm = top.number("scan_rpm", None, unit="rpm")
    if mode != "stare" and rpm is None and "scan_rpm" not in data:
        top.problem("scan_rpm", f"is required with scan_mode = {mode!r} (revolutions per minute, "
                    "positive clockwise seen from above" + ("; the radar's nominal rate, which the model "
                                                            "assumes" if mode == "acp" else "") + ")")
    elif rpm == 0 and mode != "stare":
        top.problem("scan_rpm", "must not be 0 in a turning scan (use scan_mode = \"stare\")")
    start = top.number("scan_start_deg", 0.0, unit="deg")
    acp = data.get("acp_per_rev", 4096)
    if isinstance(acp, bool) or acp not in ACP_COUNTS:
        top.problem("acp_per_rev", f"must be one of {', '.join(map(repr, ACP_COUNTS))}, not {_short(acp)}")
        acp = 4096
    beamwidth = top.number("beamwidth_deg", 1.4, positive=True, unit="deg")
    sidelobe = top.number("sidelobe_db", -50.0, unit="dB")
    if sidelobe is not None and not MIN_SIDELOBE_DB <= sidelobe <= 0:
        top.problem("sidelobe_db", f"must be in [{MIN_SIDELOBE_DB:g}, 0] dB (the two-way floor), "
                    f"not {sidelobe!r}")
        sidelobe = None
    assign_below = top.number("assign_below_db", -60.0, unit="dB")
    if assign_below is not None and not MIN_SIDELOBE_DB <= assign_below <= 0:
        top.problem("assign_below_db", f"must be in [{MIN_SIDELOBE_DB:g}, 0] dB (a two-way gain), "
                    f"not {assign_below!r}")
        assign_below = None
    pattern = None
    if "pattern_file" in data:
        name = data["pattern_file"]
        if not isinstance(name, str) or not name:
            top.problem("pattern_file", f"must be the name of a CSV file, not {_short(name)}")
        else:
            path = Path(name)
            if not path.is_absolute() and source:
                path = Path(source).parent / path       # beside the config
            try:
                pattern = read_pattern_csv(path)
            except ValueError as error:
                top.problem(None, str(error))
    if None in (start, beamwidth, sidelobe, assign_below) or (mode != "stare" and not rpm):
        return None
    return AntennaScan(mode, rpm or 0.0, float(start % 360.0), acp, beamwidth, sidelobe, pattern, assign_below)


def _parse_sharing(top: _Reader) -> StreamSharing:
    """The farm's stream sharing (``share_streams`` and the keys beside it)."""
    enabled = top.table.get("share_streams", False)
    if not isinstance(enabled, bool):
        top.problem("share_streams", f"must be true or false, not {_short(enabled)}")
        enabled = False
    tolerance = top.number("share_aspect_deg", 0.0, non_negative=True, unit="deg")
    min_sfdr = top.number("share_min_sfdr_db", 70.0, unit="dB")
    return StreamSharing(enabled, 0.0 if tolerance is None else tolerance,
                         70.0 if min_sfdr is None else min_sfdr)


def validate_config(data: dict, source: str | None = None) -> Farm:
    """Validate a parsed TOML document and build the :class:`Farm` it
    describes, as written (its range-extended turbines not yet split:
    :func:`rast.model.physics.farm.parse_config` does both)."""
    problems: list[str] = []
    farm_file = "windmill" in data
    top = _Reader(data, "", problems)
    if farm_file:
        top.unknown(_FARM_KEYS | {"windmill"})
    else:
        top.unknown(_FARM_KEYS | _WINDMILL_KEYS)

    sample_rate = top.number("sample_rate", required=True, positive=True, unit="MHz")
    frequency = top.number("radar_frequency", required=True, positive=True, unit="MHz")
    prf = top.number("prf", 20_000.0, positive=True, unit="Hz")
    pulse_width = top.number("pulse_width", 2.0, positive=True, unit="µs")
    cpi = top.number("cpi", 100.0, positive=True, unit="ms")
    ram_depth = top.integer("ram_depth", None, minimum=2)
    oversampling = top.number("stream_oversampling", 4.0, unit="× max Doppler")
    if oversampling is not None and oversampling < 2:
        top.problem("stream_oversampling", f"must be at least 2 (Nyquist), not {oversampling!r}")
    output_gain_db = top.number("output_gain_db", 0.0, unit="dB")
    adc_latency = top.integer("adc_latency", 0, minimum=0, unit="RTS samples")
    dac_latency = top.integer("dac_latency", 0, minimum=0, unit="RTS samples")
    range_extend_above = top.number("range_extend_above", None, non_negative=True,
                                    unit="RTS samples of delay swept by the blades")
    noise_dbfs = top.number("noise_dbfs", None, unit="dBFS")
    if noise_dbfs is not None and noise_dbfs > 0:
        top.problem("noise_dbfs", f"must be at most 0 dBFS (noise power per complex sample relative to "
                    f"full scale), not {noise_dbfs!r}")
        noise_dbfs = None
    scan = _parse_scan(top, source)
    sharing = _parse_sharing(top)
    interpolation = data.get("interpolation", "fir")
    if interpolation not in _INTERPOLATIONS:
        top.problem("interpolation", f"must be one of {', '.join(map(repr, _INTERPOLATIONS))}, "
                    f"not {interpolation!r}")
    if prf and pulse_width and pulse_width * 1e-6 * prf >= 1:
        top.problem("pulse_width", f"({pulse_width} µs) must be shorter than the pulse "
                    f"repetition interval ({1e6 / prf:g} µs)")

    windmills = []
    if farm_file:
        default_rate = _parse_stream_rate(top, None)
        tables = data["windmill"]
        if not isinstance(tables, list) or not tables:
            top.problem("windmill", "must be one or more [[windmill]] tables")
            tables = []
        for index, table in enumerate(tables):
            name = table.get("name") if isinstance(table, dict) else None
            where = f"windmill '{name}'" if isinstance(name, str) else f"windmill #{index + 1}"
            if not isinstance(table, dict):
                problems.append(f"{where}: must be a table")
                continue
            if "name" not in table:
                problems.append(f"{where}: 'name' is required in a farm file")
            sub = _Reader(table, where, problems)
            sub.unknown(_WINDMILL_KEYS)
            windmill = _parse_windmill(table, where, problems, default_rate)
            if windmill:
                windmills.append(windmill)
        names = [w.name for w in windmills]
        for name in sorted({n for n in names if names.count(n) > 1}):
            problems.append(f"windmill '{name}': 'name' is used by {names.count(name)} windmills; "
                            "names must be unique (they name the stream files)")
    else:
        table = {k: v for k, v in data.items() if k in _WINDMILL_KEYS}
        if "name" not in table:
            out = data.get("output_file")
            stem = Path(out).stem if isinstance(out, str) and out else "windmill"
            table["name"] = re.sub(r"[^A-Za-z0-9_.-]", "_", stem) or "windmill"
        windmill = _parse_windmill(table, "", problems, None)
        if windmill:
            windmills.append(windmill)

    if problems:
        raise ConfigError(problems, source)
    radar = Radar(frequency, prf, pulse_width, cpi)
    if interpolation == "fir":
        for w in windmills:
            if w.stream_rate == "rts":
                problems.append(f"windmill '{w.name}': 'stream_rate' = \"rts\" plays one word per RTS "
                                f"sample, which the FIR interpolator cannot follow: set "
                                f"interpolation = \"hold\" (exact at that rate)")
    if problems:
        raise ConfigError(problems, source)
    return Farm(sample_rate, radar, tuple(windmills), ram_depth, oversampling, output_gain_db,
                interpolation, adc_latency, dac_latency, range_extend_above, noise_dbfs, scan, sharing)


#: Largest config file read (bytes): a farm of thousands of turbines is a few MB.
MAX_CONFIG_BYTES = 64 << 20


def read_config_file(path) -> dict:
    """The TOML document of a config file: UTF-8 text (a byte-order mark is
    skipped), no NUL bytes, at most MAX_CONFIG_BYTES; anything else, and TOML
    nested too deep to parse, is a :class:`ConfigError` naming the file."""
    path = Path(path)
    try:
        if path.is_dir():
            raise ConfigError(["cannot read the config: it is a folder"], str(path))
        with open(path, "rb") as f:
            raw = f.read(MAX_CONFIG_BYTES + 1)
    except OSError as error:
        raise ConfigError([f"cannot read the config: {error.strerror or error}"], str(path)) from None
    if len(raw) > MAX_CONFIG_BYTES:
        raise ConfigError([f"is larger than {MAX_CONFIG_BYTES >> 20} MB: not a config file"], str(path))
    if b"\x00" in raw:
        raise ConfigError(["is a binary file, not a TOML config (it holds NUL bytes)"], str(path))
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        raise ConfigError([f"is not UTF-8 text (byte {error.start} is {raw[error.start]:#04x}): "
                           "save the config as UTF-8"], str(path)) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise ConfigError([f"is not valid TOML: {error}"], str(path)) from None
    except RecursionError:
        raise ConfigError(["nests arrays or tables too deeply to be a config"], str(path)) from None
    return data
