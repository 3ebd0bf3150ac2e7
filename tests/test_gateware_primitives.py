"""ECP5 primitive wrappers (rast.hdl.ecp5_primitives).

The behavioural path runs in the Amaranth simulator against a naive Python
model. The ECP5 path is checked structurally (which primitives, which
registers, how a memory is sliced): Yosys ships no simulation model of
DP16KD or MULT18X18D (both are blackboxes in its ECP5 cell library), so the
synthesised netlist cannot be simulated here; the bitstream build places and
times it.
"""

import random
import re

import pytest
from amaranth.back import rtlil
from amaranth.sim import Simulator

from rast.hdl.ecp5_primitives import (RegisteredRAM, RegisteredMultiplier, dp16kd_mode, is_ecp5,
                                      kept_register, kept_lut, block_ram_rows)


class FakeECP5:
    family = "ecp5"


def _rtlil(dut, platform):
    return rtlil.convert(dut, platform=platform)


def _synth_ecp5(tmp_path, text):
    """RTLIL ``text`` of a module ``top`` through synth_ecp5 into
    ``tmp_path/top.json``; returns the tools' environment."""
    import subprocess
    from rast.gateware.build import tool_env
    (tmp_path / "top.il").write_text(text)
    env = tool_env()
    subprocess.run([env["YOSYS"], "-q", "-p", "read_rtlil top.il; synth_ecp5 -top top -json top.json"],
                   cwd=tmp_path, env=env, check=True, capture_output=True)
    return env


def test_mode_choice():
    assert dp16kd_mode(32, 8192) == (2, 16)
    assert dp16kd_mode(32, 4096) == (4, 8)
    assert dp16kd_mode(32, 1024) == (18, 2)
    assert dp16kd_mode(32, 64) == (18, 2)
    assert dp16kd_mode(32, 2048) == (9, 4)
    assert dp16kd_mode(32, 32768) is None
    assert is_ecp5(FakeECP5()) and not is_ecp5(None)


@pytest.mark.parametrize("continuous", [False, True])
@pytest.mark.parametrize("addr_reg", [False, True])
def test_ram_model(addr_reg, continuous):
    """Behavioural RAM: latency 2 (3) under r_en, old data on a same-address write,
    r_data 0 until the read stage has been loaded; with ``continuous`` a read
    every clock, r_data what the read stage held (the address register and
    the read stage power up at 0, so the first words are word 0's)."""
    W, D = 12, 32
    dut = RegisteredRAM(W, D, addr_reg=addr_reg, continuous=continuous)
    assert dut.latency == (3 if addr_reg else 2)
    assert hasattr(dut, "r_en") != continuous
    areg = 0 if continuous else None
    rng = random.Random(3)
    mem = [0] * D
    stage, out, primed = 0, 0, False
    log = []

    async def bench(ctx):
        nonlocal stage, out, primed, areg
        for cyc in range(600):
            we, re_ = rng.random() < 0.5, rng.random() < 0.7
            wa, ra, wd = rng.randrange(D), rng.randrange(D), rng.randrange(1 << W)
            if rng.random() < 0.1:
                ra = wa
            if continuous:
                re_ = True
                primed = primed or cyc > 0      # the read stage powers up holding 0
            else:
                ctx.set(dut.r_en, re_)
            ctx.set(dut.w_en, we); ctx.set(dut.w_addr, wa); ctx.set(dut.w_data, wd)
            ctx.set(dut.r_addr, ra)
            await ctx.tick()
            if re_:
                if primed:                  # r_data stays 0 until the read stage is loaded
                    out = stage
                if addr_reg:
                    if areg is not None:
                        stage, primed = mem[areg], True
                    areg = ra
                else:
                    stage, primed = mem[ra], True
            if we:
                mem[wa] = wd
            got = ctx.get(dut.r_data)
            log.append((cyc, got, out))
            assert got == out, f"cycle {cyc}: r_data {got:#x}, model {out:#x}"

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    assert any(o for _, _, o in log)


@pytest.mark.parametrize("width,depth,mode_w,slices", [(32, 8192, 2, 16), (32, 4096, 4, 8),
                                                       (32, 1024, 18, 2), (32, 64, 18, 2)])
def test_ram_ecp5_structure(width, depth, mode_w, slices):
    text = _rtlil(RegisteredRAM(width, depth), FakeECP5())
    cells = re.findall(r"cell \\DP16KD", text)
    assert len(cells) == slices
    assert text.count('parameter \\REGMODE_B "OUTREG"') == slices
    assert text.count(f"parameter \\DATA_WIDTH_B {mode_w}") == slices
    assert "$mem" not in text                         # no inferred memory left
    assert RegisteredRAM(width, depth).block_rams() == slices


def test_ram_with_init_falls_back_to_inference():
    text = _rtlil(RegisteredRAM(32, 64, init=[1, 2, 3]), FakeECP5())
    assert "DP16KD" not in text and "$mem" in text


@pytest.mark.parametrize("input_reg", [False, True])
def test_multiplier_model(input_reg):
    dut = RegisteredMultiplier(16, 17, input_reg=input_reg)
    assert dut.latency == (2 if input_reg else 1)
    rng = random.Random(7)

    async def bench(ctx):
        stage, expect = (0, 0), 0
        for _ in range(300):
            a, b, en = rng.randrange(-(1 << 15), 1 << 15), rng.randrange(-(1 << 16), 1 << 16), rng.random() < 0.8
            ctx.set(dut.a, a); ctx.set(dut.b, b); ctx.set(dut.en, en)
            await ctx.tick()
            if en:
                if input_reg:
                    expect, stage = stage[0] * stage[1], (a, b)
                else:
                    expect = a * b
            assert ctx.get(dut.o) == expect
        for _ in range(dut.latency):
            ctx.set(dut.a, -(1 << 15)); ctx.set(dut.b, -(1 << 16)); ctx.set(dut.en, 1)
            await ctx.tick()
        assert ctx.get(dut.o) == 1 << 31                  # the extreme product fits

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()


def test_multiplier_ecp5_structure():
    text = _rtlil(RegisteredMultiplier(18, 17), FakeECP5())
    assert len(re.findall(r"cell \\MULT18X18D", text)) == 1
    assert 'parameter \\REG_OUTPUT_CLK "CLK0"' in text
    assert 'parameter \\REG_INPUTA_CLK "NONE"' in text and 'parameter \\REG_PIPELINE_CLK "NONE"' in text
    assert "$mul" not in text
    text = _rtlil(RegisteredMultiplier(18, 17, input_reg=True), FakeECP5())
    assert 'parameter \\REG_INPUTA_CLK "CLK0"' in text and 'parameter \\REG_INPUTB_CLK "CLK0"' in text


@pytest.mark.parametrize("kept", [False, True])
def test_kept_register_copies_survive_synthesis(kept, tmp_path):
    """Four registers of one 8-bit value, each read by different logic, through
    synth_ecp5: plain registers are merged into one (which is why a fan-out
    tree needs :func:`kept_register`), kept ones stay four."""
    import subprocess
    from amaranth.hdl import Module, Signal
    from rast.gateware.build import tool_env, parse_yosys_stat
    m = Module()
    a, o = Signal(8), Signal(8)
    if kept:
        copies = [kept_register(m, FakeECP5(), a, f"copy{k}", reset=k % 2 == 1) for k in range(4)]
    else:
        copies = [Signal(8, name=f"copy{k}") for k in range(4)]
        m.d.sync += [c.eq(a) for c in copies]
    m.d.comb += o.eq(copies[0] ^ (copies[1] + copies[2]) ^ (copies[3] - 1))
    (tmp_path / "top.il").write_text(rtlil.convert(m, ports=[a, o]))
    env = tool_env()
    subprocess.run([env["YOSYS"], "-q", "-l", "top.rpt", "-p", "read_rtlil top.il; synth_ecp5 -top top; stat"],
                   cwd=tmp_path, env=env, check=True, capture_output=True)
    assert parse_yosys_stat((tmp_path / "top.rpt").read_text())["TRELLIS_FF"] == (32 if kept else 8)


def test_ram_sites_are_the_85f_bels_nextpnr_places_at(tmp_path):
    """A RAM whose slices are given sites (one in each block-RAM row of the
    LFE5U-85F, at both ends and between) through synth_ecp5 and nextpnr's
    placer: each DP16KD is where it was asked to be, so the site names of
    block_ram_rows are the device's bels and nextpnr honours them."""
    import json
    import subprocess
    platform = type("ECP5", (), {"family": "ecp5", "device": "LFE5U-85F"})()
    rows = block_ram_rows(platform)
    sites = [rows[0][0], rows[1][17], rows[2][34], rows[3][51]]
    env = _synth_ecp5(tmp_path, _rtlil(RegisteredRAM(4, 16384, sites=sites, continuous=True), platform))
    subprocess.run([env["NEXTPNR_ECP5"], "--85k", "--package", "CABGA381", "--json", "top.json",
                    "--no-route", "--write", "placed.json", "--timing-allow-fail"],
                   cwd=tmp_path, env=env, check=True, capture_output=True)
    cells = json.loads((tmp_path / "placed.json").read_text())["modules"]["top"]["cells"]
    placed = {name.rsplit(".", 1)[-1]: c["attributes"]["NEXTPNR_BEL"]
              for name, c in cells.items() if c["type"] == "DP16KD"}
    assert placed == {f"bram{k}": site for k, site in enumerate(sites)}


def test_ram_sites_apply_on_ecp5_only():
    """Sites apply on ECP5 only; elsewhere the RAM is a Memory as always."""
    text = _rtlil(RegisteredRAM(2, 8192, sites=["X4/Y22/EBR0"]), None)
    assert "DP16KD" not in text and "BEL" not in text


@pytest.mark.parametrize("reset", [False, True])
def test_kept_register_behaviour(reset):
    """Off ECP5 a kept register is a plain one: the value one clock later,
    cleared by the domain's reset only with ``reset``."""
    from amaranth.hdl import Module, Signal, ResetSignal
    m = Module()
    a, rst = Signal(6), Signal()
    q = kept_register(m, None, a, "q", reset=reset)
    m.d.comb += ResetSignal().eq(rst)
    seen = []

    async def bench(ctx):
        for v in range(1, 21):
            ctx.set(a, v * 7 % 64)
            ctx.set(rst, v == 9)
            await ctx.tick()
            seen.append(ctx.get(q))

    sim = Simulator(m)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    assert seen == [0 if reset and v == 9 else v * 7 % 64 for v in range(1, 21)]


#: Functions for the kept LUT, each beside the same function on Python
#: booleans (the reference, written independently of the bitwise form).
KEPT_LUT_FUNCTIONS = [
    (lambda s, mu, c, la: s & ~mu & c & la, lambda s, mu, c, la: s and not mu and c and la),
    (lambda a, b, c, d: (a ^ b) | (c & ~d), lambda a, b, c, d: (a != b) or (c and not d)),
    (lambda a, b, c: ~(a | b) ^ c, lambda a, b, c: (not (a or b)) != c),
    (lambda a: ~a, lambda a: not a),
]

#: The LUT4's function as Lattice documents it: Z = INIT[{D, C, B, A}].
LUT4_MODEL = """module LUT4(input A, input B, input C, input D, output Z);
  parameter [15:0] INIT = 16'h0000;
  assign Z = INIT[{D, C, B, A}];
endmodule
"""


@pytest.mark.parametrize("k", range(len(KEPT_LUT_FUNCTIONS)))
def test_kept_lut_behaviour(k):
    """Off ECP5 a kept LUT is the plain expression: every input pattern
    against the reference function."""
    from amaranth.hdl import Module, Signal
    fn, ref = KEPT_LUT_FUNCTIONS[k]
    n = fn.__code__.co_argcount
    m = Module()
    ins = [Signal(name=f"i{j}") for j in range(n)]
    z = kept_lut(m, None, ins, fn, "z")
    seen = {}

    async def bench(ctx):
        for v in range(1 << n):
            for j, i in enumerate(ins):
                ctx.set(i, (v >> j) & 1)
            seen[v] = ctx.get(z)

    sim = Simulator(m)
    sim.add_testbench(bench)
    sim.run()
    assert seen == {v: int(ref(*((v >> j) & 1 for j in range(n)))) for v in range(1 << n)}


@pytest.mark.parametrize("k", range(len(KEPT_LUT_FUNCTIONS)))
def test_kept_lut_instance_is_the_expression(k, tmp_path):
    """On ECP5 the kept LUT is a LUT4 instance; Yosys's SAT solver proves it
    (with the LUT4's documented function) equal to the plain expression for
    every input, and finds a LUT4 with one INIT bit flipped different (so
    that the check can fail)."""
    import subprocess
    from amaranth.hdl import Module, Signal
    from rast.gateware.build import tool_env
    fn = KEPT_LUT_FUNCTIONS[k][0]
    n = fn.__code__.co_argcount
    for tag, platform in (("gold", None), ("gate", FakeECP5())):
        m = Module()
        ins = [Signal(name=f"i{j}") for j in range(n)]
        z = Signal(name="z")
        m.d.comb += z.eq(kept_lut(m, platform, ins, fn, "kept"))
        (tmp_path / f"{tag}.il").write_text(rtlil.convert(m, ports=[*ins, z], name=tag))
    gate = (tmp_path / "gate.il").read_text()
    init = re.search(r"parameter \\INIT 16'([01]{16})", gate).group(1)
    flipped = init[:-1] + ("1" if init[-1] == "0" else "0")
    (tmp_path / "flipped.il").write_text(gate.replace(f"16'{init}", f"16'{flipped}"))
    (tmp_path / "lut4.v").write_text(LUT4_MODEL)
    env = tool_env()

    def equal(netlist):
        script = (f"read_rtlil {netlist}; read_verilog lut4.v; hierarchy -top gate; flatten; "
                  "read_rtlil gold.il; miter -equiv -flatten -make_assert gold gate miter; "
                  "hierarchy -top miter; sat -verify -prove-asserts miter")
        return subprocess.run([env["YOSYS"], "-q", "-p", script], cwd=tmp_path, env=env,
                              capture_output=True).returncode == 0

    assert "LUT4" in gate
    assert equal("gate.il")
    assert not equal("flipped.il")


def test_parameter_errors():
    from amaranth.hdl import Module, Signal
    with pytest.raises(ValueError, match=r"^Inputs must be one to four one-bit values"):
        kept_lut(Module(), None, [Signal(2)], lambda a: a, "z")
    with pytest.raises(ValueError, match=r"^Inputs must be one to four one-bit values"):
        kept_lut(Module(), None, [Signal() for _ in range(5)], lambda *a: a[0], "z")
    with pytest.raises(TypeError, match=r"^RAM width must be a positive integer, not 0$"):
        RegisteredRAM(0, 16)
    with pytest.raises(ValueError, match=r"^RAM sites must be 4 bel names \(one per block RAM of a "
                                         r"16384 x 4 RAM\), not \('X4/Y22/EBR0',\)$"):
        RegisteredRAM(4, 16384, sites=["X4/Y22/EBR0"])
    with pytest.raises(ValueError, match=r"^Operand A width must be an integer in \[1, 18\], not 19$"):
        RegisteredMultiplier(19, 16)


def _lut_ram_constant_pins(m, ports, tmp_path):
    """Through synth_ecp5: the distributed RAMs' address and write-enable pins
    tied to a constant (which nextpnr routes from one die-wide net), and how
    many such RAMs there are."""
    import json
    _synth_ecp5(tmp_path, rtlil.convert(m, ports=ports))
    cells = json.loads((tmp_path / "top.json").read_text())["modules"]["top"]["cells"].values()
    rams = [c for c in cells if c["type"] == "TRELLIS_DPR16X4"]
    tied = [(port, bit) for c in rams for port, bits in c["connections"].items()
            if port in ("RAD", "WAD", "WRE") for bit in bits if bit in ("0", "1")]
    return tied, len(rams)


@pytest.mark.parametrize("platform", [None, FakeECP5()], ids=["generic", "ecp5"])
def test_ring_delay_rams_have_no_constant_pins_on_ecp5(platform, tmp_path):
    """A state ring of 7 clocks (the 64-channel build's M = 8) in distributed
    RAM: its 16 words (``lut_ram_depth``; 8 would do) leave no address pin
    constant; its write enable, always on, is the constant generically and
    on ECP5 a flip-flop of its own (``local_constant``), so that no pin of
    the RAMs is on the constant net there."""
    from amaranth.hdl import Module, Signal
    from rast.hdl.register_chain import ring_delay
    m = Module()
    a = Signal(8)
    out, _ = ring_delay(m, a, 7, [0] * 7, "ring", input_reg=True, platform=platform)
    o = Signal(8)
    m.d.comb += o.eq(out)
    tied, rams = _lut_ram_constant_pins(m, [a, o], tmp_path)
    assert rams >= 2
    if platform is None:
        assert tied and {port for port, _ in tied} == {"WRE"}
    else:
        assert tied == []


def test_lut_ram_depth():
    from rast.hdl.ecp5_primitives import lut_ram_depth
    assert [lut_ram_depth(n) for n in (1, 2, 7, 8, 9, 16, 17, 33)] == [16, 16, 16, 16, 16, 16, 32, 64]
