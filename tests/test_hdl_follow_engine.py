"""Channels that follow the beam inside the engine (WindFarmReplay built with
``follow_rows``) in the Amaranth simulator: four channels handed to ten
turbines as a free-running beam sweeps them, bit-exact with the model of one
channel per turbine (each playing its stream from the scene's start, the
pattern 0 outside the window), sample for sample over the whole sweep."""

import dataclasses

import numpy as np
import pytest

from rast.hdl.replay_top import WindFarmReplay
from rast.model.contract.follow import (FollowRow, follow_guard_codes, follow_occupancy, follow_pattern,
                                        follow_phase, pack_rows)
from rast.model.contract.fixedpoint import PHASE_FRAC_BITS, ReplayContract, pack_iq
from rast.model.contract.regmap import CTRL_ENABLE, SCAN_RESTART, register_map, stream_crc32
from rast.model.contract.scan import AZIMUTH_CODES, PATTERN_ENTRIES, pattern_words
from rast.model.physics.antenna import AntennaScan

from hdl_harness import run_replay, model_replay, assert_same

RATE = 20_000_000
#: A revolution of 2**16 samples: the beam one code a step.
SCAN = AntennaScan("free", RATE * 60 / AZIMUTH_CODES, 0.0, 4096, 0.35, -70.0, None, -60.0)


def _scene(rng, n, first, spacing, interpolation, max_inc):
    """Rows at ``first + spacing·j`` and two close together between the
    third and the fourth, each a random stream, gain and tap."""
    az = [first + spacing * j for j in range(n - 2)] + [first + spacing * 2 + spacing // 2 + d for d in (20, 45)]
    rows, streams = [], []
    for a in sorted(az):
        length = int(rng.integers(6, 11)) if interpolation != "fir" else int(rng.integers(40, 60))
        words = pack_iq(rng.integers(-20000, 20000, length), rng.integers(-20000, 20000, length))
        streams.append([int(w) for w in words])
        rows.append(dict(azimuth=int(a), gain=int(rng.integers(1 << 15, 1 << 16)), delay=int(rng.integers(0, 6)),
                         length=length, phase_increment=int(rng.integers(max_inc // 4, max_inc + 1))))
    return rows, streams


@pytest.mark.slow
@pytest.mark.parametrize("interpolation, slots", [("hold", 2), ("linear", 1), ("fir", 4)])
def test_following_channels_play_what_one_channel_per_turbine_plays(interpolation, slots):
    rng = np.random.default_rng(slots)
    C, n = 4, 10
    dut = WindFarmReplay(C, slots=slots, pool_words=1024, max_delay=20, max_tap=6, interpolation=interpolation,
                         sample_rate_hz=RATE, scan=True, start_frac=True, follow_rows=16)
    c, rmap = dut.contract, dut.register_map
    table = pattern_words(SCAN)
    window = follow_pattern(SCAN, table)
    guard = follow_guard_codes(SCAN, c, C)
    width = window.hi + 1 - window.lo + guard
    ref = ReplayContract(channels=n, slots=slots, pool_words=1024, max_delay=20, max_tap=6,
                         interpolation=interpolation, sample_rate_hz=RATE, scan=True, start_frac=True)
    # (increments both blocks take: the model's n channels are more pipelines, a lower limit)
    rows, streams = _scene(rng, n, 20000, width // 2 + 1, interpolation,
                           min(c.max_phase_increment, ref.max_phase_increment))
    assert follow_occupancy([r["azimuth"] for r in rows], window, guard).channels == C
    # the streams rolled: twice the period but one word, from each region's base
    ops, base, bases = [], 0, []
    for words in streams:
        rolled = words + words[:-1]
        ops += [(0, "w", rmap.addr("STREAM_ADDR"), base)] + [(0, "w", rmap.addr("STREAM_DATA"), w) for w in rolled]
        bases.append(base)
        base += len(rolled)
    table_rows = [FollowRow(r["azimuth"], r["gain"], r["delay"], b, r["length"], r["phase_increment"])
                  for r, b in zip(rows, bases)]
    words = pack_rows(table_rows)
    ops += [(0, "w", rmap.addr("TABLE_ADDR"), 0)] + [(0, "w", rmap.addr("TABLE_DATA"), int(w)) for w in words]
    ops += [(0, "r", rmap.addr("TABLE_CRC"), 0)]
    kept = np.flatnonzero(window.table.words)
    ops += [(0, "w", rmap.addr("PATTERN"), 0), (0, "w", rmap.addr("PATTERN_ADDR"), int(kept[0]))]
    ops += [(0, "w", rmap.addr("PATTERN_DATA"), int(w)) for w in window.table.words[kept[0]:kept[-1] + 1]]
    start_code = (rows[0]["azimuth"] + window.lo - guard - 60) % AZIMUTH_CODES
    ops += [(0, "w", rmap.addr("SCAN_PERIOD"), AZIMUTH_CODES), (0, "w", rmap.addr("SCAN_START"), start_code),
            (0, "w", rmap.addr("FOLLOW_WINDOW"), (window.lo - guard) % AZIMUTH_CODES
             | ((window.hi + 1) % AZIMUTH_CODES) << 16),
            (0, "w", rmap.addr("FOLLOW_SPAN"), width | guard << 16)]
    ops += [(0, "w", rmap.addr("CTRL", l), CTRL_ENABLE) for l in range(C)]     # the channels the beam hands out
    per_access = -(-8 // slots) if slots < 8 else 1
    k0 = (len(ops) + 10) * per_access + 20           # the setup has landed
    ops += [(k0 - 10, "w", rmap.addr("SCAN_CTRL"), 1 | SCAN_RESTART),
            (k0, "w", rmap.addr("FOLLOW_CTRL"), 1 | n << 4 | 1 << 31)]
    sweep = rows[-1]["azimuth"] + window.hi + 1 - start_code + 80
    T = k0 + sweep
    ops += [(T - 5, "r", rmap.addr("STATUS"), 0), (T - 5, "r", rmap.addr("FOLLOW_CTRL"), 0)]
    xi, xq = rng.integers(-32768, 32768, T), rng.integers(-32768, 32768, T)
    hi, hq, done = run_replay(dut, xi, xq, ops, hold=True)
    assert [d for d in done if d[0] == k0 and d[2] == rmap.addr("FOLLOW_CTRL")], "the start did not land at k0"
    reads = {d[2]: d[3] for d in done if d[1] == "r"}
    assert reads[rmap.addr("TABLE_CRC")] == stream_crc32(words)
    status = rmap.reg("STATUS")
    for flag in ("late", "overrun"):
        assert not reads[status.addr] >> status.field(flag).lsb & 1, f"STATUS.{flag} is set"

    # the model with one channel per turbine: the same scan, every turbine
    # switched in at the scene's start (step k0) at the phase it has when its
    # refill is over, as if it had played from k0
    rref = register_map(ref)
    shared = [d for d in done if d[1] == "w" and rmap.by_addr(d[2]).channel is None
              and rref.by_addr(d[2]) is not None and not rmap.by_addr(d[2]).name.startswith(("FOLLOW", "TABLE"))]
    loads = []
    for l, (r, b) in enumerate(zip(rows, bases)):
        phase = follow_phase(ref.refill_samples, r["phase_increment"], r["length"])
        for name, value in (("AZIMUTH", r["azimuth"]), ("GAIN", r["gain"]), ("DELAY", r["delay"]),
                            ("LENGTH", r["length"]), ("PHASE_INC", r["phase_increment"]),
                            ("BASE", b + (phase >> PHASE_FRAC_BITS)), ("START", phase & 0xFFFFFFFF)):
            loads.append((k0, "w", rref.addr(name, l), value))
        loads.append((k0, "w", rref.addr("FOLLOW_SWITCH"), l | (k0 & 0xFF) << 16))
        loads.append((k0, "w", rref.addr("CTRL", l), CTRL_ENABLE))
    loads.append((k0, "w", rref.addr("APPLY"), 1))
    ops_ref = sorted(shared + loads, key=lambda d: d[0])
    mi, mq, _, _ = model_replay(ref, [], xi, xq, ops_ref)
    assert_same(f"follow {interpolation} M={slots}", xi, xq, hi, hq, mi, mq)
    # every turbine was lit for most of its window (edges round to 0)
    assert np.count_nonzero(hi[k0:]) > n * (window.hi - window.lo) // 2, "the sweep lit too little"
