"""Simulation tops on LiteDRAM's ``--sim`` core (``SDRAMPHYModel`` inside),
initialised by the CPU-less sequencer.

* :class:`SDRAMPoolTop`: :class:`~rast.hdl.sdram_pool.SDRAMStreamPool` alone.
  Engine side in ``sync`` (ports ``clk``/``rst``), controller in ``sdram``
  (``sdram_clk``/``sdram_rst``).
* :class:`SDRAMEngineTop`: the replay engine with its pool in SDRAM
  (``WindFarmReplay(pool="sdram")``), the ports of the block-RAM engine's
  top so that the bulk wrapper (``rast.sim.bulk``) drives it unchanged.
* :class:`SDRAMSystemTop`: the board's replay system (UART bridge + engine)
  on the same core, for the load chain through the UART.

Both are :class:`OnSimSDRAM`: one clock port, the controller's clock made
from the fabric clock by :class:`FractionalClock` at the board's ratio
(SDRAM_CLOCK_HZ against the contract's fabric clock: 4 for 200 MHz, 16/5 for
160 MHz), two domains crossing through the pool's two ``CrossingQueue``
instances.
"""

from fractions import Fraction
from numbers import Rational

from amaranth.hdl import ClockDomain, ClockSignal, Module, ResetInserter, ResetSignal, Signal
from amaranth.lib import wiring
from amaranth.lib.cdc import FFSynchronizer
from amaranth.lib.wiring import In, Out

from rast.gateware.sdram.core import LiteDRAMCore
from rast.gateware.sdram.generate import CORE_NAME, generate_core
from rast.hdl.sdram_pool import SDRAMStreamPool, WORD_WIDTH
from rast.model.contract.fixedpoint import SDRAM_CLOCK_HZ, SDRAM_FABRIC_HZ

__all__ = ["SDRAMPoolTop", "sdram_top_sources", "TOPLEVEL", "LITEDRAM_LINT_WAIVERS",
           "FractionalClock", "OnSimSDRAM", "SDRAMEngineTop", "SDRAMSystemTop", "ENGINE_TOPLEVEL",
           "fabric_clocks_per_sdram_clock", "sdram_engine_sources", "sdram_image", "SDRAM_IMAGE_MEMORIES"]

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


ENGINE_TOPLEVEL = "sdram_engine_top"


def fabric_clocks_per_sdram_clock(fabric_hz: int) -> Fraction:
    """Fabric clocks per controller clock on the board: ``fabric_hz`` (0: not
    stated, SDRAM_FABRIC_HZ as the contract takes it) over SDRAM_CLOCK_HZ."""
    return Fraction(int(fabric_hz) or SDRAM_FABRIC_HZ, SDRAM_CLOCK_HZ)


class FractionalClock(wiring.Component):
    """A clock at ``1 / ratio`` of the domain's, for simulation: ``clk``
    toggles whenever a phase accumulator that gains ``2 * denominator`` per
    clock passes ``numerator``, so ``ratio`` = ``numerator / denominator``
    clocks make one period on average, and every edge is a fabric edge (at
    16/5, the 160 MHz board's 50 MHz controller, five periods of 3 or 4
    clocks in every 16). At a whole ratio the periods are equal; at 4 the
    output is bit 1 of a counter from 0. The board's PLL gives edges between
    the fabric's instead; the crossings between the two domains assume no
    phase relation, so what the simulation must get right is the rate.

    Parameters
    ----------
    ratio : Rational
        Clocks of the domain per output period, at least 2 (each half period
        at least one clock).

    Members
    -------
    clk : Out(1)
    """

    clk: Out(1)

    def __init__(self, ratio):
        if not isinstance(ratio, Rational) or isinstance(ratio, bool):
            raise TypeError(f"Clock ratio must be a rational number, not {ratio!r}")
        if ratio < 2:
            raise ValueError(f"Clock ratio must be at least 2 (a clock a half period), not {ratio}")
        self._ratio = Fraction(ratio)
        super().__init__()

    @property
    def ratio(self) -> Fraction:
        return self._ratio

    def elaborate(self, platform):
        m = Module()
        num, step = self._ratio.numerator, 2 * self._ratio.denominator
        phase = Signal(range(num))
        with m.If(phase + step >= num):
            m.d.sync += [phase.eq(phase + step - num), self.clk.eq(~self.clk)]
        with m.Else():
            m.d.sync += phase.eq(phase + step)
        return m


class OnSimSDRAM(wiring.Component):
    """``inner`` (a component with an SDRAM pool's ``native`` port) on
    LiteDRAM's simulation core.

    Ports: ``inner``'s members named in ``names``, passed through, and the
    core's ``init_done``, ``init_error``. The controller's domain ``sdram``
    runs at the fabric clock / ``fabric_per_sdram`` (:class:`FractionalClock`),
    its reset held for 16 fabric clocks after the fabric's.

    ``hold_until_init``: ``inner``'s ``sync`` domain held in reset until the
    core's ``init_done`` (synchronised), its stream input ``i`` and its
    ``bus`` not ready until then: an engine whose channels play from power-up
    out of a preloaded SDRAM (:func:`sdram_image`) fetches nothing before the
    controller answers, and its first input sample is the model's first.
    """

    def __init__(self, core, inner, names, *, cdelay_clocks=1, fabric_per_sdram=4, hold_until_init=False):
        self._clock = FractionalClock(fabric_per_sdram)
        self._generated = core
        self._inner = inner
        self._names = tuple(names)
        self._core = LiteDRAMCore(core, domain="sdram", cdelay_clocks=cdelay_clocks)
        self._hold = hold_until_init
        sig = inner.signature.members
        super().__init__({name: sig[name] for name in self._names}
                         | {"init_done": Out(1), "init_error": Out(1)})

    @property
    def inner(self):
        return self._inner

    def verilog_sources(self, name):
        """``{file: Verilog}``: this top as module ``name`` and LiteDRAM's core."""
        from amaranth.back import verilog
        text = verilog.convert(self, name=name, emit_src=False)
        return {f"{name}.v": text, f"{CORE_NAME}.v": litedram_for_verilator(self._generated.verilog)}

    def elaborate(self, platform):
        m = Module()
        m.domains.sdram = ClockDomain("sdram", local=True)
        m.submodules.sdram_clock = clock = self._clock
        hold = Signal(range(17), init=16)
        with m.If(hold != 0):
            m.d.sync += hold.eq(hold - 1)
        m.d.comb += [ClockSignal("sdram").eq(clock.clk), ResetSignal("sdram").eq(hold != 0)]
        inner, ready = self._inner, None
        m.submodules.sdram = core = self._core
        if self._hold:
            ready = Signal()
            m.submodules.init_sync = FFSynchronizer(core.init_done, ready)
            m.submodules.inner = ResetInserter({"sync": ~ready})(inner)
        else:
            m.submodules.inner = inner
        wiring.connect(m, inner.native, core.native)
        for name in self._names:
            member = self.signature.members[name]
            outer, port = getattr(self, name), getattr(inner, name)
            if ready is not None and name == "i":
                m.d.comb += [port.payload.eq(outer.payload), port.valid.eq(outer.valid & ready),
                             outer.ready.eq(port.ready & ready)]
            elif ready is not None and name == "bus":
                m.d.comb += [port.addr.eq(outer.addr), port.w_data.eq(outer.w_data),
                             port.w_stb.eq(outer.w_stb & ready), port.r_stb.eq(outer.r_stb & ready),
                             outer.ready.eq(port.ready & ready), outer.r_data.eq(port.r_data),
                             outer.r_valid.eq(port.r_valid)]
            elif member.is_port:
                m.d.comb += (port.eq(outer) if member.flow == In else outer.eq(port))
            elif member.flow == In:
                wiring.connect(m, wiring.flipped(outer), port)
            else:
                wiring.connect(m, port, wiring.flipped(outer))
        m.d.comb += [self.init_done.eq(core.init_done), self.init_error.eq(core.init_error)]
        return m


class SDRAMEngineTop(OnSimSDRAM):
    """``WindFarmReplay(pool="sdram", **kwargs)`` on LiteDRAM's simulation
    core; ports: the engine's ``i``, ``o``, ``bus``, ``overflow``, ``slot``,
    ``pool_error``, ``underflow`` (those of the block-RAM engine's top, so
    that the bulk wrapper drives it unchanged) and ``init_done``, ``init_error``.
    ``fabric_per_sdram``: fabric clocks per controller clock, by default the
    board's for the contract's fabric clock (:func:`fabric_clocks_per_sdram_clock`).

    ``kwargs`` with ``init`` streams: the engine plays them from power-up out
    of an SDRAM model the bulk wrapper loads at the start (:func:`sdram_image`
    into SDRAM_IMAGE_MEMORIES), held until the controller's ``init_done``."""

    def __init__(self, core, channels, *, cdelay_clocks=1, fabric_per_sdram=None, **kwargs):
        from rast.hdl.replay_top import WindFarmReplay
        preloaded = any(ini.words for ini in kwargs.get("init") or ())
        engine = WindFarmReplay(channels, pool="sdram", sdram_preloaded=preloaded, **kwargs)
        if fabric_per_sdram is None:
            fabric_per_sdram = fabric_clocks_per_sdram_clock(engine.contract.clock_hz)
        super().__init__(core, engine, ("i", "o", "bus", "overflow", "slot", "pool_error", "underflow"),
                         cdelay_clocks=cdelay_clocks, fabric_per_sdram=fabric_per_sdram,
                         hold_until_init=preloaded)

    @property
    def engine(self):
        return self.inner


class SDRAMSystemTop(OnSimSDRAM):
    """The board's replay system (UART bridge + engine,
    :class:`rast.gateware.top.ReplaySystem`, ``pool="sdram"``) on LiteDRAM's
    simulation core, for the load chain through the UART (``rast.sim.uart_chain``):
    ports ``rx``, ``tx``, ``i``, ``o``, ``overflow``, ``pool_error``,
    ``init_done``, ``init_error``; the controller at SDRAM_CLOCK_HZ against
    ``clk_hz``, as on the board."""

    def __init__(self, core, clk_hz, *, cdelay_clocks=1, **system_kwargs):
        from rast.gateware.top import ReplaySystem
        super().__init__(core, ReplaySystem(clk_hz, pool="sdram", **system_kwargs),
                         ("rx", "tx", "i", "o", "overflow", "pool_error"), cdelay_clocks=cdelay_clocks,
                         fabric_per_sdram=fabric_clocks_per_sdram_clock(round(clk_hz)))

    @property
    def system(self):
        return self.inner

    @property
    def divisor(self):
        return self.inner.divisor


def sdram_engine_sources(channels, *, cdelay_clocks=1, fabric_per_sdram=None, **kwargs):
    """``{file: Verilog}`` of :class:`SDRAMEngineTop` (module ``sdram_engine_top``)
    and LiteDRAM's simulation core; ``kwargs`` as for ``WindFarmReplay``."""
    top = SDRAMEngineTop(generate_core(sim=True), channels, cdelay_clocks=cdelay_clocks,
                         fabric_per_sdram=fabric_per_sdram, **kwargs)
    return top.verilog_sources(ENGINE_TOPLEVEL)


#: The simulation core's SDRAM banks as the bulk wrapper reaches them from its
#: DUT (``sdram_engine_top``'s ``sdram`` holds the core, ``litedram``): file
#: name -> memory. LiteDRAM's ``SDRAMPHYModel`` keeps one array per bank (of
#: the MT48LC16M16's four), 16-bit words at ``row * 512 + column``.
SDRAM_IMAGE_MEMORIES = {f"sdram_bank{b}.hex": f"dut.sdram.litedram.mem{'' if b == 0 else f'_{b}'}"
                        for b in range(4)}
_COLUMN_BITS, _BANK_BITS = 9, 2


def sdram_image(pool_words) -> dict:
    """The pool's words (``pool_words[a]`` at pool address a, the first
    ``len(pool_words)`` of the SDRAM) as the simulation core's bank arrays
    hold them: ``{file name: (indices, 16-bit words)}`` per bank of
    SDRAM_IMAGE_MEMORIES. Each 32-bit word is two beats of the native port
    at addresses 2a (I, the low half) and 2a + 1 (Q); LiteDRAM's crossbar
    maps a beat address row | bank | column (ROW_BANK_COL: 9 column bits, 2
    bank bits)."""
    import numpy as np
    words = np.asarray(pool_words, dtype=np.int64) & 0xFFFFFFFF
    beat = np.arange(2 * len(words), dtype=np.int64)
    half = np.empty(2 * len(words), dtype=np.int64)
    half[0::2], half[1::2] = words & 0xFFFF, words >> 16
    column = beat & ((1 << _COLUMN_BITS) - 1)
    bank = (beat >> _COLUMN_BITS) & ((1 << _BANK_BITS) - 1)
    row = beat >> (_COLUMN_BITS + _BANK_BITS)
    index = (row << _COLUMN_BITS) | column
    return {name: (index[bank == b], half[bank == b]) for b, name in enumerate(SDRAM_IMAGE_MEMORIES)}
