"""The rule of channels that follow the beam (rast.model.contract.follow):
the window of kept pattern entries, the rows held at each beam code, the
assignment by entry order, the refusal, the table's words, the phase."""

import math

import numpy as np
import pytest

from rast.model.contract.datapath import phase_sequence
from rast.model.contract.fixedpoint import ReplayContract
from rast.model.contract.follow import (FollowRow, Follower, check_follow, follow_guard_codes, follow_lead_steps,
                                        follow_load_steps,
                                        follow_occupancy,
                                        follow_pattern, follow_phase, pack_rows, unpack_rows)
from rast.model.contract.scan import AZIMUTH_CODES, pattern_lookup, pattern_words
from rast.model.physics.antenna import AntennaScan

CODES_PER_DEG = AZIMUTH_CODES / 360.0


def _scan(sidelobe_db=-70.0, assign_below_db=-60.0, beamwidth_deg=1.4, mode="free", acp=4096):
    return AntennaScan(mode, 12.5, 0.0, acp, beamwidth_deg, sidelobe_db, None, assign_below_db)


def _window(scan):
    return follow_pattern(scan, pattern_words(scan))


def _held_brute(az, lo, hi, guard):
    """Rows held at every beam code, counted code by code: row j is held from
    its entry code az_j + lo - guard for W codes."""
    width = hi + 1 - lo + guard
    held = np.zeros(AZIMUTH_CODES, dtype=np.int64)
    for a in az:
        codes = (a + lo - guard + np.arange(width)) % AZIMUTH_CODES
        held[codes] += 1
    return held


def _held_rows(az, lo, hi, guard, beam):
    width = hi + 1 - lo + guard
    return set(np.flatnonzero((beam - (np.asarray(az) + lo - guard)) % AZIMUTH_CODES < width).tolist())


def test_the_window_is_the_kept_entries_and_everything_else_is_zero():
    scan = _scan()
    window = _window(scan)
    half = scan.beamwidth_deg * math.sqrt(60.0 / 24.0) * CODES_PER_DEG     # the Gaussian lobe at -60 dB
    step = 1 << window.table.shift
    assert abs(window.lo + half) <= step and abs(window.hi - half) <= step
    inside = pattern_lookup(window.table, np.arange(window.lo, window.hi + 1))
    assert inside[0] > 0 and inside[-1] > 0 and np.all(inside > 0)
    outside = pattern_lookup(window.table, np.array([window.lo - 1, window.hi + 1, 20000, -20000, 32767]))
    assert np.array_equal(outside, np.zeros(5, dtype=np.int64))
    full = pattern_words(scan)     # inside the window the words are the pattern's own
    offsets = np.arange(window.lo, window.hi + 1)
    assert np.array_equal(pattern_lookup(window.table, offsets), pattern_lookup(full, offsets))


def test_following_is_refused_where_the_pattern_floor_lies_above_the_assignment_floor():
    with pytest.raises(ValueError, match="sidelobe_db -50 dB lies above assign_below_db -60 dB"):
        _window(_scan(sidelobe_db=-50.0))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_occupancy_is_the_most_rows_held_at_any_beam_code(seed):
    rng = np.random.default_rng(seed)
    window = _window(_scan())
    guard = 17
    az = np.sort(np.concatenate([rng.integers(0, AZIMUTH_CODES, 300),
                                 rng.integers(65400, 65536 + 200, 40) % AZIMUTH_CODES,   # a farm across north
                                 np.full(7, 1234)]))                                    # seven on one bearing
    held = _held_brute(az, window.lo, window.hi, guard)
    need = follow_occupancy(az, window, guard)
    assert need.channels == held.max()
    span = (need.beam_code + np.arange((need.last_code - need.beam_code) % AZIMUTH_CODES + 1)) % AZIMUTH_CODES
    assert np.all(held[span] == held.max())
    assert held[(need.beam_code - 1) % AZIMUTH_CODES] < held.max()
    assert held[(need.last_code + 1) % AZIMUTH_CODES] < held.max()


def test_a_scene_needing_more_channels_than_the_build_is_refused_with_azimuth_and_count():
    window = _window(_scan())
    az = np.array([100, 16384, 16390, 16400, 16420, 30000])       # four near east
    assert check_follow(az, window, 3, channels=4).channels == 4
    with pytest.raises(ValueError, match=r"4 turbines are within the beam's window at once with the beam from "
                                         r"87\.97 to 92\.21 deg .* more than the build's 3 channels"):
        check_follow(az, window, 3, channels=3)


@pytest.mark.parametrize("step", [1, 16])
def test_the_assignment_follows_the_closed_form_and_never_takes_a_channel_twice(step):
    rng = np.random.default_rng(step)
    scan = _scan(mode="free" if step == 1 else "acp")
    window = _window(scan)
    contract = ReplayContract(channels=64, slots=8, sample_rate_hz=20_000_000)
    guard = follow_guard_codes(scan, contract, 64)
    # 64 loads of 21 steps and a refill of 157 at 20 MS/s, 12.5 rpm: 1.07 codes
    loads = 64 * follow_load_steps(8) + contract.refill_samples
    assert guard == step + math.ceil(loads * 12.5 / 60 * AZIMUTH_CODES / 20e6) + 1 == step + 3
    az = np.sort(np.concatenate([rng.integers(0, AZIMUTH_CODES, 400), np.full(5, 65530), np.full(5, 3)]))
    channels = follow_occupancy(az, window, guard).channels
    follower = Follower(az, window, guard, channels)
    owner = {}                                      # channel -> row
    beam = 40000
    beams = [beam]
    for ev in follower.start(beam):
        assert ev.kind == "enter" and ev.channel not in owner and not ev.late
        owner[ev.channel] = ev.row
    assert set(owner.values()) == _held_rows(az, window.lo, window.hi, guard, beam)
    for _ in range(AZIMUTH_CODES // step + 500):     # more than a revolution
        beam = (beam + step) % AZIMUTH_CODES
        for ev in follower.move(beam):
            if ev.kind == "leave":
                assert owner.pop(ev.channel) == ev.row
            else:
                assert ev.channel not in owner and not ev.late
                owner[ev.channel] = ev.row
        beams.append(beam)
        assert set(owner.values()) == _held_rows(az, window.lo, window.hi, guard, beam)
    assert follower.entered > az.size           # every row entered, some twice


def test_an_entry_the_beam_has_passed_by_the_guard_is_late():
    window = _window(_scan())
    az = np.array([10000, 20000])
    follower = Follower(az, window, 3, 2)
    follower.start(0)
    entry = (10000 + window.lo - 3) % AZIMUTH_CODES
    events = follower.move(entry + 2)               # two codes past: inside the guard
    assert [(e.kind, e.row, e.late) for e in events] == [("enter", 0, False)]
    events = follower.move((20000 + window.lo - 3 + 3) % AZIMUTH_CODES)     # the guard's width past
    assert [(e.kind, e.row, e.late) for e in events] == [("leave", 0, False), ("enter", 1, True)]


def test_rows_must_be_sorted():
    with pytest.raises(ValueError, match="sorted by azimuth"):
        Follower([5, 3], _window(_scan()), 3, 2)


def test_the_table_words_hold_every_field():
    rows = [FollowRow(65535, (1 << 17) - 1, 65535, (1 << 23) - 1, (1 << 24) - 1, (1 << 32) - 1),
            FollowRow(1, 2, 3, 4, 5, 6), FollowRow(40000, 65536, 1000, 123456, 8192, 0x12345678)]
    words = pack_rows(rows)
    assert words.dtype == np.uint32 and words.size == 12
    assert unpack_rows(words) == rows
    assert int(words[4]) == 1 | (2 << 16)           # row 1, word 0: azimuth, then the gain from bit 16
    with pytest.raises(ValueError, match="row 0: delay 65536 does not fit its 16 bits"):
        pack_rows([FollowRow(0, 0, 65536, 0, 8, 0)])


def test_a_rows_phase_is_a_channels_that_played_from_the_start():
    length, inc = 1237, 0x9E3779B9
    steps = 5000
    played = phase_sequence(0, inc, length, steps)
    for n in (0, 1, 777, 4999):
        assert follow_phase(n, inc, length) == int(played[n])


@pytest.mark.parametrize("step", [1, 5])
def test_at_one_code_a_row_leaves_before_the_next_enters(step):
    window = _window(_scan())
    guard = 3
    width = window.hi + 1 - window.lo + guard
    az = np.array([10000, 10000 + width])          # the second's entry code is the first's exit code
    assert follow_occupancy(az, window, guard).channels == 1
    follower = Follower(az, window, guard, 1)
    follower.start(0)
    exit_code = (10000 + window.hi + 1) % AZIMUTH_CODES
    beam = exit_code - 100
    follower.move(beam)
    events = []
    while beam < exit_code + 10:
        beam += step
        events += follower.move(beam)
    assert [(e.kind, e.row, e.channel) for e in events] == [("leave", 0, 0), ("enter", 1, 0)]


def test_the_loads_lead_fits_the_named_steps_bits_at_every_m():
    """A load names its switch's step by 8 bits: its lead (the phase's
    product or the first writes, the last writes, the staging) must stay
    under 256 steps at every M, and cover the clocks it counts."""
    from rast.model.contract.fixedpoint import REGISTER_STAGING, take_interval
    from rast.model.contract.follow import LOAD_WRITES_AFTER, LOAD_WRITES_BEFORE, PHASE_CLOCKS
    from rast.model.contract.regmap import FOLLOW_SWITCH_STEP_BITS
    for m in range(1, 65):
        lead = follow_lead_steps(m)
        ti = take_interval(m)
        assert lead * m >= max(PHASE_CLOCKS, LOAD_WRITES_BEFORE * ti) + LOAD_WRITES_AFTER * ti + REGISTER_STAGING
        assert lead < 1 << FOLLOW_SWITCH_STEP_BITS - 1
