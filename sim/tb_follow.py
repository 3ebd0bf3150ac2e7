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
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge, ReadOnly

from rast.model.contract.fixedpoint import ReplayContract
from rast.model.contract.regmap import register_map
from rast.model.physics.antenna import AntennaScan
from rast.sim.follow_drive import follow_reference, follow_scene, scene_start
from rast.sim.testbench import Scoreboard, params, run_dir


def _signed16(v: int) -> int:
    return v - (1 << 16) if v & 0x8000 else v


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

    Clock(dut.clk, 10, unit="ns").start()
    dut.rst.value = 1
    for name in ("i__valid", "bus__w_stb", "bus__r_stb", "acp", "arp"):
        getattr(dut, name).value = 0
    dut.o__ready.value = 1
    await ClockCycles(dut.clk, 3)
    await FallingEdge(dut.clk)
    dut.rst.value = 0
    await FallingEdge(dut.clk)

    out_i, out_q, done, reads, landing = [], [], [], [], []
    n_in = op_i = 0
    for cycle in range((T + len(ops)) * 16 * contract.slots + 4000):
        if n_in >= T and len(out_i) >= T and op_i >= len(ops) and not reads and not landing:
            break
        due = op_i < len(ops) and ops[op_i][0] <= n_in
        dut.i__valid.value = int(n_in < T)
        if n_in < T:
            dut.i__payload.value = (int(xi[n_in]) & 0xFFFF) | (int(xq[n_in]) & 0xFFFF) << 16
        if due:
            _, kind, addr, value = ops[op_i]
            dut.bus__addr.value = addr
            dut.bus__w_stb.value = int(kind == "w")
            dut.bus__w_data.value = value if kind == "w" else 0
            dut.bus__r_stb.value = int(kind == "r")
        else:
            dut.bus__w_stb.value = 0
            dut.bus__r_stb.value = 0
        await ReadOnly()
        ce = n_in < T and int(dut.i__ready.value)
        taken = due and int(dut.bus__ready.value)
        if int(dut.o__valid.value):
            word = int(dut.o__payload.value)
            out_i.append(_signed16(word & 0xFFFF))
            out_q.append(_signed16(word >> 16))
        if int(dut.bus__r_valid.value):
            done[reads.pop(0)][3] = int(dut.bus__r_data.value)
        while landing and landing[0][0] == cycle:
            done[landing.pop(0)[1]][0] = n_in
        await FallingEdge(dut.clk)
        if taken:
            _, kind, addr, value = ops[op_i]
            op_i += 1
            landing.append((cycle + p["write_staging"], len(done)))
            if kind == "r":
                reads.append(len(done))
            done.append([None, kind, addr, value if kind == "w" else None])
        if ce:
            n_in += 1
    else:
        raise AssertionError(f"not finished ({n_in}/{T} in, {len(out_i)} out)")

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
