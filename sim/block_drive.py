"""Driving the replay block's Verilog under cocotb clock by clock: input
samples, register accesses (each presented once its step is reached, taken
when the bus is ready, landing ``write_staging`` clocks later) and the radar's
pins, every output sample recorded. Shared by the cocotb benches of the
antenna scan (``rast.sim.tb_scan``) and of channels that follow the beam
(``rast.sim.tb_follow``); the Amaranth simulator's twin is
``tests/hdl_harness.run_replay``."""

from __future__ import annotations

from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge, ReadOnly

__all__ = ["drive_block"]


def _signed16(v: int) -> int:
    return v - (1 << 16) if v & 0x8000 else v


async def drive_block(dut, xi, xq, ops, *, slots: int, write_staging: int, pins=None, last_pin_clock: int = 0):
    """Reset ``dut``, then drive it until every input is in, every output
    out and every access done. ``ops``: ``(step, "w"|"r", addr, value)``
    sorted by step; ``pins``: clock -> the pins ("acp", "arp") high then (a
    block with the scan's pins; None: none driven). Returns ``(out_i, out_q,
    done, accepted_at)``: ``done`` as ``[k, kind, addr, value or read-back]``
    with ``k`` the inputs accepted before the access landed, ``accepted_at``
    each input's clock."""
    T = len(xi)
    Clock(dut.clk, 10, unit="ns").start()
    dut.rst.value = 1
    for name in ("i__valid", "bus__w_stb", "bus__r_stb") + (("acp", "arp") if pins is not None else ()):
        getattr(dut, name).value = 0
    dut.o__ready.value = 1
    await ClockCycles(dut.clk, 3)
    await FallingEdge(dut.clk)
    dut.rst.value = 0
    await FallingEdge(dut.clk)

    out_i, out_q, done, accepted_at, reads, landing = [], [], [], [], [], []
    n_in = op_i = 0
    for cycle in range((T + len(ops)) * 16 * slots + 4000 + last_pin_clock):
        if n_in >= T and len(out_i) >= T and op_i >= len(ops) and not reads and not landing:
            break
        due = op_i < len(ops) and ops[op_i][0] <= n_in
        dut.i__valid.value = int(n_in < T)
        if n_in < T:
            dut.i__payload.value = (int(xi[n_in]) & 0xFFFF) | (int(xq[n_in]) & 0xFFFF) << 16
        if pins is not None:
            levels = pins.get(cycle, ())
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
            landing.append((cycle + write_staging, len(done)))
            if kind == "r":
                reads.append(len(done))
            done.append([None, kind, addr, value if kind == "w" else None])
        if ce:
            n_in += 1
            accepted_at.append(cycle)
    else:
        raise AssertionError(f"not finished ({n_in}/{T} in, {len(out_i)} out, {op_i}/{len(ops)} accesses)")
    return out_i, out_q, done, accepted_at
