"""The radar antenna's scan and its two-way pattern (config keys ``scan_mode``,
``scan_rpm``, ``scan_start_deg``, ``acp_per_rev``, ``beamwidth_deg``,
``sidelobe_db``, ``pattern_file``, ``assign_below_db``; docs/antenna_scan.md).

An RTS fed through a coupler bypasses the antenna, so it applies the pattern
itself: each turbine's echo is scaled by the two-way gain at the offset
between the beam's azimuth and the turbine's (``Windmill.azimuth_deg``).
Azimuths are degrees clockwise from north; an offset is ``beam − turbine``
wrapped to [−180, 180).

The default pattern is a Gaussian main lobe, parabolic in dB,
``G(θ) = −24·(θ/θ₃)²`` dB two-way (−3 dB one way, −6 dB two way, at θ₃/2),
floored at ``sidelobe_db``; or a measured two-way pattern from a CSV file
(offset in degrees, gain in dB), interpolated linearly in dB, floored the
same way and taken as the floor beyond the offsets it lists.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["SCAN_MODES", "ACP_COUNTS", "PatternTable", "AntennaScan", "gaussian_two_way_db",
           "wrap_offset_deg", "read_pattern_csv", "MAX_PATTERN_ROWS"]

SCAN_MODES = ("stare", "free", "acp")
#: Azimuth change pulses per revolution the ACP input takes ("auto": learned
#: as the count between two azimuth reference pulses).
ACP_COUNTS = (4096, 16384, 65536, "auto")
#: Rows a pattern file may hold (a measured pattern at 0.01° is 36,000).
MAX_PATTERN_ROWS = 1 << 17


def wrap_offset_deg(offset_deg):
    """An azimuth difference wrapped to [−180, 180) degrees."""
    return np.mod(np.asarray(offset_deg, dtype=float) + 180.0, 360.0) - 180.0


def gaussian_two_way_db(offset_deg, beamwidth_deg: float, sidelobe_db: float):
    """The two-way Gaussian main lobe ``−24·(θ/θ₃)²`` dB, floored at ``sidelobe_db``."""
    theta = wrap_offset_deg(offset_deg)
    return np.maximum(-24.0 * (theta / beamwidth_deg) ** 2, sidelobe_db)


@dataclass(frozen=True)
class PatternTable:
    """A measured two-way pattern: gain in dB at ascending offsets in degrees."""
    offset_deg: np.ndarray
    gain_db: np.ndarray
    source: str = ""


def read_pattern_csv(path) -> PatternTable:
    """A pattern file: rows of ``offset_deg, gain_db`` (a header row of text is
    skipped; blank lines and ``#`` comments too). Offsets in [−180, 180],
    strictly ascending once sorted, at least two; gains finite and ≤ 0 dB
    (the pattern's peak is the radar's own gain). Raises ValueError naming the
    file and the line."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as error:
        raise ValueError(f"pattern_file {str(path)!r}: cannot read it: "
                         f"{getattr(error, 'strerror', None) or error}") from None
    rows = []
    for number, cells in enumerate(csv.reader(text.splitlines()), start=1):
        cells = [c.strip() for c in cells]
        if not cells or not any(cells) or cells[0].startswith("#"):
            continue
        try:
            values = [float(c) for c in cells[:2]]
        except ValueError:
            if not rows and number == 1:
                continue                        # a header
            raise ValueError(f"pattern_file {str(path)!r} line {number}: expected two numbers "
                             f"(offset_deg, gain_db), not {','.join(cells)[:60]!r}") from None
        if len(values) != 2 or not all(math.isfinite(v) for v in values):
            raise ValueError(f"pattern_file {str(path)!r} line {number}: expected two finite numbers "
                             f"(offset_deg, gain_db), not {','.join(cells)[:60]!r}")
        if not -180 <= values[0] <= 180:
            raise ValueError(f"pattern_file {str(path)!r} line {number}: offset {values[0]:g} deg "
                             "is outside [-180, 180]")
        if values[1] > 0:
            raise ValueError(f"pattern_file {str(path)!r} line {number}: gain {values[1]:g} dB is above "
                             "0 dB: give the two-way pattern relative to its peak")
        rows.append(values)
        if len(rows) > MAX_PATTERN_ROWS:
            raise ValueError(f"pattern_file {str(path)!r}: more than {MAX_PATTERN_ROWS:,} rows")
    if len(rows) < 2:
        raise ValueError(f"pattern_file {str(path)!r}: needs at least two rows (offset_deg, gain_db), "
                         f"has {len(rows)}")
    table = np.array(sorted(rows))
    if np.any(np.diff(table[:, 0]) <= 0):
        k = int(np.flatnonzero(np.diff(table[:, 0]) <= 0)[0])
        raise ValueError(f"pattern_file {str(path)!r}: offset {table[k, 0]:g} deg is listed twice")
    return PatternTable(table[:, 0], table[:, 1], str(path))


@dataclass(frozen=True)
class AntennaScan:
    """How the beam turns and what it weighs each turbine by.

    ``mode``: "stare" (every turbine lit on every pulse, the pattern unused),
    "free" (the RTS turns the beam itself at ``rpm``) or "acp" (the beam
    follows the radar's azimuth change pulses, ``acp_per_rev`` per revolution;
    the model then assumes the radar turns at ``rpm``). ``rpm``: revolutions
    per minute, positive clockwise seen from above; ``start_deg``: the beam's
    azimuth at t = 0; ``beamwidth_deg``: 3-dB one-way beamwidth θ₃;
    ``sidelobe_db``: the two-way floor (≤ 0 dB); ``pattern``: a measured
    pattern replacing the Gaussian lobe.
    """
    mode: str = "stare"
    rpm: float = 0.0
    start_deg: float = 0.0
    acp_per_rev: int | str = 4096
    beamwidth_deg: float = 1.4
    sidelobe_db: float = -50.0
    pattern: PatternTable | None = field(default=None, compare=False)
    #: The two-way gain (dB) at or below which a turbine needs no channel of a
    #: board whose channels follow the beam (``rast.model.physics.beam_window``).
    assign_below_db: float = -60.0

    @property
    def turning(self) -> bool:
        return self.mode != "stare"

    def two_way_gain_db(self, offset_deg):
        """The two-way gain at azimuth offsets (beam − turbine), dB."""
        if self.pattern is None:
            return gaussian_two_way_db(offset_deg, self.beamwidth_deg, self.sidelobe_db)
        theta = wrap_offset_deg(offset_deg)
        p = self.pattern
        gain = np.interp(theta, p.offset_deg, p.gain_db, left=self.sidelobe_db, right=self.sidelobe_db)
        return np.maximum(gain, self.sidelobe_db)

    def beam_azimuth_deg(self, t_s):
        """The beam's azimuth at times ``t_s`` (clockwise from north, [0, 360));
        in acp mode quantised down to the last azimuth change pulse (the
        radar's count unknown with "auto", the model's azimuth is then continuous)."""
        t = np.asarray(t_s, dtype=float)
        az = np.mod(self.start_deg + 6.0 * self.rpm * t, 360.0)
        if self.mode == "acp" and self.acp_per_rev != "auto":
            az = np.floor(az * self.acp_per_rev / 360.0) * (360.0 / self.acp_per_rev)
        return az

    def amplitude(self, t_s, azimuth_deg: float):
        """The amplitude factor ``10^(G/20)`` a turbine at ``azimuth_deg`` gets
        at times ``t_s`` (1 when the antenna stares)."""
        if not self.turning:
            return np.ones(np.shape(t_s))
        return 10.0 ** (self.two_way_gain_db(self.beam_azimuth_deg(t_s) - azimuth_deg) / 20.0)

    @property
    def revolution_s(self) -> float:
        return 60.0 / abs(self.rpm) if self.rpm else math.inf

    def dwell_pulses(self, prf_hz: float) -> float:
        """Pulses while the beam turns one beamwidth (the radar's hits per dwell)."""
        return prf_hz * self.beamwidth_deg / (6.0 * abs(self.rpm)) if self.rpm else math.inf
