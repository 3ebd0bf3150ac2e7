"""cocotb testbench of the replay block built with the antenna scan: the
radar's ACP and ARP pins driven clock by clock (jitter, glitches shorter
than the input filter, a missing ARP) beside the input samples and the
register accesses, every output sample compared with the bit-exact model fed
the same accesses and the pulses the filter passes (``rast.sim.scan_drive``).

Parameters (``RAST_TB_PARAMS``): ``contract`` (ReplayContract keywords),
``inits`` (ChannelInit keywords per channel), ``steps``, ``seed``, ``ops``
(``[step, "w"|"r", addr, value]``), ``pulses`` (``[pin, clock, high]``),
``acp_lead``, ``filter_clocks``, ``write_staging``. Writes ``scan.json``
(reads, events, the learned count) to the run directory.
"""

from __future__ import annotations

import json

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge, ReadOnly

from rast.model.contract.fixedpoint import ReplayContract
from rast.model.contract.powerup import ChannelInit
from rast.sim.scan_drive import merge, model_replay, pin_levels, pulse_events
from rast.sim.testbench import Scoreboard, params, run_dir


def _signed16(v: int) -> int:
    return v - (1 << 16) if v & 0x8000 else v


@cocotb.test()
async def scan(dut):
    p = params()
    contract = ReplayContract(**p["contract"])
    inits = [ChannelInit(**{**ini, "words": tuple(ini["words"])}) for ini in p["inits"]]
    rng = np.random.default_rng(p["seed"])
    T = p["steps"]
    xi, xq = rng.integers(-32768, 32768, T), rng.integers(-32768, 32768, T)
    ops = sorted((tuple(o) for o in p["ops"]), key=lambda o: o[0])
    high = pin_levels(p["pulses"])

    Clock(dut.clk, 10, unit="ns").start()
    dut.rst.value = 1
    for name in ("i__valid", "bus__w_stb", "bus__r_stb", "acp", "arp"):
        getattr(dut, name).value = 0
    dut.o__ready.value = 1
    await ClockCycles(dut.clk, 3)
    await FallingEdge(dut.clk)
    dut.rst.value = 0
    await FallingEdge(dut.clk)

    out_i, out_q, done, accepted_at = [], [], [], []
    reads, landing = [], []
    n_in = op_i = 0
    limit = (T + len(ops)) * 16 * contract.slots + 4000 + max((c for _, c, _ in p["pulses"]), default=0)
    for cycle in range(limit):
        if n_in >= T and len(out_i) >= T and op_i >= len(ops) and not reads and not landing:
            break
        due = op_i < len(ops) and ops[op_i][0] <= n_in
        dut.i__valid.value = int(n_in < T)
        if n_in < T:
            dut.i__payload.value = (int(xi[n_in]) & 0xFFFF) | (int(xq[n_in]) & 0xFFFF) << 16
        levels = high.get(cycle, ())
        dut.acp.value = int("acp" in levels)
        dut.arp.value = int("arp" in levels)
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
            accepted_at.append(cycle)
    else:
        raise AssertionError(f"not finished after {limit} cycles ({n_in}/{T} in, {len(out_i)} out)")

    events = pulse_events(p["pulses"], accepted_at, p["acp_lead"], p["filter_clocks"])
    done = merge([tuple(d) for d in done], events)
    mi, mq, model_reads, model = model_replay(contract, inits, xi, xq, done)
    sb = Scoreboard("scan")
    sb.check({"I": (np.array(out_i), mi), "Q": (np.array(out_q), mq)})
    for k, addr, want, got in model_reads:
        if want != got:
            sb._fail(f"read of register {addr:#x} at step {k}: RTL {got:#x}, model {want:#x}")
    (run_dir() / "scan.json").write_text(json.dumps({
        "events": len(events), "reads": [[k, addr, got] for k, addr, _, got in model_reads],
        "per_rev": model.beam.per_rev, "steps": T,
        "nonzero": int(np.count_nonzero((mi != 0) | (mq != 0)))}))
