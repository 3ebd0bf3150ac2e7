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

from rast.model.contract.fixedpoint import ReplayContract
from rast.model.contract.powerup import ChannelInit
from rast.sim.block_drive import drive_block
from rast.sim.scan_drive import merge, model_replay, pin_levels, pulse_events
from rast.sim.testbench import Scoreboard, params, run_dir


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

    out_i, out_q, done, accepted_at = await drive_block(
        dut, xi, xq, ops, slots=contract.slots, write_staging=p["write_staging"], pins=high,
        last_pin_clock=max((c for _, c, _ in p["pulses"]), default=0))

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
