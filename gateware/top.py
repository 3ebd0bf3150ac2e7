"""Board top: PLL, ADC/DAC I/Q ports, UART host bridge and the replay block.

:class:`ReplaySystem` is the board-independent part (bridge + replay block);
the simulation tests drive it directly. :class:`SampleIO` is the board's
sample path around it (DDR cells, one fabric register in, two out),
:class:`BoardCore` the two together: everything of the board but the PLL,
which is what ``tests/test_cosim_board_io.py`` simulates with a clock from
the testbench. :class:`BoardTop` adds the clocking, the pins and the LEDs of
a board (:mod:`rast.gateware.platforms`).

With ``pool="sdram"`` (in the replay block's keyword arguments) the streams
live in the board's SDRAM: the replay block's LiteDRAM native port
(``native``, clock domain ``sdram``) and its sticky ``pool_error`` are
passed up through :class:`ReplaySystem` and :class:`BoardCore`, and
:class:`BoardTop` adds the 50 MHz controller clock and a copy shifted 90°
for the SDRAM clock pin (two more PLL outputs), LiteDRAM's generated core
(:class:`~rast.gateware.sdram.core.LiteDRAMCore`) on the ``sdram`` pins and
the SDRAM clock through an ``ODDRX1F`` (docs/sdram.md, docs/bitstream.md).

Sample interface to an ADC/DAC daughterboard (pin map: ``docs/bitstream.md``):
I and Q share one 16-bit bus per direction, double data rate: I on the
rising edge, Q on the falling edge of the sample clock. The board drives the
ADC's and the DAC's sample clock (``adc_clk``, ``dac_clk``: the sample clock
forwarded through an ``ODDRX1F``, so it is edge-aligned with the DAC data;
converters sample on the clock's falling/rising edge respectively, see the
pin map), and ``dac_iq`` high marks the I half of each sample.
"""

from amaranth.hdl import Elaboratable, Module, Signal, ClockSignal, Const, Cat, Mux, signed
from amaranth.lib import io, wiring, stream
from amaranth.lib.wiring import In, Out

from ..hdl.iq import IQ
from ..hdl.ecp5_primitives import kept_register
from ..hdl.replay_top import WindFarmReplay
from rast.model.contract.fixedpoint import INPUT_WIDTH, OUTPUT_WIDTH, PIN_LAG, SDRAM_CLOCK_HZ, reset_slot
from rast.model.contract.hostproto import DEFAULT_BAUD
from .bridge import UARTBridge
from .pll import ECP5PLL, pll_params
from .uart import divisor as uart_divisor

__all__ = ["ReplaySystem", "SampleIO", "BoardCore", "BoardTop", "DEFAULT_BAUD", "SDRAM_PHASE_DEG",
           "sdram_pll_outputs", "board_pll_params"]

DEFAULT_TIMEOUT_S = 0.02

#: Phase of the SDRAM clock pin against the controller's clock (docs/sdram.md:
#: litex-boards' ULX3S target at 1:1; the first thing to sweep at bring-up).
SDRAM_PHASE_DEG = 90.0


def sdram_pll_outputs(phase_deg=SDRAM_PHASE_DEG):
    """The PLL's secondary outputs of an SDRAM build: the controller's clock
    (domain ``sdram``, SDRAM_CLOCK_HZ) and its copy shifted ``phase_deg`` for
    the SDRAM clock pin (domain ``sdram_ps``)."""
    f = SDRAM_CLOCK_HZ / 1e6
    return (("sdram", f, 0.0), ("sdram_ps", f, phase_deg))


def board_pll_params(f_in_mhz, clock_mhz, pool="bram"):
    """The PLL of a board top: the fabric clock, and for ``pool="sdram"`` the
    outputs of :func:`sdram_pll_outputs`, whose controller clock must be
    SDRAM_CLOCK_HZ exactly (the contract's SDRAM bounds are in its clocks)."""
    if pool != "sdram":
        return pll_params(f_in_mhz, clock_mhz)
    p = pll_params(f_in_mhz, clock_mhz, outputs=sdram_pll_outputs())
    for o in p.outputs:
        if abs(o.f_out_mhz * 1e6 - SDRAM_CLOCK_HZ) > 1e-3:
            raise ValueError(f"The PLL makes the SDRAM clock {o.domain!r} at {o.f_out_mhz:.4f} MHz beside a "
                             f"{clock_mhz:g} MHz fabric clock; the SDRAM controller needs exactly "
                             f"{SDRAM_CLOCK_HZ / 1e6:g} MHz")
    return p


class ReplaySystem(wiring.Component):
    """UART bridge mastering the register bus of a :class:`WindFarmReplay`.

    Parameters
    ----------
    clk_hz : float
        Fabric clock (sets the UART divisor and the frame timeout).
    baud : int
    timeout_s : float
        Frame timeout of the bridge.
    **replay_kwargs
        Passed to :class:`WindFarmReplay` (``channels``, ``pool_words``, ...).

    Members
    -------
    rx : In(1), tx : Out(1)
    i : In(stream.Signature(IQ(16))), o : Out(stream.Signature(IQ(16)))
    overflow : Out(1)
    native, pool_error :
        The replay block's, with ``pool="sdram"`` only.
    """

    def __init__(self, clk_hz, baud=DEFAULT_BAUD, timeout_s=DEFAULT_TIMEOUT_S, *,
                 divisor=None, timeout=None, **replay_kwargs):
        self.replay = WindFarmReplay(**replay_kwargs)
        self.divisor = divisor if divisor is not None else uart_divisor(clk_hz, baud)
        self.timeout = timeout if timeout is not None else max(20 * self.divisor,
                                                               round(clk_hz * timeout_s))
        self.bridge = UARTBridge(self.replay.register_map.addr_width, self.divisor, self.timeout)
        super().__init__({
            "rx": In(1, init=1),
            "tx": Out(1, init=1),
            "i": In(stream.Signature(IQ(INPUT_WIDTH))),
            "o": Out(stream.Signature(IQ(OUTPUT_WIDTH))),
            "overflow": Out(1),
            **_passed_members(self.replay),
        })

    def elaborate(self, platform):
        m = Module()
        m.submodules.replay = replay = self.replay
        m.submodules.bridge = bridge = self.bridge
        wiring.connect(m, bridge.bus, replay.bus)
        wiring.connect(m, wiring.flipped(self.i), replay.i)
        wiring.connect(m, replay.o, wiring.flipped(self.o))
        m.d.comb += [bridge.rx.eq(self.rx), self.tx.eq(bridge.tx),
                     self.overflow.eq(replay.overflow)]
        _connect_passed(m, replay, self)
        return m


def _passed_members(inner):
    """``native`` and ``pool_error`` of ``inner`` (a component), and its
    ``acp`` and ``arp`` (the antenna scan), where it has them."""
    sig = inner.signature.members
    return {name: sig[name] for name in ("native", "pool_error", "acp", "arp") if name in sig}


def _connect_passed(m, inner, outer):
    """Pass ``inner``'s ``native`` and ``pool_error`` up to ``outer``'s, and
    ``outer``'s ``acp`` and ``arp`` down to ``inner``'s."""
    if "native" in outer.signature.members:
        wiring.connect(m, inner.native, wiring.flipped(outer.native))
        m.d.comb += outer.pool_error.eq(inner.pool_error)
    if "acp" in outer.signature.members:
        m.d.comb += [inner.acp.eq(outer.acp), inner.arp.eq(outer.arp)]


class SampleIO(wiring.Component):
    """The board's sample path outside the replay block: ADC pins to a sample
    stream, a sample stream to DAC pins, and the converters' clocks, all in
    the fabric clock domain.

    The converters run at the sample rate, f_clk / ``slots``. Their clocks
    (``adc_clk``, ``dac_clk``) and the DAC's I marker (``dac_iq``) are made
    from the replay block's slot counter: a pattern high for the first
    ``slots`` half clocks of each period (the first half of the sample), low
    for the rest, registered twice and driven through an ``ODDRX1F`` like
    the DAC's data, so clocks and data leave the pins together (at
    ``slots`` = 1 it is the fabric clock forwarded). No clock crosses to
    another domain.

    ADC: one ``io.DDRBuffer`` (an ``IDDRX1F`` per pin, taking the pins on
    every rising and falling edge of the fabric clock); the I half of sample k
    is the pins' value at the k-th rising edge of ``adc_clk`` as driven, the Q
    half at its falling edge. Both go into one register, offered to the block
    until it takes them. DAC: the block's output is taken once per period
    (``dac.ready`` in its last clock) into a register, and driven I while
    ``dac_clk`` is high, Q while it is low.

    Latency, ADC pin sample to DAC pin sample, in samples:
    ``rast.model.contract.fixedpoint.board_latency`` (checked by
    ``tests/test_cosim_board_io.py``).

    Parameters
    ----------
    adc_port, dac_port :
        Objects with I/O ports ``data`` (16 bits) and ``clk``, and for the DAC
        also ``iq``: the ``rts_adc``/``rts_dac`` resources requested with
        ``dir="-"``, or ``io.SingleEndedPort`` s in a simulation.
    slots : int
        Fabric clocks per sample (the replay block's M).
    domain : str
        The fabric clock domain.

    Members
    -------
    adc : Out(stream.Signature(IQ(16)))
    dac : In(stream.Signature(IQ(16)))
    slot : In(range(slots))
        The replay block's slot counter (0 in a period's first clock).
    """

    def __init__(self, adc_port, dac_port, slots=1, domain="sync"):
        if not isinstance(slots, int) or isinstance(slots, bool) or slots < 1:
            raise ValueError(f"Slots must be a positive integer, not {slots!r}")
        self._adc, self._dac, self._slots, self._domain = adc_port, dac_port, slots, domain
        super().__init__({
            "adc": Out(stream.Signature(IQ(INPUT_WIDTH))),
            "dac": In(stream.Signature(IQ(OUTPUT_WIDTH))),
            "slot": In(range(max(2, slots))),
        })

    def elaborate(self, platform):
        m = Module()
        d, M = self._domain, self._slots
        m.submodules.adc_data = adc_data = io.DDRBuffer("i", self._adc.data, i_domain=d)
        m.submodules.adc_clk = adc_clk = io.DDRBuffer("o", self._adc.clk, o_domain=d)
        # A buffer per DAC data pin: Amaranth's ECP5 lowering gives each output
        # buffer a pair of OE delay registers, and one pair for the 16 pins
        # (80 rows of the chip's edge apart) was a 64-channel build's latest
        # path (6.2 ns, 5.5 of it one route).
        dac_data = []
        for k in range(len(self._dac.data)):
            m.submodules[f"dac_data{k}"] = buf = io.DDRBuffer("o", self._dac.data[k], o_domain=d)
            dac_data.append(buf)
        m.submodules.dac_clk = dac_clk = io.DDRBuffer("o", self._dac.clk, o_domain=d)
        m.submodules.dac_iq = dac_iq = io.DDRBuffer("o", self._dac.iq, o_domain=d)

        # The slot counter's value of the clock before, in a register beside
        # the pins (reset to ``was``, the counter's value a clock before its
        # reset value ``reset_slot(M)``):
        # ``in_slot(S)``, "this clock's slot is in S", decodes it there. The
        # block's counter sits in the core; decoded straight from it, the
        # pins' registers were a long route and a compare away (the DAC's
        # data from the slot counter, 7.5 to 7.8 ns in n10_20_200). A copy
        # of the counter's next value instead is the counter itself to
        # Yosys, which merged the two.
        was = (reset_slot(M) - 1) % M
        if M > 1:
            before = Signal.like(self.slot, init=was, name="pin_slot_before")
            m.d[d] += before.eq(self.slot)

        def in_slot(slots, ahead=0, slot_before=None):
            """This clock's slot (``ahead`` clocks later's) is in ``slots``;
            ``slot_before``: from a copy of ``before`` XOR ``was`` (0 at reset)."""
            if M == 1:
                return Const(0 in slots)
            if slot_before is None:
                return Cat(*[before == (k - 1 - ahead) % M for k in slots]).any()
            return Cat(*[slot_before == ((k - 1 - ahead) % M) ^ was for k in slots]).any()

        # The pattern's two half clocks of this slot, registered: high while
        # the half clock's index within the period is below M.
        first_i, second_i = range((M + 1) // 2), range(M // 2)     # 2·slot < M, 2·slot + 1 < M
        # A pair of registers per pin, kept apart (one pair for the three
        # pins was a two-pipeline build's worst path, 6.5 ns of one route),
        # decoded from a copy of the slot of their own, beside them (from
        # ``before``, 6.0 ns at two pipelines): kept too, so its reset to 0
        # stands for ``before``'s ``was``.
        # Every pin's pattern and data leave through a second register of
        # their own (``PIN_LAG``), which the placer puts beside the pin's
        # output cell: the DAC's 16 data pins span 80 rows of the chip's
        # edge, and from one register per bit near the output FIFO the route
        # to the cell was up to 5.4 ns (a 16-channel build's latest path).
        def to_pin(value, name, reset):
            return kept_register(m, platform, value, f"{name}_pin", reset=reset, domain=d)

        for name, cell in (("adc_clk", adc_clk), ("dac_clk", dac_clk), ("dac_iq", dac_iq)):
            own = kept_register(m, platform, self.slot ^ was, f"{name}_slot", reset=True,
                                domain=d) if M > 1 else None
            for half, in_half in enumerate((first_i, second_i)):
                bit = kept_register(m, platform, in_slot(in_half, slot_before=own),
                                    f"{name}_hi{half}", reset=True, domain=d)
                m.d.comb += cell.o[half].eq(to_pin(bit, f"{name}_hi{half}", reset=True))

        # ADC: the pin clock's rising edge is PIN_LAG clocks after the slot-0
        # clock that made it; the IDDRX1F shows a pin sample the clock after.
        i_at, q_at = (PIN_LAG + 1) % M, (PIN_LAG + 1 + M // 2) % M
        q_bit = 1 if M % 2 else 0          # odd M: Q is the falling-edge sample
        i_held = Signal(signed(INPUT_WIDTH))
        x = Signal(IQ(INPUT_WIDTH))
        valid = Signal()
        if M > 1:
            # decided a clock ahead into registers (the slot's compare into
            # the enables of the sample's 32 bits, placed by the replay block,
            # was among a 64-channel build's late paths, 5.5 ns)
            take_i = Signal(init=reset_slot(M) == i_at, name="adc_take_i")
            take_q = Signal(init=reset_slot(M) == q_at, name="adc_take_q")
            m.d[d] += [take_i.eq(in_slot([i_at], ahead=1)), take_q.eq(in_slot([q_at], ahead=1))]
        else:
            take_i = take_q = Const(1)
        with m.If(take_i):
            m.d[d] += i_held.eq(adc_data.i[0])
        with m.If(take_q):
            m.d[d] += [x.re.eq(adc_data.i[0] if M == 1 else i_held), x.im.eq(adc_data.i[q_bit]),
                       valid.eq(1)]
        with m.Elif(self.adc.ready):
            m.d[d] += valid.eq(0)
        m.d.comb += [self.adc.payload.eq(x), self.adc.valid.eq(valid)]

        # DAC: one sample per period, taken in its last clock, I then Q.
        y = Signal(IQ(OUTPUT_WIDTH))
        if M > 1:
            # decided a clock ahead into a register: from the slot's compare,
            # through the output FIFO's read, into its counters' enables was
            # among a 16-channel build's latest paths (5.6 ns)
            dac_ready = Signal(name="dac_ready")        # slot 0 after reset: not the last
            m.d[d] += dac_ready.eq(in_slot([M - 1], ahead=1))
        else:
            dac_ready = in_slot([M - 1])
        m.d.comb += self.dac.ready.eq(dac_ready)
        with m.If(self.dac.ready):
            m.d[d] += y.eq(Mux(self.dac.valid, self.dac.payload, 0))
        # which half each edge drives, decided a clock ahead into registers
        # beside the data's: decoded from ``before`` in the data's clock, its
        # route to the 32 data registers was the two-pipeline build's worst
        # path (6.6 ns, 4.6 of it one route)
        if M > 1:
            sel0 = Signal(init=0 in first_i, name="dac_sel0")
            sel1 = Signal(init=0 in second_i, name="dac_sel1")
            m.d[d] += [sel0.eq(in_slot(first_i, ahead=1)), sel1.eq(in_slot(second_i, ahead=1))]
        else:
            sel0, sel1 = in_slot(first_i), in_slot(second_i)
        d0, d1 = Signal(signed(OUTPUT_WIDTH)), Signal(signed(OUTPUT_WIDTH))
        m.d[d] += [d0.eq(Mux(sel0, y.re, y.im)), d1.eq(Mux(sel1, y.re, y.im))]
        pin0, pin1 = to_pin(d0, "dac_d0", reset=False), to_pin(d1, "dac_d1", reset=False)
        for k, buf in enumerate(dac_data):
            m.d.comb += [buf.o[0].eq(pin0[k]), buf.o[1].eq(pin1[k])]
        return m


class BoardCore(wiring.Component):
    """Everything of :class:`BoardTop` but the PLL, the pin requests and the
    LEDs: :class:`SampleIO` feeding a :class:`ReplaySystem`, in domain ``sync``.

    Parameters
    ----------
    clk_hz : float
        Fabric clock (UART divisor, frame timeout; ``SAMPLE_RATE`` register
        = clk_hz / slots unless ``sample_rate_hz`` is given).
    adc_port, dac_port :
        As for :class:`SampleIO`.
    baud, divisor, timeout :
        As for :class:`ReplaySystem`.
    **replay_kwargs
        Passed to :class:`WindFarmReplay`.

    Members
    -------
    rx : In(1), tx : Out(1), overflow : Out(1)
    native, pool_error :
        The replay block's, with ``pool="sdram"`` only.
    """

    def __init__(self, clk_hz, adc_port, dac_port, baud=DEFAULT_BAUD, *, divisor=None, timeout=None,
                 **replay_kwargs):
        slots = replay_kwargs.get("slots", 1)
        replay_kwargs.setdefault("sample_rate_hz", round(clk_hz / slots))
        self.system = ReplaySystem(clk_hz, baud, divisor=divisor, timeout=timeout, **replay_kwargs)
        self.sample_io = SampleIO(adc_port, dac_port, slots)
        super().__init__({"rx": In(1, init=1), "tx": Out(1, init=1), "overflow": Out(1),
                          **_passed_members(self.system)})

    def elaborate(self, platform):
        m = Module()
        m.submodules.system = sys_ = self.system
        m.submodules.sample_io = sio = self.sample_io
        wiring.connect(m, sio.adc, sys_.i)
        wiring.connect(m, sys_.o, sio.dac)
        m.d.comb += [sys_.rx.eq(self.rx), self.tx.eq(sys_.tx), self.overflow.eq(sys_.overflow),
                     sio.slot.eq(sys_.replay.slot)]
        _connect_passed(m, sys_, self)
        return m


class BoardTop(Elaboratable):
    """The replay system on an ECP5 board: PLL, pins, :class:`BoardCore`, LEDs.

    Parameters
    ----------
    clock_mhz : float
        Fabric clock made by the PLL: ``slots`` (in ``replay_kwargs``) times
        the RTS sample rate.
    baud : int
    **replay_kwargs
        Passed to :class:`WindFarmReplay`.

    The platform must provide the board clock as its ``default_clk``, a
    ``uart`` resource, the ``rts_adc``/``rts_dac`` resources of
    :func:`rast.gateware.platforms.rts_resources` and optionally ``led``.

    With ``pool="sdram"`` also an amaranth-boards ``sdram`` resource (the
    ULX3S's): LiteDRAM's generated core (``generate_core(sim=False)``, its
    Verilog added to the platform's files) drives the command, address and
    mask pins from its I/O registers and takes the 16 data pads raw (it
    places its own bidirectional ``TRELLIS_IO``); the SDRAM clock pin is an
    ``ODDRX1F`` with D0 = 1, D1 = 0 clocked by the ``sdram_ps`` output
    (SDRAM_PHASE_DEG behind the controller's clock). A ``wifi_gpio0``
    resource, where the platform has one, is driven high (the ESP32 then
    leaves the FPGA alone); LED2 shows LiteDRAM's ``init_done``, LED3
    ``init_error`` or the replay block's ``pool_error``.
    """

    def __init__(self, clock_mhz=100.0, baud=DEFAULT_BAUD, **replay_kwargs):
        self.clock_mhz = float(clock_mhz)
        self.baud = baud
        self.replay_kwargs = replay_kwargs
        self.pool = replay_kwargs.get("pool", "bram")
        self.system = None
        self.core = None
        self.pll = None
        self.sdram = None      # the LiteDRAMCore of an SDRAM build, once elaborated

    def elaborate(self, platform):
        m = Module()
        clk_res = platform.lookup(platform.default_clk)
        f_in = clk_res.clock.frequency / 1e6
        clk_in = platform.request(platform.default_clk, 0)
        self.pll = board_pll_params(f_in, self.clock_mhz, self.pool)
        m.submodules.pll = pll = ECP5PLL(clk_in.i, self.pll, domain="sync")
        f = self.pll.f_out_mhz * 1e6

        adc = platform.request("rts_adc", 0, dir="-")
        dac = platform.request("rts_dac", 0, dir="-")
        # The SAMPLE_RATE register states the rate the PLL really makes.
        slots = self.replay_kwargs.get("slots", 1)
        self.core = core = BoardCore(f, adc, dac, self.baud, sample_rate_hz=round(f / slots),
                                     **self.replay_kwargs)
        self.system = core.system
        m.submodules.core = core

        uart = platform.request("uart", 0)
        m.d.comb += [core.rx.eq(uart.rx.i), uart.tx.o.eq(core.tx)]
        if self.replay_kwargs.get("scan"):
            if not any(r[0] == "rts_scan" for r in platform.resources):
                raise ValueError(f"The antenna scan needs the radar's ACP and ARP pins (rts_scan); "
                                 f"{type(platform).__name__} has none (pin map keys acp, arp)")
            pins = platform.request("rts_scan", 0)
            m.d.comb += [core.acp.eq(pins.acp.i), core.arp.eq(pins.arp.i)]

        # Status LEDs, where the board has them: overflow (sticky), PLL lock.
        leds = [r for r in platform.resources if r[0] == "led"]
        if len(leds) >= 2:
            m.d.comb += [platform.request("led", 0).o.eq(core.overflow),
                         platform.request("led", 1).o.eq(pll.locked)]
        if self.pool == "sdram":
            self._elaborate_sdram(m, platform, core, leds)
        return m

    def _elaborate_sdram(self, m, platform, core, leds):
        from .sdram.core import LiteDRAMCore
        from .sdram.generate import CORE_NAME, generate_core
        if not any(r[0] == "sdram" for r in platform.resources):
            raise ValueError(f"An SDRAM pool needs the platform's sdram resource; "
                             f"{type(platform).__name__} has none")
        gen = generate_core(sim=False)
        platform.add_file(f"{CORE_NAME}.v", gen.verilog)
        pins = platform.request("sdram", 0, dir="-")
        self.sdram = dram = LiteDRAMCore(gen, domain="sdram", dq=pins.dq.io)
        m.submodules.sdram = dram
        wiring.connect(m, core.native, dram.native)

        # Command, address and mask pins straight from the core's output
        # registers (OFS1P3BX, packed into the I/O cells): the core's outputs
        # are pin levels, so an active-low pin is driven through its port
        # with the inversion taken off.
        for pin, sig in (("clk_en", dram.sdram_cke), ("cs", dram.sdram_cs_n), ("we", dram.sdram_we_n),
                         ("ras", dram.sdram_ras_n), ("cas", dram.sdram_cas_n), ("ba", dram.sdram_ba),
                         ("a", dram.sdram_a), ("dqm", dram.sdram_dm)):
            port = getattr(pins, pin)
            if len(port) != len(sig):
                raise ValueError(f"SDRAM pin {pin} has {len(port)} bits; LiteDRAM's core drives {len(sig)}")
            if any(port.invert):
                port = ~port
            m.submodules[f"sdram_{pin}"] = buf = io.Buffer("o", port)
            m.d.comb += buf.o.eq(sig)

        # The SDRAM clock: the 90°-shifted copy of the controller's clock out
        # of an ODDRX1F (D0 = 1, D1 = 0): a fixed I/O cell path from the PLL.
        m.submodules.sdram_clk = clk = io.DDRBuffer("o", pins.clk, o_domain="sdram_ps")
        m.d.comb += [clk.o[0].eq(1), clk.o[1].eq(0)]

        if any(r[0] == "wifi_gpio0" for r in platform.resources):
            m.d.comb += platform.request("wifi_gpio0", 0).o.eq(1)
        if len(leds) >= 4:
            m.d.comb += [platform.request("led", 2).o.eq(dram.init_done),
                         platform.request("led", 3).o.eq(dram.init_error | core.pool_error)]
