"""Channels that follow the beam: the rule, written down once
(docs/beam_following.md).

A board whose channels follow the beam keeps a *turbine table* (one row per
channel of the one-channel-per-turbine scene, sorted by azimuth) and hands
its C channels to the rows the beam is about to reach. Everything is in
azimuth codes (``rast.model.contract.scan``: 2**16 a revolution).

* The window. The pattern table's entries whose two-way gain at their centre
  lies above ``assign_below_db`` are kept; every other entry, and the floor
  word, is 0 (:func:`follow_pattern`). A turbine outside the kept entries
  then adds nothing, on any board: the model with one channel per turbine
  and this table is the reference the following board is bit-exact with.
  The kept entries span the offsets (beam − turbine) ``lo .. hi`` (codes,
  signed; the first kept entry's first code to the last one's last).
* The guard. A row is *held* (has a channel) while its offset lies in
  ``lo − guard .. hi``: it takes its channel ``guard`` codes before it can
  add anything, so the load that sets the channel up, and the switch's
  refill, end while its gain is still 0. ``guard`` is the beam's largest
  step (one code free running; a revolution over the ACP count following
  the radar) plus the codes the beam turns while C loads are made and the
  last refills, plus one (:func:`follow_guard_codes`).
* Entering and leaving. Row k has the entry code ``E_k = az_k + lo − guard``
  and the exit code ``X_k = az_k + hi + 1`` (mod 2**16): it is held for the
  beams ``b`` with ``(b − E_k) mod 2**16 < W``, ``W = hi + 1 − lo + guard``.
  The beam turns clockwise; when it moves from ``p`` to ``b`` every row whose
  exit or entry code lies in ``(p, b]`` leaves or enters, in the order of the
  codes, leaving before entering at one code. Rows sorted by azimuth enter
  and leave in the same order, so the j-th entry since the start takes
  channel ``j mod C`` and the j-th exit frees channel ``j mod C``: no
  search, and no channel is taken twice as long as at most C rows are held
  at once (:func:`follow_occupancy`; a scene needing more is refused).
* The blade phase. A row's stream position at step n of the scene (step 0:
  the start) is ``(n · PHASE_INC) mod (LENGTH · 2**32)``, the position of a
  channel that had played it from the start: the load sets the channel's
  phase to that at the step it lands (``follow_phase``).
* A row is 128 bits, four 32-bit words, fields from bit 0 up:
  ``FOLLOW_ROW_FIELDS``; the table is loaded and CRC-checked as streams are.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rast.model.contract.fixedpoint import GAIN_WIDTH, PHASE_FRAC_BITS, REGISTER_STAGING, take_interval
from rast.model.contract.scan import AZIMUTH_CODES, PATTERN_ENTRIES, PatternWords

__all__ = ["FOLLOW_STEP_BITS", "PHASE_CLOCKS", "follow_switch_margin_steps", "follow_lead_steps", "follow_load_steps", "FOLLOW_ROW_FIELDS", "FOLLOW_ROW_WORDS", "FollowRow", "pack_rows", "unpack_rows", "FollowWindow",
           "follow_pattern", "follow_guard_codes", "FollowOccupancy", "rows_held", "follow_occupancy", "check_follow",
           "follow_phase", "Follower", "FollowEvent"]

#: Bits of the scene's step counter: the blade phase is exact for 2**48 steps
#: from the start (162 days at 20 MS/s).
FOLLOW_STEP_BITS = 48
#: Fabric clocks the blade phase's product takes: two a bit of the step.
PHASE_CLOCKS = 2 * FOLLOW_STEP_BITS
#: Register writes of a load before its phase is known (AZIMUTH, GAIN, DELAY,
#: APPLY, LENGTH, PHASE_INC) and after (BASE, START, FOLLOW_SWITCH).
LOAD_WRITES_BEFORE, LOAD_WRITES_AFTER = 6, 3


def follow_switch_margin_steps(slots: int) -> int:
    """Steps ahead the step a load's FOLLOW_SWITCH names must be when the
    loader offers the write: the bus may keep it a ``take_interval``, it lands
    REGISTER_STAGING clocks later, and two steps spare."""
    return -(-(take_interval(slots) + REGISTER_STAGING) // slots) + 2


def follow_lead_steps(slots: int) -> int:
    """Steps from the loader's deciding an entry to the step its switch
    names: the phase's product (a clock to start it) or the first writes
    (each offered a clock after the last was taken, a ``take_interval``
    apart), then BASE and START, and the switch's margin
    (:func:`follow_switch_margin_steps`), a step spare. Under half the span
    of FOLLOW_SWITCH's step bits at every M."""
    ti = take_interval(slots) + 1
    clocks = max(PHASE_CLOCKS + 2, LOAD_WRITES_BEFORE * ti) + (LOAD_WRITES_AFTER - 1) * ti
    return -(-clocks // slots) + follow_switch_margin_steps(slots) + 1


#: A row's fields, (name, width) from bit 0 up; 128 bits in all.
FOLLOW_ROW_FIELDS = (("azimuth", 16), ("gain", GAIN_WIDTH), ("delay", 16), ("base", 23), ("length", 24),
                     ("phase_inc", PHASE_FRAC_BITS))
FOLLOW_ROW_WORDS = 4
assert sum(w for _, w in FOLLOW_ROW_FIELDS) == 32 * FOLLOW_ROW_WORDS


@dataclass(frozen=True)
class FollowRow:
    """One row of the turbine table: what a channel is loaded with when the
    row takes it (the registers of the same names; ``azimuth`` a code)."""
    azimuth: int
    gain: int
    delay: int
    base: int
    length: int
    phase_inc: int


def pack_rows(rows) -> np.ndarray:
    """The table's words (uint32, FOLLOW_ROW_WORDS a row), rows in the order
    given; a field too wide for its bits is refused by name."""
    words = []
    for k, row in enumerate(rows):
        value, lsb = 0, 0
        for name, width in FOLLOW_ROW_FIELDS:
            v = int(getattr(row, name))
            if not 0 <= v < 1 << width:
                raise ValueError(f"turbine table row {k}: {name} {v} does not fit its {width} bits")
            value |= v << lsb
            lsb += width
        words += [(value >> (32 * j)) & 0xFFFFFFFF for j in range(FOLLOW_ROW_WORDS)]
    return np.array(words, dtype=np.uint32)


def unpack_rows(words) -> list:
    """The rows of a table's words (:func:`pack_rows` undone)."""
    words = [int(w) for w in words]
    if len(words) % FOLLOW_ROW_WORDS:
        raise ValueError(f"a turbine table is {FOLLOW_ROW_WORDS} words a row, not {len(words)} words")
    rows = []
    for k in range(0, len(words), FOLLOW_ROW_WORDS):
        value = sum(w << (32 * j) for j, w in enumerate(words[k:k + FOLLOW_ROW_WORDS]))
        fields, lsb = {}, 0
        for name, width in FOLLOW_ROW_FIELDS:
            fields[name] = (value >> lsb) & ((1 << width) - 1)
            lsb += width
        rows.append(FollowRow(**fields))
    return rows


@dataclass(frozen=True)
class FollowWindow:
    """The kept entries' offsets ``lo .. hi`` (codes, signed) and the table
    with every other entry and the floor at 0."""
    lo: int
    hi: int
    table: PatternWords


def follow_pattern(scan, table: PatternWords) -> FollowWindow:
    """``table`` (``pattern_words(scan)``) with the entries at or below
    ``scan.assign_below_db`` and the floor set to 0, and the kept span.
    Refused where following saves nothing: the pattern's floor above the
    assignment floor (every turbine always adds), or no entry above it."""
    floor = scan.assign_below_db
    if scan.sidelobe_db > floor:
        raise ValueError(f"sidelobe_db {scan.sidelobe_db:g} dB lies above assign_below_db {floor:g} dB: "
                         "every turbine adds at every azimuth, so no channel can follow the beam; set "
                         "sidelobe_db at or below assign_below_db")
    shift = table.shift
    k = np.arange(PATTERN_ENTRIES)
    centre_deg = (k - PATTERN_ENTRIES // 2 + 0.5) * (1 << shift) * 360.0 / AZIMUTH_CODES
    kept = np.asarray(scan.two_way_gain_db(centre_deg)) > floor
    if not kept.any():
        raise ValueError(f"no entry of the pattern lies above assign_below_db {floor:g} dB")
    first, last = int(np.argmax(kept)), int(PATTERN_ENTRIES - 1 - np.argmax(kept[::-1]))
    words = np.where(kept, table.words, 0)
    half = PATTERN_ENTRIES // 2
    return FollowWindow((first - half) << shift, ((last - half + 1) << shift) - 1,
                        PatternWords(words, 0, shift))


def follow_load_steps(slots: int) -> int:
    """Steps an entry takes the loader, at most, beside its switch's lead:
    reading its row and waiting for the bus's first take, and an exit's
    write (GAIN 0) between two entries, one ``take_interval`` each."""
    return follow_lead_steps(slots) + -(-(2 * take_interval(slots) + 8) // slots)


def follow_guard_codes(scan, contract, loads: int) -> int:
    """The guard (codes): the beam's largest step, plus the codes it turns
    while ``loads`` loads are made one after another (each
    :func:`follow_load_steps`, the loader waiting for its switch) and the
    last one's refill (``contract.refill_samples``, muted), plus one.
    Following the radar with ``acp_per_rev = "auto"`` the step of 4096 ACPs
    is assumed (a radar with fewer sets its count: a load that lands late is
    flagged, never silent)."""
    if scan.mode == "free":
        step = 1
    else:
        acp = 4096 if scan.acp_per_rev == "auto" else int(scan.acp_per_rev)
        step = -(-AZIMUTH_CODES // acp)
    if contract.sample_rate_hz <= 0:
        raise ValueError("the guard needs the build's sample rate (sample_rate_hz)")
    codes_per_sample = abs(scan.rpm) / 60.0 * AZIMUTH_CODES / contract.sample_rate_hz
    steps = loads * follow_load_steps(contract.slots) + contract.refill_samples
    return step + math.ceil(steps * codes_per_sample) + 1


@dataclass(frozen=True)
class FollowOccupancy:
    """The most rows held at one beam code, and a span of beam codes
    (``beam_code`` to ``last_code``, clockwise) where that many are held."""
    channels: int
    beam_code: int
    rows: int
    last_code: int = 0

    @property
    def beam_deg(self) -> float:
        return self.beam_code * 360.0 / AZIMUTH_CODES

    @property
    def last_deg(self) -> float:
        return self.last_code * 360.0 / AZIMUTH_CODES


def rows_held(azimuth_codes, window: FollowWindow, guard: int) -> np.ndarray:
    """The rows held at every beam code (2**16 counts): row k from its entry
    code ``az_k + lo − guard`` for W codes (a difference array round the circle)."""
    az = np.asarray(azimuth_codes, dtype=np.int64) % AZIMUTH_CODES
    width = window.hi + 1 - window.lo + guard
    if width >= AZIMUTH_CODES:
        return np.full(AZIMUTH_CODES, az.size, dtype=np.int64)
    first = (az + window.lo - guard) % AZIMUTH_CODES
    diff = np.zeros(2 * AZIMUTH_CODES + 1, dtype=np.int64)
    np.add.at(diff, first, 1)
    np.add.at(diff, first + width, -1)
    held = np.cumsum(diff)
    return held[:AZIMUTH_CODES] + held[AZIMUTH_CODES:2 * AZIMUTH_CODES]


def follow_occupancy(azimuth_codes, window: FollowWindow, guard: int) -> FollowOccupancy:
    """The most of the rows at ``azimuth_codes`` held at one beam code, the
    first such code and the last of its run."""
    held = rows_held(azimuth_codes, window, guard)
    most = int(held.max())
    n = int(np.asarray(azimuth_codes).size)
    starts = np.flatnonzero((held == most) & (np.roll(held, 1) < most))
    if starts.size == 0:                                  # as many at every code
        return FollowOccupancy(most, 0, n, AZIMUTH_CODES - 1)
    first = int(starts[0])
    run = int(np.argmax(np.roll(held, -first) < most))
    return FollowOccupancy(most, first, n, (first + run - 1) % AZIMUTH_CODES)


def check_follow(azimuth_codes, window: FollowWindow, guard: int, channels: int) -> FollowOccupancy:
    """:func:`follow_occupancy`, refused when it needs more than ``channels``."""
    need = follow_occupancy(azimuth_codes, window, guard)
    if need.channels > channels:
        raise ValueError(f"{need.channels} turbines are within the beam's window at once with the beam from "
                         f"{need.beam_deg:.2f} to {need.last_deg:.2f} deg (codes {need.beam_code}..{need.last_code}), more than the build's {channels} "
                         f"channels; the window is {window.lo - guard}..{window.hi} codes of offset "
                         f"({guard} of them the guard)")
    return need


def follow_phase(step, phase_inc, length):
    """A row's stream phase at ``step`` of the scene (units of 2**-32 words):
    ``(step · phase_inc) mod (length · 2**32)``, the step counted modulo
    2**FOLLOW_STEP_BITS."""
    step = int(step) % (1 << FOLLOW_STEP_BITS)
    return (int(step) * int(phase_inc)) % (int(length) << PHASE_FRAC_BITS)


@dataclass(frozen=True)
class FollowEvent:
    """Row ``row`` enters (takes) or leaves (frees) ``channel``; ``code`` is
    the entry or exit code; ``late``: it entered with the beam already
    ``guard`` codes or more past its entry code."""
    kind: str           # "enter" | "leave"
    row: int
    channel: int
    code: int
    late: bool = False


class Follower:
    """The assignment, beam code by beam code, as the board makes it.

    ``azimuth_codes``: the table's rows' codes, sorted; :meth:`start` seeds
    the channels for the beam at the start (the rows held there enter in
    table order from the first after the beam's back edge); :meth:`move`
    takes the beam to a new code and returns the events in order. The
    scene begins once the start's loads have landed: the rows inside the
    window then are not late."""

    def __init__(self, azimuth_codes, window: FollowWindow, guard: int, channels: int):
        az = np.asarray(azimuth_codes, dtype=np.int64)
        if az.size and np.any(np.diff(az) < 0):
            raise ValueError("the turbine table's rows must be sorted by azimuth")
        self.az = az
        self.lo, self.hi, self.guard, self.channels = window.lo, window.hi, guard, channels
        self.width = window.hi + 1 - window.lo + guard
        if self.width >= AZIMUTH_CODES:
            raise ValueError("the window with its guard spans the whole revolution")

    def entry_code(self, k: int) -> int:
        return int(self.az[k] + self.lo - self.guard) % AZIMUTH_CODES

    def exit_code(self, k: int) -> int:
        return int(self.az[k] + self.hi + 1) % AZIMUTH_CODES

    def start(self, beam: int) -> list:
        """Seed: both pointers at the first row (table order, from row 0)
        whose entry code lies in ``(beam − W, …]``; then the beam sweeps from
        ``beam − W`` to ``beam``, entering the rows held at ``beam``."""
        n = self.az.size
        self.entered = self.left = 0
        self.pos = (beam - self.width) % AZIMUTH_CODES
        if n == 0:
            self.next_in = self.next_out = 0
            return []
        keys = (self.az + self.lo - self.guard - self.pos - 1) % AZIMUTH_CODES
        self.next_in = self.next_out = int(np.argmin(keys))
        return self.move(beam, seeding=True)

    @property
    def held(self) -> int:
        return self.entered - self.left

    def move(self, beam: int, seeding: bool = False) -> list:
        """Events of the beam's move from the last code to ``beam`` (while
        ``seeding``, before the scene begins, no entry is late)."""
        n = self.az.size
        span = (beam - self.pos) % AZIMUTH_CODES
        events = []
        while n:
            d_in = (self.entry_code(self.next_in) - self.pos - 1) % AZIMUTH_CODES
            d_out = (self.exit_code(self.next_out) - self.pos - 1) % AZIMUTH_CODES
            can_in, can_out = d_in < span and self.held < n, d_out < span and self.held > 0
            if can_out and (d_out <= d_in or not can_in):
                events.append(FollowEvent("leave", self.next_out, self.left % self.channels,
                                          self.exit_code(self.next_out)))
                self.left += 1
                self.next_out = (self.next_out + 1) % n
            elif can_in:
                if self.held >= self.channels:
                    raise ValueError(f"row {self.next_in} finds no free channel: {self.held} held "
                                     f"(beam code {beam})")
                late = not seeding and (beam - self.entry_code(self.next_in)) % AZIMUTH_CODES >= self.guard
                events.append(FollowEvent("enter", self.next_in, self.entered % self.channels,
                                          self.entry_code(self.next_in), late))
                self.entered += 1
                self.next_in = (self.next_in + 1) % n
            else:
                break
        self.pos = beam % AZIMUTH_CODES
        return events

