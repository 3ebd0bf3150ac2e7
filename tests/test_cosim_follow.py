"""Channels that follow the beam in the replay block's Verilog under cocotb
(Verilator): a scene loaded through the bus, then a whole revolution of the
free-running beam and more (the first turbines taken again on the second
pass, by other channels), every output sample equal to the model of one
channel per turbine (``rast.sim.tb_follow``)."""

import json

import numpy as np
import pytest

from rast.gateware.verilog import verilog_text
from rast.model.contract.fixedpoint import ReplayContract, WRITE_STAGING
from rast.model.contract.follow import follow_guard_codes, follow_occupancy, follow_pattern
from rast.model.contract.regmap import stream_crc32
from rast.model.contract.scan import AZIMUTH_CODES, pattern_words
from rast.model.physics.antenna import AntennaScan
from rast.sim.follow_drive import follow_scene
from rast.sim.pytest_support import cocotb_run

#: Cosimulations: left out of `make test-fast`, run by `make test` and CI.
pytestmark = pytest.mark.slow

RATE = 20_000_000
KW = dict(channels=4, slots=2, pool_words=1024, max_delay=20, max_tap=6, interpolation="hold",
          sample_rate_hz=RATE, scan=True, start_frac=True, follow_rows=16)
SCAN = dict(mode="free", rpm=RATE * 60 / AZIMUTH_CODES, start_deg=0.0, acp_per_rev=4096, beamwidth_deg=0.35,
            sidelobe_db=-70.0, pattern=None, assign_below_db=-60.0)


def test_a_revolution_of_following_channels_is_bit_exact_in_verilator():
    c = ReplayContract(**KW)
    rng = np.random.default_rng(21)
    # twelve turbines all round (each a few degrees from the fixed bearings), a farm of four close together
    azimuths = sorted([b + int(rng.integers(-1500, 1500)) for b in (2000, 9000, 17000, 24000, 38000, 45000,
                                                                    52000, 60000)] + [30000 + 90 * k for k in range(4)])
    scan = AntennaScan(**SCAN)
    window = follow_pattern(scan, pattern_words(scan))
    guard = follow_guard_codes(scan, c, c.channels)
    assert follow_occupancy(azimuths, window, guard).channels <= c.channels
    steps = AZIMUTH_CODES + 2000                           # past north and the first turbines again
    verilog = verilog_text(KW["channels"], **{k: v for k, v in KW.items() if k != "channels"}, name="follow_top")
    run = cocotb_run({"follow_top.v": verilog}, "follow_top", "rast.sim.tb_follow", "follow",
                     simulator="verilator", name="follow-revolution", label="follow_top",
                     tb_params=dict(contract={k: v for k, v in KW.items()}, scan=SCAN, azimuths=azimuths,
                                    steps=steps, seed=21, write_staging=WRITE_STAGING))
    rep = json.loads((run / "follow.json").read_text())
    scene = follow_scene(np.random.default_rng(21), c, scan, azimuths)
    assert rep["table_crc"] == stream_crc32(scene["table"])
    assert rep["status"] >> 3 & 3 == 0, "STATUS.late or .overrun"
    # lit: every turbine for most of its window, one revolution at least
    assert rep["lit"] > len(azimuths) * (window.hi - window.lo) // 2
