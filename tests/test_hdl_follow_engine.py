"""Channels that follow the beam inside the engine (WindFarmReplay built with
``follow_rows``) in the Amaranth simulator: four channels handed to ten
turbines as a free-running beam sweeps them, bit-exact with the model of one
channel per turbine (each playing its stream from the scene's start, the
pattern 0 outside the window), sample for sample over the whole sweep
(``rast.sim.follow_drive``; the revolution in Verilator:
``tests/test_cosim_follow.py``)."""

import numpy as np
import pytest

from rast.hdl.replay_top import WindFarmReplay
from rast.model.contract.follow import follow_guard_codes, follow_occupancy, follow_pattern
from rast.model.contract.regmap import stream_crc32
from rast.model.contract.scan import AZIMUTH_CODES, pattern_words
from rast.model.physics.antenna import AntennaScan
from rast.sim.follow_drive import follow_reference, follow_scene, scene_start

from hdl_harness import run_replay, assert_same

RATE = 20_000_000
#: A revolution of 2**16 samples: the beam one code a step; a 0.35-degree beam.
SCAN = AntennaScan("free", RATE * 60 / AZIMUTH_CODES, 0.0, 4096, 0.35, -70.0, None, -60.0)


def sector(contract, n, first=20000):
    """``n`` turbines one half-window apart (at most two at once) and two more
    close together between the third and the fourth: four at once."""
    window = follow_pattern(SCAN, pattern_words(SCAN))
    width = window.hi + 1 - window.lo + follow_guard_codes(SCAN, contract, contract.channels)
    s = width // 2 + 1
    return sorted([first + s * j for j in range(n - 2)] + [first + 2 * s + s // 2 + d for d in (20, 45)])


@pytest.mark.slow
@pytest.mark.parametrize("interpolation, slots", [("linear", 1), ("fir", 4)])     # (hold at M = 2: the cosim's)
def test_following_channels_play_what_one_channel_per_turbine_plays(interpolation, slots):
    rng = np.random.default_rng(slots)
    C, n = 4, 10
    dut = WindFarmReplay(C, slots=slots, pool_words=1024, max_delay=20, max_tap=6, interpolation=interpolation,
                         sample_rate_hz=RATE, scan=True, start_frac=True, follow_rows=16)
    c, rmap = dut.contract, dut.register_map
    azimuths = sector(c, n)
    scene = follow_scene(rng, c, SCAN, azimuths, stream_words=(16, 28) if interpolation == "fir" else (6, 11))
    assert follow_occupancy(azimuths, scene["window"], scene["guard"]).channels == C
    # the sweep: from the beam's start past the last turbine's window
    T0 = (len(scene["ops"]) + 10) * -(-8 // slots) + 20
    T = T0 + (azimuths[-1] + scene["window"].hi + 1 - scene["start_code"]) % AZIMUTH_CODES + 80
    ops = scene["ops"] + [(T - 5, "r", rmap.addr("STATUS"), 0)]
    xi, xq = rng.integers(-32768, 32768, T), rng.integers(-32768, 32768, T)
    hi, hq, done = run_replay(dut, xi, xq, ops)
    k0 = scene_start(c, done)
    reads = {d[2]: d[3] for d in done if d[1] == "r"}
    assert reads[rmap.addr("TABLE_CRC")] == stream_crc32(scene["table"])
    status = rmap.reg("STATUS")
    for flag in ("late", "overrun"):
        assert not reads[status.addr] >> status.field(flag).lsb & 1, f"STATUS.{flag} is set"
    mi, mq = follow_reference(c, scene["rows"], done, xi, xq)
    assert_same(f"follow {interpolation} M={slots}", xi, xq, hi, hq, mi, mq)
    # every turbine was lit for most of its window (edges round to 0)
    w = scene["window"]
    assert np.count_nonzero(hi[k0:]) > n * (w.hi - w.lo) // 2, "the sweep lit too little"
