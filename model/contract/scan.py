"""The fixed-point rule of the antenna scan, written down once
(docs/fixed_point.md, "The antenna scan"; docs/antenna_scan.md).

* Azimuth: ``AZIMUTH_BITS`` = 16 bits per revolution, clockwise from north
  (code 0 = north, 16384 = east). A turbine's azimuth code is
  ``round(azimuth_deg / 360 · 2**16) mod 2**16``.
* The beam, free running: a revolution is ``P = round(sample_rate · 60 / |rpm|)``
  RTS samples, exactly (a rate within half a sample per revolution of the
  asked one; a binary phase accumulator of 32 bits would be 0.6 % off at
  12.5 rpm and 20 MS/s). The position counts ``2**16`` per sample modulo
  ``P · 2**16`` from the start's code times ``P`` (down for an anticlockwise
  scan); the beam's code is the position over ``P``, rounded down: a code
  and a remainder below ``P``, the remainder growing (shrinking) by 2**16 a
  sample and carrying into the code. ``P`` is below 2**32.
* Following the radar: ``N`` ACPs a revolution (``acp_per_rev``, or learned:
  the count between two ARPs, when at least ``ACP_MIN_LEARN`` and no ARP was
  missed in between; 65536 until one is learned); the count since the last
  ARP ``k`` gives the code ``floor(k · 2**16 / N) mod 2**16``. An ARP and an
  ACP in the same step: the ARP first (the ACP is the revolution's first).
  An ACP while ``k = N`` means an ARP was missed: ARP-lost, until the next
  ARP; the count and the code go on. Following the radar: the ACP count times
  ``2**16 / acp_per_rev``, rounded down.
* The offset ``o = beam − turbine`` wraps modulo 2**16 and is read signed.
* The pattern: a table of ``PATTERN_ENTRIES`` unsigned words of
  ``PATTERN_WIDTH`` bits, ``PATTERN_FRAC`` fractional (the peak, 0 dB, is
  ``2**15``), spaced ``2**shift`` azimuth codes and centred on the beam: entry
  ``k`` holds the two-way amplitude ``10^(G/20)`` at offset
  ``(k − 512 + ½)·2**shift`` codes, rounded to nearest. An offset is looked up
  as ``k = (o + 2**(9 + shift)) >> shift`` when ``0 ≤ k < 1024``; beyond the
  table's span it gets the floor word, ``round(10^(sidelobe_db/20) · 2**15)``.
  ``shift`` (0…6) is the smallest whose span holds every offset where the
  pattern is above its floor: the finest step that loses nothing.
* A channel's gain on a step: ``round_half_up(GAIN · pattern_word, PATTERN_FRAC)``,
  a ``GAIN_WIDTH``-bit word (the product of two words ≤ 1.0 is ≤ the gain).
"""

from __future__ import annotations


import numpy as np

from rast.model.contract.fixedpoint import round_half_up

__all__ = ["AZIMUTH_BITS", "AZIMUTH_CODES", "PATTERN_INDEX_BITS", "PATTERN_ENTRIES",
           "PATTERN_WIDTH", "PATTERN_FRAC", "PATTERN_ONE", "MAX_PATTERN_SHIFT", "azimuth_code",
           "samples_per_revolution", "free_beam_codes", "acp_beam_code", "AcpTrack", "ACP_MIN_LEARN",
           "ACP_UNLEARNED", "BeamGenerator", "pattern_shift", "span_deg",
           "PatternWords", "pattern_words", "pattern_lookup", "scanned_gain", "beam_codes", "scan_settings"]

AZIMUTH_BITS = 16
AZIMUTH_CODES = 1 << AZIMUTH_BITS
PATTERN_INDEX_BITS = 10
PATTERN_ENTRIES = 1 << PATTERN_INDEX_BITS
PATTERN_WIDTH = 16
PATTERN_FRAC = 15
PATTERN_ONE = 1 << PATTERN_FRAC
MAX_PATTERN_SHIFT = AZIMUTH_BITS - PATTERN_INDEX_BITS


def azimuth_code(azimuth_deg) -> np.ndarray:
    """``round(azimuth_deg / 360 · 2**16) mod 2**16``."""
    return np.mod(np.round(np.asarray(azimuth_deg, dtype=float) / 360.0 * AZIMUTH_CODES), AZIMUTH_CODES
                  ).astype(np.int64)


def samples_per_revolution(rpm: float, sample_rate_hz: float) -> int:
    """``P``: RTS samples per revolution of the free-running beam."""
    p = round(sample_rate_hz * 60.0 / abs(rpm))
    if p >= 1 << 32:
        raise ValueError(f"scan_rpm {rpm:g} is a revolution of more than 2**32 RTS samples at "
                         f"{sample_rate_hz / 1e6:g} MS/s: at least {sample_rate_hz * 60 / (1 << 32):.3g} rpm")
    if p < AZIMUTH_CODES:
        raise ValueError(f"scan_rpm {rpm:g} turns more than one azimuth code per RTS sample at "
                         f"{sample_rate_hz / 1e6:g} MS/s: at most {sample_rate_hz * 60 / AZIMUTH_CODES:g} rpm")
    return p


def free_beam_codes(start_deg: float, rpm: float, sample_rate_hz: float, steps) -> np.ndarray:
    """The free-running beam's azimuth code at RTS samples ``steps``."""
    p = samples_per_revolution(rpm, sample_rate_hz)
    modulus = p * AZIMUTH_CODES
    start = int(azimuth_code(start_deg)) * p
    n = np.asarray(steps, dtype=np.int64) % p                  # the position's period is P samples
    direction = 1 if rpm > 0 else -1
    position = (start + direction * n * AZIMUTH_CODES) % modulus
    return position // p


def acp_beam_code(count, acp_per_rev: int) -> np.ndarray:
    """The beam's code after ``count`` ACPs since the ARP: ``floor(count · 2**16 / N) mod 2**16``."""
    return (np.asarray(count, dtype=np.int64) * AZIMUTH_CODES) // int(acp_per_rev) % AZIMUTH_CODES


#: Fewest ACPs between two ARPs that "auto" takes as the count of a revolution.
ACP_MIN_LEARN = 256
#: The count per revolution before one is learned.
ACP_UNLEARNED = AZIMUTH_CODES


class AcpTrack:
    """The beam following the radar, step by step (the contract's rule above).

    ``acp_per_rev``: N, or "auto". :meth:`event` takes one step's ARP and
    ACP (the ARP first); :attr:`code` is the code after them."""

    def __init__(self, acp_per_rev):
        self.auto = acp_per_rev == "auto"
        self.fixed = None if self.auto else int(acp_per_rev)
        self.restart()

    def restart(self) -> None:
        """Count, code and what was learned cleared (the generator's restart)."""
        self.n = ACP_UNLEARNED if self.auto else self.fixed
        self.count = 0
        self.lost = False
        self.learned = False

    def event(self, arp: bool, acp: bool) -> None:
        if arp:
            if self.auto and not self.lost and ACP_MIN_LEARN <= self.count <= AZIMUTH_CODES:
                self.n, self.learned = self.count, True
            self.count, self.lost = 0, False
        if acp:
            if self.count == self.n:
                self.lost = True
            self.count += 1

    @property
    def code(self) -> int:
        return int(acp_beam_code(self.count, self.n))


class BeamGenerator:
    """The board's beam step by step, as its generator
    (``rast.hdl.scan_generator.ScanGenerator``) makes it from the SCAN_*
    registers and the ACP/ARP strobes: the replay model's.

    :meth:`configure` takes the registers' values, :meth:`restart` is
    SCAN_CTRL.restart, :meth:`event` an ARP and/or ACP strobe, :meth:`take`
    the next steps' beams. ACP settings changed within a revolution, or
    SCAN_PERIOD while the beam turns, are taken at the next restart (the
    gateware's count, stepped by the old settings, may differ until then).
    An ARP within ``ACP_MIN_CLOCKS`` fabric clocks after an ACP learns
    nothing in the gateware (its division is not done); the model assumes
    none comes that close."""

    def __init__(self):
        self.mode, self.anticlockwise, self.period, self.start = 0, False, AZIMUTH_CODES, 0
        self.track = AcpTrack(ACP_UNLEARNED)
        self.free_code, self.free_rem = 0, 0

    def configure(self, mode: int, anticlockwise: bool, auto: bool, acp_log2: int, period: int, start: int):
        self.mode, self.anticlockwise, self.period, self.start = mode, bool(anticlockwise), period, start
        self.track.auto, self.track.fixed = bool(auto), 1 << acp_log2
        if not auto:
            self.track.n = self.track.fixed

    def restart(self) -> None:
        self.free_code, self.free_rem = self.start, 0
        self.track.restart()

    def event(self, arp: bool, acp: bool) -> None:
        self.track.event(arp, acp)

    @property
    def per_rev(self) -> int:
        return self.track.n

    @property
    def code(self) -> int:
        """The beam's code now (SCAN_STATUS.beam)."""
        return (self.free_code if self.mode == 1 else self.track.code if self.mode == 2 else 0)

    def take(self, n: int) -> np.ndarray:
        """The beams of the next ``n`` steps (the free beam advancing a sample each)."""
        if self.mode != 1:
            return np.full(n, self.code, dtype=np.int64)
        p = self.period
        modulus = p * AZIMUTH_CODES
        pos = self.free_code * p + self.free_rem
        step = -AZIMUTH_CODES if self.anticlockwise else AZIMUTH_CODES
        beams = (pos + step * np.arange(n, dtype=np.int64)) % modulus // p
        pos = (pos + step * n) % modulus
        self.free_code, self.free_rem = pos // p, pos % p
        return beams


def span_deg(shift: int) -> float:
    """Half the table's span: offsets within ±this many degrees are looked up."""
    return (1 << (PATTERN_INDEX_BITS - 1 + shift)) * 360.0 / AZIMUTH_CODES


def pattern_shift(scan) -> int:
    """The finest table step whose span holds every offset where ``scan``'s
    pattern is above its floor (``rast.model.physics.antenna.AntennaScan``)."""
    theta = np.linspace(-180.0, 180.0, 360_001)            # 0.001° apart
    above = np.abs(theta[scan.two_way_gain_db(theta) > scan.sidelobe_db])
    reach = float(above.max()) + 0.001 if above.size else 0.0
    for shift in range(MAX_PATTERN_SHIFT + 1):
        if span_deg(shift) > reach:
            return shift
    return MAX_PATTERN_SHIFT


class PatternWords:
    """The table a scan loads: ``words`` (PATTERN_ENTRIES), ``floor`` and ``shift``."""

    def __init__(self, words, floor: int, shift: int):
        self.words = np.asarray(words, dtype=np.int64)
        self.floor = int(floor)
        self.shift = int(shift)


def _amplitude_word(gain_db) -> np.ndarray:
    word = np.floor(10.0 ** (np.asarray(gain_db, dtype=float) / 20.0) * PATTERN_ONE + 0.5).astype(np.int64)
    return np.clip(word, 1, PATTERN_ONE)


def pattern_words(scan) -> PatternWords:
    """The pattern table of ``scan`` (contract rule above)."""
    shift = pattern_shift(scan)
    k = np.arange(PATTERN_ENTRIES)
    centre_deg = (k - PATTERN_ENTRIES // 2 + 0.5) * (1 << shift) * 360.0 / AZIMUTH_CODES
    return PatternWords(_amplitude_word(scan.two_way_gain_db(centre_deg)),
                        int(_amplitude_word(scan.sidelobe_db)), shift)


def pattern_lookup(table: PatternWords, offset_codes) -> np.ndarray:
    """The pattern word at azimuth offsets (beam − turbine, codes, any integer)."""
    o = np.mod(np.asarray(offset_codes, dtype=np.int64) + AZIMUTH_CODES // 2, AZIMUTH_CODES) - AZIMUTH_CODES // 2
    u = o + (1 << (PATTERN_INDEX_BITS - 1 + table.shift))
    k = u >> table.shift
    inside = (u >= 0) & (k < PATTERN_ENTRIES)
    return np.where(inside, table.words[np.clip(k, 0, PATTERN_ENTRIES - 1)], table.floor)


def scanned_gain(gain_word, pattern_word) -> np.ndarray:
    """A channel's gain word on a step: ``round_half_up(gain · pattern, PATTERN_FRAC)``."""
    return round_half_up(np.asarray(gain_word, dtype=np.int64) * np.asarray(pattern_word, dtype=np.int64),
                         PATTERN_FRAC)


def beam_codes(scan, sample_rate_hz: float, steps) -> np.ndarray:
    """The beam's azimuth code at RTS samples ``steps`` as the board would
    have it: free running, or (acp mode) from the ACPs of a radar turning
    at ``scan.rpm`` (rounded down to the last one; with "auto" the model,
    not knowing the radar's count, takes one ACP per azimuth code)."""
    if scan.mode == "free":
        return free_beam_codes(scan.start_deg, scan.rpm, sample_rate_hz, steps)
    acp = AZIMUTH_CODES if scan.acp_per_rev == "auto" else int(scan.acp_per_rev)
    t = np.asarray(steps, dtype=np.int64) / sample_rate_hz
    turns = scan.start_deg / 360.0 + scan.rpm / 60.0 * t
    count = np.mod(np.floor(turns * acp), acp).astype(np.int64)
    return acp_beam_code(count, acp)


def scan_settings(scan, sample_rate_hz: float) -> dict:
    """What a host loads into a block built with the scan for ``scan``
    (``rast.model.physics.antenna.AntennaScan``): the SCAN_* and PATTERN
    register values and the table (the manifest's ``scan``)."""
    mode = {"stare": 0, "free": 1, "acp": 2}[scan.mode]
    out = {"mode": mode, "anticlockwise": int(scan.rpm < 0), "auto": 0, "acp_log2": 16,
           "period_samples": AZIMUTH_CODES, "start_code": int(azimuth_code(scan.start_deg))}
    if scan.mode == "free":
        out["period_samples"] = samples_per_revolution(scan.rpm, sample_rate_hz)
    if scan.mode == "acp":
        if scan.acp_per_rev == "auto":
            out["auto"] = 1
        else:
            out["acp_log2"] = int(scan.acp_per_rev).bit_length() - 1
    table = pattern_words(scan)
    out["pattern"] = {"shift": table.shift, "floor": table.floor, "words": [int(w) for w in table.words]}
    return out
