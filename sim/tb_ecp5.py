"""cocotb unit tests of the ECP5 primitive models (``sim/ecp5/``) on hand-worked cases.

The top is ``ecp5_models_tb`` (``sim/ecp5/models_tb.v``). Every expected value
below is worked out by hand from the primitive's documented behaviour (the
readings in docs/netlist_sim.md), never read back from the model.
"""

from __future__ import annotations

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge, RisingEdge

MASK18 = (1 << 18) - 1
MASK36 = (1 << 36) - 1


async def _start(dut):
    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    await FallingEdge(dut.clk)


def _idle(ram):
    for p in "ab":
        for s in ("di", "ad", "ce", "oce", "we", "rst", "cs"):
            getattr(ram, f"{s}{p}").value = 0


async def _edge(dut, n=1):
    """``n`` rising edges, then settle at the falling edge (inputs change there)."""
    for _ in range(n):
        await RisingEdge(dut.clk)
    await FallingEdge(dut.clk)


@cocotb.test()
async def dp16kd_x18_outreg(dut):
    """x18, port A writes, port B reads through its output register (latency 2)."""
    r = dut.x18_outreg
    _idle(r)
    await _start(dut)
    # word 5 <- 0x2ABCD (both bytes), word 6 <- 0x12345 with only byte 0 enabled (AD[0])
    r.cea.value, r.wea.value = 1, 1
    r.ada.value, r.dia.value = (5 << 4) | 0b11, 0x2ABCD
    await _edge(dut)
    r.ada.value, r.dia.value = (6 << 4) | 0b01, 0x12345
    await _edge(dut)
    r.cea.value, r.wea.value = 0, 0
    # read word 5: edge 1 loads the read latch, edge 2 the output register
    r.ceb.value, r.oceb.value, r.adb.value = 1, 1, 5 << 4
    await _edge(dut)
    assert r.dob.value.to_unsigned() == 0, "OUTREG: data appeared after one edge"
    r.adb.value = 6 << 4
    await _edge(dut)
    assert r.dob.value.to_unsigned() == 0x2ABCD
    await _edge(dut)
    assert r.dob.value.to_unsigned() == 0x12345 & 0x1FF, "byte enable AD[0] only: bits 17:9 stay 0"
    # OCE low holds the output register while the latch moves on
    r.oceb.value, r.adb.value = 0, 5 << 4
    await _edge(dut, 2)
    assert r.dob.value.to_unsigned() == 0x145
    # synchronous reset with OCE low: gated, the register keeps its value
    r.ceb.value, r.rstb.value = 0, 1
    await _edge(dut)
    assert r.dob.value.to_unsigned() == 0x145, "RST with OCE low must not clear (gated reading)"
    # ... with OCE high it clears (and the reset wins over the load)
    r.oceb.value = 1
    await _edge(dut)
    assert r.dob.value.to_unsigned() == 0
    r.rstb.value = 0
    await _edge(dut)
    assert r.dob.value.to_unsigned() == 0x2ABCD, "the latch (word 5) moves to DO once reset is released"


@cocotb.test()
async def dp16kd_cross_port_collision(dut):
    """Reading the word the other port writes at the same edge: not the old word, not the new."""
    r = dut.x18_outreg
    _idle(r)
    await _start(dut)
    r.cea.value, r.wea.value, r.ada.value, r.dia.value = 1, 1, (9 << 4) | 0b11, 0x00F0F
    await _edge(dut)
    r.dia.value = 0x3C3C3                       # overwrite word 9 while port B reads it
    r.ceb.value, r.oceb.value, r.adb.value = 1, 1, 9 << 4
    await _edge(dut)
    r.cea.value, r.wea.value = 0, 0
    await _edge(dut)
    got = r.dob.value
    if got.is_resolvable:
        assert got.to_unsigned() not in (0x00F0F, 0x3C3C3), f"collision read returned {got.to_unsigned():#x}"
        assert got.to_unsigned() == ~0x00F0F & MASK18, "Verilator: the old word inverted"
    # the write itself took place
    await _edge(dut)
    assert r.dob.value.to_unsigned() == 0x3C3C3


@cocotb.test()
async def dp16kd_x2_chip_select(dut):
    """x2 (word = AD[13:1]), NOREG (latency 1), port B selected only by CS = 0b101."""
    r = dut.x2_cs
    _idle(r)
    await _start(dut)
    r.cea.value, r.wea.value = 1, 1
    for word, data in ((0, 0b10), (1, 0b01), (8191, 0b11)):
        r.ada.value, r.dia.value = (word << 1) | 1, data       # AD[0] is below the word: ignored
        await _edge(dut)
    r.cea.value, r.wea.value = 0, 0
    r.ceb.value, r.csb.value, r.adb.value = 1, 0b101, 1 << 1
    await _edge(dut)
    assert r.dob.value.to_unsigned() == 0b01
    r.adb.value = 8191 << 1
    await _edge(dut)
    assert r.dob.value.to_unsigned() == 0b11
    r.csb.value, r.adb.value = 0b000, 0              # deselected: DO holds
    await _edge(dut)
    assert r.dob.value.to_unsigned() == 0b11
    r.csb.value = 0b101
    await _edge(dut)
    assert r.dob.value.to_unsigned() == 0b10


@cocotb.test()
async def dp16kd_initval_writethrough(dut):
    """x18 power-up contents from INITVAL (20-bit slots, 18 bits used), WRITETHROUGH on port A."""
    r = dut.x18_init
    _idle(r)
    await _start(dut)
    r.cea.value = 1
    expect = {0: 0x00001, 1: 0x3FFFF, 2: 0, 16: 0, 17: 0x12345}
    for word, value in expect.items():
        r.ada.value = word << 4
        await _edge(dut)
        assert r.doa.value.to_unsigned() == value, f"word {word}"
    r.wea.value, r.ada.value, r.dia.value = 1, (2 << 4) | 0b11, 0x0ABCD
    await _edge(dut)
    assert r.doa.value.to_unsigned() == 0x0ABCD, "WRITETHROUGH shows the written word at once"


def _s18(x):
    return x & MASK18


@cocotb.test()
async def mult_signed_registered(dut):
    """Input and output registers on CLK0 (latency 2), CE0 holds, RST0 gated by CE0."""
    m = dut.mult_regs
    await _start(dut)
    m.ce.value, m.rst.value, m.signeda.value, m.signedb.value = 1, 0, 1, 1
    m.a.value, m.b.value = _s18(-3), 5
    await _edge(dut)
    assert m.p.value.to_unsigned() == 0, "output register: nothing after one edge"
    m.a.value, m.b.value = _s18(-131072), _s18(-131072)     # most negative squared
    await _edge(dut)
    assert m.p.value.to_unsigned() == -15 & MASK36
    await _edge(dut)
    assert m.p.value.to_unsigned() == 1 << 34
    m.ce.value = 0
    m.a.value, m.b.value = 7, 7
    await _edge(dut, 2)
    assert m.p.value.to_unsigned() == 1 << 34, "CE0 low holds both register stages"
    m.rst.value = 1
    await _edge(dut)
    assert m.p.value.to_unsigned() == 1 << 34, "RST0 with CE0 low must not clear (gated reading)"
    m.ce.value = 1
    await _edge(dut)
    assert m.p.value.to_unsigned() == 0


@cocotb.test()
async def mult_sign_modes(dut):
    """No registers: unsigned x unsigned, signed x unsigned."""
    m = dut.mult_comb
    await _start(dut)
    for sa, sb, a, b, want in ((0, 0, 0x3FFFF, 2, 0x7FFFE),
                               (1, 0, 0x3FFFF, 0x3FFFF, -0x3FFFF & MASK36),
                               (0, 1, 0x3FFFF, 0x3FFFF, -0x3FFFF & MASK36),
                               (1, 1, 0x3FFFF, 0x3FFFF, 1)):
        m.signeda.value, m.signedb.value, m.a.value, m.b.value = sa, sb, a, b
        await _edge(dut)
        assert m.p.value.to_unsigned() == want, f"SIGNEDA={sa} SIGNEDB={sb} {a:#x}*{b:#x}"


@cocotb.test()
async def unmodelled_mode(dut):
    """Runs on a top with an unmodelled mode: the model must have stopped before this."""
    await ClockCycles(dut.clk, 1)
