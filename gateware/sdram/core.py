"""LiteDRAM's generated core as an Amaranth component, with its CPU-less initialisation."""

from amaranth.hdl import ClockSignal, DomainRenamer, Instance, IOPort, Module, ResetSignal, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ...hdl.sdram_pool import native_port_signature
from .generate import CORE_NAME, GeneratedCore
from .init import SDRAMInit, bios_sdram_init

__all__ = ["LiteDRAMCore"]


class LiteDRAMCore(wiring.Component):
    """``litedram_core`` (:func:`~rast.gateware.sdram.generate.generate_core`)
    clocked by ``domain``, initialised by :class:`~rast.gateware.sdram.init.SDRAMInit`
    on its ``wb_ctrl`` bus; its native user port is ``native``.

    The hardware variant's SDRAM pins are ports of this component except
    ``dq``: the core puts its own bidirectional ``TRELLIS_IO`` cells and I/O
    registers on it, so the pads must reach it raw (an ``IOPort``, e.g. a
    platform resource requested with ``dir="-"``). The SDRAM clock pin is not
    the core's: the board top drives it (docs/sdram.md). The ``--sim`` variant
    has no pins (LiteDRAM's ``SDRAMPHYModel`` inside) and no reset input.

    Parameters
    ----------
    core : GeneratedCore
    domain : str
        The controller's (SDRAM) clock domain.
    dq : IOPort or None
        The 16 data pads (hardware variant only).
    cdelay_clocks : int
        See :class:`~rast.gateware.sdram.init.SDRAMInit`.

    Members
    -------
    native : In(native_port_signature(core.port_addr_width, core.port_data_width))
    init_done : Out(1)
        The core's own (LiteDRAM opens the user port from then on).
    init_error : Out(1)
    sdram_a, sdram_ba, sdram_ras_n, sdram_cas_n, sdram_we_n, sdram_cs_n, sdram_cke, sdram_dm :
        Out, hardware variant only.
    """

    def __init__(self, core, *, domain="sdram", dq=None, cdelay_clocks=1):
        if not isinstance(core, GeneratedCore):
            raise TypeError(f"LiteDRAM core must be a GeneratedCore, not {core!r}")
        if not (isinstance(domain, str) and domain):
            raise TypeError(f"Domain must be a domain name, not {domain!r}")
        if core.sim and dq is not None:
            raise ValueError("The simulation core has no SDRAM pins; dq must be None")
        if not core.sim and not (isinstance(dq, IOPort) and len(dq) == 16):
            raise TypeError(f"Data pads must be a 16-bit IOPort, not {dq!r}")
        self._core, self._domain, self._dq = core, domain, dq
        self._init = SDRAMInit(bios_sdram_init(core), cdelay_clocks=cdelay_clocks)
        ports = {
            "native": In(native_port_signature(core.port_addr_width, core.port_data_width)),
            "init_done": Out(1), "init_error": Out(1),
        }
        if not core.sim:
            g = core.geometry
            ports.update({"sdram_a": Out(g["rowbits"]), "sdram_ba": Out(g["bankbits"]),
                          "sdram_ras_n": Out(1), "sdram_cas_n": Out(1), "sdram_we_n": Out(1),
                          "sdram_cs_n": Out(1), "sdram_cke": Out(1), "sdram_dm": Out(2)})
        super().__init__(ports)

    @property
    def core(self):
        return self._core

    @property
    def init(self):
        return self._init

    def elaborate(self, platform):
        m = Module()
        d = self._domain
        # the sequencer runs in the controller's domain
        m.submodules.init = DomainRenamer(d)(self._init)
        bus = self._init.bus
        n = self.native
        user_rst = Signal()
        kw = dict(
            i_clk=ClockSignal(d),
            o_init_done=self.init_done, o_init_error=self.init_error,
            o_user_clk=Signal(name="user_clk"), o_user_rst=user_rst,
            i_user_port_stream_cmd_valid=n.cmd.valid, o_user_port_stream_cmd_ready=n.cmd.ready,
            i_user_port_stream_cmd_we=n.cmd.payload.we, i_user_port_stream_cmd_addr=n.cmd.payload.addr,
            i_user_port_stream_wdata_valid=n.wdata.valid, o_user_port_stream_wdata_ready=n.wdata.ready,
            i_user_port_stream_wdata_we=n.wdata.payload.we,
            i_user_port_stream_wdata_data=n.wdata.payload.data,
            o_user_port_stream_rdata_valid=n.rdata.valid, i_user_port_stream_rdata_ready=n.rdata.ready,
            o_user_port_stream_rdata_data=n.rdata.payload,
            i_wb_ctrl_adr=bus.adr, i_wb_ctrl_dat_w=bus.dat_w, o_wb_ctrl_dat_r=bus.dat_r,
            i_wb_ctrl_sel=bus.sel, i_wb_ctrl_cyc=bus.cyc, i_wb_ctrl_stb=bus.stb, i_wb_ctrl_we=bus.we,
            o_wb_ctrl_ack=bus.ack, o_wb_ctrl_err=bus.err, i_wb_ctrl_cti=bus.cti, i_wb_ctrl_bte=bus.bte,
        )
        if self._core.sim:
            kw["i_sim_trace"] = 0
        else:
            kw.update(i_rst=ResetSignal(d), io_sdram_dq=self._dq,
                      o_sdram_a=self.sdram_a, o_sdram_ba=self.sdram_ba,
                      o_sdram_ras_n=self.sdram_ras_n, o_sdram_cas_n=self.sdram_cas_n,
                      o_sdram_we_n=self.sdram_we_n, o_sdram_cs_n=self.sdram_cs_n,
                      o_sdram_cke=self.sdram_cke, o_sdram_dm=self.sdram_dm)
        m.submodules.litedram = Instance(CORE_NAME, **kw)
        return m
