"""cocotb testbench of a replay block whose channels follow the beam: a
scene (``rast.sim.follow_drive``) loaded through the bus, then input samples
for a whole revolution of the free-running beam and more, every output
sample compared with the model of one channel per turbine.

Parameters (``RAST_TB_PARAMS``): ``contract`` (ReplayContract keywords),
``scan`` (AntennaScan keywords), ``azimuths`` (codes, sorted), ``steps``
after the load, ``seed``, ``write_staging``. Writes ``follow.json`` (the
scene's start, the status read at the end, the samples lit) to the run
directory.
"""

from __future__ import annotations

import json

import cocotb
import numpy as np

from rast.model.contract.fixedpoint import ReplayContract
from rast.model.contract.regmap import register_map
from rast.model.physics.antenna import AntennaScan
from rast.sim.block_drive import drive_block
from rast.sim.follow_drive import follow_reference, follow_scene, scene_start
from rast.sim.testbench import Scoreboard, params, run_dir


@cocotb.test()
async def follow(dut):
    p = params()
    contract = ReplayContract(**p["contract"])
    rmap = register_map(contract)
    rng = np.random.default_rng(p["seed"])
    scene = follow_scene(rng, contract, AntennaScan(**p["scan"]), p["azimuths"])
    load_steps = len(scene["ops"]) * 8
    T = load_steps + p["steps"]
    ops = sorted(scene["ops"] + [(T - 5, "r", rmap.addr("STATUS"), 0)], key=lambda o: o[0])
    xi, xq = rng.integers(-32768, 32768, T), rng.integers(-32768, 32768, T)

    out_i, out_q, done, _ = await drive_block(dut, xi, xq, ops, slots=contract.slots,
                                              write_staging=p["write_staging"], pins={})
    done = [tuple(d) for d in done]
    mi, mq = follow_reference(contract, scene["rows"], done, xi, xq)
    Scoreboard("follow").check({"I": (np.array(out_i), mi), "Q": (np.array(out_q), mq)})
    k0 = scene_start(contract, done)
    status = next(v for k, kind, addr, v in done if kind == "r" and addr == rmap.addr("STATUS"))
    table_crc = next(v for k, kind, addr, v in done if kind == "r" and addr == rmap.addr("TABLE_CRC"))
    (run_dir() / "follow.json").write_text(json.dumps({
        "start_step": k0, "steps": T, "status": status, "table_crc": table_crc,
        "start_code": scene["start_code"], "window": [scene["window"].lo, scene["window"].hi],
        "guard": scene["guard"], "lit": int(np.count_nonzero((mi[k0:] != 0) | (mq[k0:] != 0)))}))
