"""Board top: PLL, ADC/DAC I/Q ports, UART host bridge and the replay block.

:class:`ReplaySystem` is the board-independent part (bridge + replay block);
the simulation tests drive it directly. :class:`SampleIO` is the board's
sample path around it (DDR cells and one fabric register each way),
:class:`BoardCore` the two together: everything of the board but the PLL,
which is what ``tests/test_cosim_board_io.py`` simulates with a clock from
the testbench. :class:`BoardTop` adds the clocking, the pins and the LEDs of
a board (:mod:`rast.gateware.platforms`).

Sample interface to an ADC/DAC daughterboard (pin map: ``docs/bitstream.md``):
I and Q share one 16-bit bus per direction, double data rate: I on the
rising edge, Q on the falling edge of the sample clock. The board drives the
ADC's and the DAC's sample clock (``adc_clk``, ``dac_clk``: the sample clock
forwarded through an ``ODDRX1F``, so it is edge-aligned with the DAC data;
converters sample on the clock's falling/rising edge respectively, see the
pin map), and ``dac_iq`` high marks the I half of each sample.
"""

from amaranth.hdl import Elaboratable, Module, Signal, ClockSignal, Const, Mux, signed
from amaranth.lib import io, wiring, stream
from amaranth.lib.wiring import In, Out

from ..hdl.iq import IQ
from ..hdl.replay_top import WindFarmReplay
from ..model.fixedpoint import INPUT_WIDTH, OUTPUT_WIDTH, PIN_LAG
from ..model.hostproto import DEFAULT_BAUD
from .bridge import UARTBridge
from .pll import ECP5PLL, pll_params
from .uart import divisor as uart_divisor

__all__ = ["ReplaySystem", "SampleIO", "BoardCore", "BoardTop", "DEFAULT_BAUD"]

DEFAULT_TIMEOUT_S = 0.02


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
        return m


class SampleIO(wiring.Component):
    """The board's sample path outside the replay block: ADC pins to a sample
    stream, a sample stream to DAC pins, and the converters' clocks, all in
    the fabric clock domain.

    The converters run at the sample rate, f_clk / ``slots``. Their clocks
    (``adc_clk``, ``dac_clk``) and the DAC's I marker (``dac_iq``) are made
    from the replay block's slot counter: a pattern high for the first
    ``slots`` half clocks of each period (the first half of the sample), low
    for the rest, registered and driven through an ``ODDRX1F`` like the DAC's
    data, so clocks and data leave the pins together (at ``slots`` = 1 it is
    the fabric clock forwarded). No clock crosses to another domain.

    ADC: one ``io.DDRBuffer`` (an ``IDDRX1F`` per pin, taking the pins on
    every rising and falling edge of the fabric clock); the I half of sample k
    is the pins' value at the k-th rising edge of ``adc_clk`` as driven, the Q
    half at its falling edge. Both go into one register, offered to the block
    until it takes them. DAC: the block's output is taken once per period
    (``dac.ready`` in its last clock) into a register, and driven I while
    ``dac_clk`` is high, Q while it is low.

    Latency, ADC pin sample to DAC pin sample, in samples:
    ``rast.model.fixedpoint.board_latency`` (checked by
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
        m.submodules.dac_data = dac_data = io.DDRBuffer("o", self._dac.data, o_domain=d)
        m.submodules.dac_clk = dac_clk = io.DDRBuffer("o", self._dac.clk, o_domain=d)
        m.submodules.dac_iq = dac_iq = io.DDRBuffer("o", self._dac.iq, o_domain=d)

        # The pattern's two half clocks of this slot, registered: high while
        # the half clock's index within the period is below M.
        hi0, hi1 = Signal(), Signal()
        m.d[d] += [hi0.eq(2 * self.slot < M), hi1.eq(2 * self.slot + 1 < M)]
        for cell in (adc_clk, dac_clk, dac_iq):
            m.d.comb += [cell.o[0].eq(hi0), cell.o[1].eq(hi1)]

        # ADC: the pin clock's rising edge is PIN_LAG clocks after the slot-0
        # clock that made it; the IDDRX1F shows a pin sample the clock after.
        i_at, q_at = (PIN_LAG + 1) % M, (PIN_LAG + 1 + M // 2) % M
        q_bit = 1 if M % 2 else 0          # odd M: Q is the falling-edge sample
        i_held = Signal(signed(INPUT_WIDTH))
        x = Signal(IQ(INPUT_WIDTH))
        valid = Signal()
        with m.If(self.slot == i_at):
            m.d[d] += i_held.eq(adc_data.i[0])
        with m.If(self.slot == q_at):
            m.d[d] += [x.re.eq(adc_data.i[0] if M == 1 else i_held), x.im.eq(adc_data.i[q_bit]),
                       valid.eq(1)]
        with m.Elif(self.adc.ready):
            m.d[d] += valid.eq(0)
        m.d.comb += [self.adc.payload.eq(x), self.adc.valid.eq(valid)]

        # DAC: one sample per period, taken in its last clock, I then Q.
        y = Signal(IQ(OUTPUT_WIDTH))
        m.d.comb += self.dac.ready.eq(self.slot == M - 1)
        with m.If(self.dac.ready):
            m.d[d] += y.eq(Mux(self.dac.valid, self.dac.payload, 0))
        d0, d1 = Signal(signed(OUTPUT_WIDTH)), Signal(signed(OUTPUT_WIDTH))
        m.d[d] += [d0.eq(Mux(2 * self.slot < M, y.re, y.im)),
                   d1.eq(Mux(2 * self.slot + 1 < M, y.re, y.im))]
        m.d.comb += [dac_data.o[0].eq(d0), dac_data.o[1].eq(d1)]
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
    """

    def __init__(self, clk_hz, adc_port, dac_port, baud=DEFAULT_BAUD, *, divisor=None, timeout=None,
                 **replay_kwargs):
        slots = replay_kwargs.get("slots", 1)
        replay_kwargs.setdefault("sample_rate_hz", round(clk_hz / slots))
        self.system = ReplaySystem(clk_hz, baud, divisor=divisor, timeout=timeout, **replay_kwargs)
        self.sample_io = SampleIO(adc_port, dac_port, slots)
        super().__init__({"rx": In(1, init=1), "tx": Out(1, init=1), "overflow": Out(1)})

    def elaborate(self, platform):
        m = Module()
        m.submodules.system = sys_ = self.system
        m.submodules.sample_io = sio = self.sample_io
        wiring.connect(m, sio.adc, sys_.i)
        wiring.connect(m, sys_.o, sio.dac)
        m.d.comb += [sys_.rx.eq(self.rx), self.tx.eq(sys_.tx), self.overflow.eq(sys_.overflow),
                     sio.slot.eq(sys_.replay.slot)]
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
    """

    def __init__(self, clock_mhz=100.0, baud=DEFAULT_BAUD, **replay_kwargs):
        self.clock_mhz = float(clock_mhz)
        self.baud = baud
        self.replay_kwargs = replay_kwargs
        self.system = None
        self.core = None
        self.pll = None

    def elaborate(self, platform):
        m = Module()
        clk_res = platform.lookup(platform.default_clk)
        f_in = clk_res.clock.frequency / 1e6
        clk_in = platform.request(platform.default_clk, 0)
        self.pll = pll_params(f_in, self.clock_mhz)
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

        # Status LEDs, where the board has them: overflow (sticky), PLL lock.
        leds = [r for r in platform.resources if r[0] == "led"]
        if len(leds) >= 2:
            m.d.comb += [platform.request("led", 0).o.eq(core.overflow),
                         platform.request("led", 1).o.eq(pll.locked)]
        return m
