"""Which turbines a turning beam needs at once: the window of the pattern
above a floor, and the channels a scene needs at its worst azimuth.

A turbine whose two-way gain (``AntennaScan.two_way_gain_db`` of the offset
beam − turbine) lies at or below ``assign_below_db`` contributes less than
that floor; a board whose channels follow the beam serves only the turbines
inside the window where the gain is above it, and the most of them inside
the window at one beam azimuth is the channels it needs. The window is the
span of offsets from the lowest to the highest where the gain is above the
floor (a sidelobe above the floor widens it, conservatively); when the
pattern's floor ``sidelobe_db`` lies above ``assign_below_db`` the gain
never falls below it and every turbine needs its channel all the time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rast.model.physics.antenna import AntennaScan

__all__ = ["BeamWindow", "assignment_window", "BeamChannels", "channels_needed", "follow_rows_held", "farm_follow_plan"]

#: Offsets at which a measured pattern is evaluated for its window (degrees).
_PATTERN_STEP_DEG = 1e-3


@dataclass(frozen=True)
class BeamWindow:
    """Offsets (beam − turbine, degrees) from ``low_deg`` to ``high_deg`` hold
    every gain above ``floor_db``; None for both: the whole circle."""
    floor_db: float
    low_deg: float | None
    high_deg: float | None

    @property
    def whole_circle(self) -> bool:
        return self.low_deg is None

    @property
    def width_deg(self) -> float:
        return 360.0 if self.whole_circle else self.high_deg - self.low_deg


def assignment_window(scan: AntennaScan, floor_db: float) -> BeamWindow:
    """The window of ``scan``'s two-way pattern above ``floor_db``. The
    Gaussian lobe's is ±θ₃·√(−floor/24) (−24·(θ/θ₃)² dB = floor); a
    measured pattern's is found on a 0.001° grid."""
    if scan.sidelobe_db > floor_db:
        return BeamWindow(floor_db, None, None)
    if scan.pattern is None:
        half = scan.beamwidth_deg * math.sqrt(-floor_db / 24.0)
        return BeamWindow(floor_db, -half, half) if half < 180.0 else BeamWindow(floor_db, None, None)
    offsets = np.arange(-180.0, 180.0, _PATTERN_STEP_DEG)
    above = offsets[scan.two_way_gain_db(offsets) > floor_db]
    if above.size == 0:
        return BeamWindow(floor_db, 0.0, 0.0)
    return BeamWindow(floor_db, float(above.min()), float(above.max()))


@dataclass(frozen=True)
class BeamChannels:
    """The most turbines inside the window at one beam azimuth."""
    channels: int
    beam_azimuth_deg: float     # a beam azimuth where that many are inside
    turbines: int
    window: BeamWindow


def channels_needed(azimuths_deg, window: BeamWindow) -> BeamChannels:
    """The most of the turbines at ``azimuths_deg`` inside ``window`` at one
    beam azimuth b (turbine k is inside when its offset b − az_k, wrapped,
    lies in the window: az_k in [b − high, b − low]), and such a b. The
    count is a sliding arc over the sorted azimuths; its maximum is reached
    with the arc starting at a turbine."""
    az = np.sort(np.mod(np.asarray(azimuths_deg, dtype=float), 360.0))
    n = az.size
    if n == 0:
        return BeamChannels(0, 0.0, 0, window)
    if window.whole_circle or window.width_deg >= 360.0:
        return BeamChannels(n, 0.0, n, window)
    doubled = np.concatenate([az, az + 360.0])
    ends = np.searchsorted(doubled, az + window.width_deg, side="right")
    counts = ends - np.arange(n)
    k = int(np.argmax(counts))
    # every beam azimuth from (last inside) + low to (first inside) + high
    # holds them all: the middle of that span
    beam = (doubled[ends[k] - 1] + window.low_deg + az[k] + window.high_deg) / 2
    return BeamChannels(int(counts[k]), float(np.mod(beam, 360.0)), n, window)


def _follow_setup(farm, contract, channels: int | None):
    """The scene's window, sorted azimuth codes and guard on a board built
    as ``contract`` (``channels`` loads; None: as many as the scene needs,
    found with the guard of one load)."""
    from rast.model.contract.follow import follow_guard_codes, follow_occupancy, follow_pattern
    from rast.model.contract.scan import azimuth_code, pattern_words

    scan = farm.scan
    window = follow_pattern(scan, pattern_words(scan))
    az = np.sort(azimuth_code([w.azimuth_deg for w in farm.windmills]))
    loads = channels
    if loads is None:
        loads = follow_occupancy(az, window, follow_guard_codes(scan, contract, 1)).channels
    return window, az, follow_guard_codes(scan, contract, loads)


def follow_rows_held(farm, contract):
    """The turbines holding a channel of a board following the beam (built
    as ``contract``: its timing sets the guard) at each of the 2**16 beam
    codes; None where following saves nothing."""
    from rast.model.contract.follow import rows_held
    if not farm.scan.turning:
        return None
    try:
        window, az, guard = _follow_setup(farm, contract, None)
    except ValueError:
        return None
    return rows_held(az, window, guard)


def farm_follow_plan(farm, contract, channels: int | None = None) -> str:
    """What a board whose channels follow the beam needs for ``farm``, by the
    contract's rule (``rast.model.contract.follow``: the kept pattern entries,
    the guard, the rows held at once); with ``channels`` (a build's) a scene
    that needs more is refused (ValueError naming the beam and the count).
    The guard is timed on ``contract`` (the build's), for ``channels`` loads
    or, without, as many as the scene needs."""
    from rast.model.contract.follow import check_follow, follow_occupancy
    from rast.model.contract.scan import AZIMUTH_CODES

    scan = farm.scan
    n = len(farm.windmills)
    try:
        window, az, guard = _follow_setup(farm, contract, channels)
    except ValueError as error:
        if channels is not None:
            raise
        return f"beam-following channels: none saved: {error} ({n} channels)"
    need = (follow_occupancy(az, window, guard) if channels is None
            else check_follow(az, window, guard, channels))
    deg = 360.0 / AZIMUTH_CODES
    return (f"beam-following channels: the two-way pattern is above {scan.assign_below_db:g} dB from "
            f"{window.lo * deg:+.2f} to {window.hi * deg:+.2f} deg of offset, a turbine takes its channel "
            f"{guard} codes ({guard * deg:.3f} deg) earlier; at most {need.channels} of the {n} turbines "
            f"hold one at once (beam from {need.beam_deg:.2f} to {need.last_deg:.2f} deg)")
