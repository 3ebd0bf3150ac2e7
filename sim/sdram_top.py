"""Simulation top of the SDRAM stream pool: :class:`~rast.hdl.sdram_pool.SDRAMStreamPool`
on LiteDRAM's ``--sim`` core (``SDRAMPHYModel`` inside), initialised by the
CPU-less sequencer. Engine side in ``sync`` (ports ``clk``/``rst``), controller
in ``sdram`` (``sdram_clk``/``sdram_rst``)."""

from amaranth.hdl import Module
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from rast.gateware.sdram.core import LiteDRAMCore
from rast.gateware.sdram.generate import CORE_NAME, generate_core
from rast.hdl.sdram_pool import SDRAMStreamPool, WORD_WIDTH

__all__ = ["SDRAMPoolTop", "sdram_top_sources", "TOPLEVEL", "LITEDRAM_LINT_WAIVERS"]

TOPLEVEL = "sdram_top"

#: Verilator warnings waived in LiteDRAM's generated Verilog only (a
#: ``lint_off`` comment at the top of that file; the project's own list in
#: ``rast.gateware.verilog`` still applies to everything else), with the reason.
LITEDRAM_LINT_WAIVERS = {
    "COMBDLY": "Migen writes '<=' in its always @(*) blocks; Verilator executes them as '=', "
               "which is what Migen means (497 of them, the only class Verilator reports there)",
}


def litedram_for_verilator(text: str) -> str:
    head = "".join(f"/* verilator lint_off {w} */\n" for w in LITEDRAM_LINT_WAIVERS)
    return head + text


class SDRAMPoolTop(wiring.Component):
    """The pool's engine-side ports, ``init_done`` and ``lost`` at the top."""

    def __init__(self, core, *, tag_width=6, queue_depth=16, cdelay_clocks=1):
        self._pool = SDRAMStreamPool(core.port_addr_width, tag_width, queue_depth=queue_depth,
                                     sdram_domain="sdram")
        self._core = LiteDRAMCore(core, domain="sdram", cdelay_clocks=cdelay_clocks)
        aw = core.port_addr_width
        super().__init__({
            "r_valid": In(1), "r_ready": Out(1), "r_addr": In(aw), "r_tag": In(tag_width),
            "d_valid": Out(1), "d_tag": Out(tag_width), "d_data": Out(WORD_WIDTH),
            "w_valid": In(1), "w_ready": Out(1), "w_addr": In(aw), "w_data": In(WORD_WIDTH),
            "rd_valid": In(1), "rd_ready": Out(1), "rd_addr": In(aw),
            "rd_data_valid": Out(1), "rd_data": Out(WORD_WIDTH),
            "lost": Out(1), "init_done": Out(1), "init_error": Out(1),
        })

    def elaborate(self, platform):
        m = Module()
        m.submodules.pool = pool = self._pool
        m.submodules.sdram = core = self._core
        wiring.connect(m, pool.native, core.native)
        for name in ("r_valid", "r_addr", "r_tag", "w_valid", "w_addr", "w_data", "rd_valid", "rd_addr"):
            m.d.comb += getattr(pool, name).eq(getattr(self, name))
        for name in ("r_ready", "d_valid", "d_tag", "d_data", "w_ready", "rd_ready", "rd_data_valid",
                     "rd_data", "lost"):
            m.d.comb += getattr(self, name).eq(getattr(pool, name))
        m.d.comb += [self.init_done.eq(core.init_done), self.init_error.eq(core.init_error)]
        return m


def sdram_top_sources(*, tag_width=6, queue_depth=16, cdelay_clocks=1):
    """``({file: Verilog}, core)``: the top (Amaranth) and LiteDRAM's simulation core."""
    from amaranth.back import verilog
    core = generate_core(sim=True)
    top = SDRAMPoolTop(core, tag_width=tag_width, queue_depth=queue_depth, cdelay_clocks=cdelay_clocks)
    text = verilog.convert(top, name=TOPLEVEL, emit_src=False)
    return {f"{TOPLEVEL}.v": text, f"{CORE_NAME}.v": litedram_for_verilator(core.verilog)}, core
