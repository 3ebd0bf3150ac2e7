"""cocotb checks of a RegisteredRAM's ECP5 netlist against its behavioural Verilog, cycle by cycle.

Top: ``ram_lockstep`` (:func:`rast.sim.netlist.ram_lockstep_sources`). Random
writes and reads with random read enables; ``RAST_TB_PARAMS`` chooses

* ``resets``: synchronous resets at random cycles in the middle of the run,
  also while the read stage is not yet primed (the cycles right after a reset);
* ``same_word``: the probability (percent) that a cycle reads the word it writes.

Every cycle, ``r_data`` of the netlist must equal the behavioural one; the
first difference fails the test with the cycle, the inputs and both values.
"""

from __future__ import annotations

import random

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge, RisingEdge

from rast.sim.testbench import params, run_dir


@cocotb.test()
async def lockstep(dut):
    p = params()
    rng = random.Random(p["seed"])
    depth, width, cycles = p["depth"], p["width"], p["cycles"]
    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    dut.rst.value = 1
    for s in (dut.w_en, dut.w_addr, dut.w_data, dut.r_en, dut.r_addr):
        s.value = 0
    await FallingEdge(dut.clk)
    await FallingEdge(dut.clk)
    dut.rst.value = 0
    reset_at = set(rng.sample(range(20, cycles), p["resets"])) if p["resets"] else set()
    resets_seen = unprimed_resets = 0
    since_reset = 0
    history = []
    for n in range(cycles):
        rst = n in reset_at or (n - 1) in reset_at          # two-cycle reset pulses
        w_en = rng.random() < 0.5
        w_addr = rng.randrange(depth)
        r_en = rng.random() < 0.7
        if rng.random() * 100 < p["same_word"]:
            r_addr, w_en, r_en = w_addr, True, True
        else:
            r_addr = rng.randrange(depth)
            if r_addr == w_addr:
                r_addr = (r_addr + 1) % depth
        dut.rst.value, dut.w_en.value, dut.w_addr.value = int(rst), int(w_en), w_addr
        dut.w_data.value = rng.getrandbits(width)
        dut.r_en.value, dut.r_addr.value = int(r_en), r_addr
        if rst:
            resets_seen += 1
            unprimed_resets += since_reset < 3
            since_reset = 0
        else:
            since_reset += 1
        await RisingEdge(dut.clk)
        await FallingEdge(dut.clk)
        rtl, net = dut.r_data_rtl.value, dut.r_data_net.value
        history.append((n, int(rst), int(w_en), w_addr, int(r_en), r_addr))
        if not net.is_resolvable or net.to_unsigned() != rtl.to_unsigned():
            msg = (f"cycle {n}: netlist r_data {net} != behavioural {rtl.to_unsigned():#x}; last inputs "
                   f"(cycle, rst, w_en, w_addr, r_en, r_addr): {history[-6:]}")
            (run_dir() / "failure.txt").write_text(msg + "\n")
            raise AssertionError(msg)
    if p["resets"]:
        assert resets_seen and unprimed_resets, "no reset hit an unprimed read stage: the test proves nothing"
    cocotb.log.info("%d cycles equal, %d reset cycles (%d while not primed)", cycles, resets_seen, unprimed_resets)
