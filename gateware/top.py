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

from amaranth.hdl import Elaboratable, Module, Signal, ClockSignal, Const
from amaranth.lib import io, wiring, stream
from amaranth.lib.wiring import In, Out

from ..hdl.iq import IQ
from ..hdl.replay_top import WindFarmReplay
from ..model.fixedpoint import INPUT_WIDTH, OUTPUT_WIDTH, BOARD_INPUT_LATENCY, BOARD_OUTPUT_LATENCY
from .bridge import UARTBridge
from .pll import ECP5PLL, pll_params
from .uart import divisor as uart_divisor

__all__ = ["ReplaySystem", "SampleIO", "BoardCore", "BoardTop", "DEFAULT_BAUD"]

DEFAULT_BAUD = 1_000_000      # exact on the ULX3S's FT231X (3 MHz / 3)
DEFAULT_TIMEOUT_S = 0.02


class ReplaySystem(wiring.Component):
    """UART bridge mastering the register bus of a :class:`WindFarmReplay`.

    Parameters
    ----------
    clk_hz : float
        Sample clock (sets the UART divisor and the frame timeout).
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
    stream, a sample stream to DAC pins, and the converters' clocks.

    ADC: one ``io.DDRBuffer`` (an ``IDDRX1F`` per pin on the ECP5; I is the
    rising-edge half, Q the falling-edge half), then one fabric register.
    DAC: one fabric register, then one ``io.DDRBuffer`` (``ODDRX1F``: I while
    the clock is high, Q while it is low). ``adc_clk``, ``dac_clk`` and
    ``dac_iq`` are constant 1/0 pairs through ``ODDRX1F``: the sample clock
    forwarded, and the I-half marker. Continuous: ``adc.valid`` is always 1,
    ``dac.ready`` always 1.

    Latency (sample clocks, ``rast.model.fixedpoint``): ADC pin sample to the
    edge at which a consumer of ``adc`` takes it, ``BOARD_INPUT_LATENCY`` (3);
    from the edge at which the producer of ``dac`` loads its output register
    to the DAC pin sample, ``BOARD_OUTPUT_LATENCY`` (4).

    Parameters
    ----------
    adc_port, dac_port :
        Objects with I/O ports ``data`` (16 bits) and ``clk``, and for the DAC
        also ``iq``: the ``rts_adc``/``rts_dac`` resources requested with
        ``dir="-"``, or ``io.SingleEndedPort`` s in a simulation.
    domain : str
        The sample clock domain.

    Members
    -------
    adc : Out(stream.Signature(IQ(16)))
    dac : In(stream.Signature(IQ(16)))
    """

    input_latency = BOARD_INPUT_LATENCY
    output_latency = BOARD_OUTPUT_LATENCY

    def __init__(self, adc_port, dac_port, domain="sync"):
        self._adc, self._dac, self._domain = adc_port, dac_port, domain
        super().__init__({
            "adc": Out(stream.Signature(IQ(INPUT_WIDTH))),
            "dac": In(stream.Signature(IQ(OUTPUT_WIDTH))),
        })

    def elaborate(self, platform):
        m = Module()
        d = self._domain
        m.submodules.adc_data = adc_data = io.DDRBuffer("i", self._adc.data, i_domain=d)
        m.submodules.adc_clk = adc_clk = io.DDRBuffer("o", self._adc.clk, o_domain=d)
        m.submodules.dac_data = dac_data = io.DDRBuffer("o", self._dac.data, o_domain=d)
        m.submodules.dac_clk = dac_clk = io.DDRBuffer("o", self._dac.clk, o_domain=d)
        m.submodules.dac_iq = dac_iq = io.DDRBuffer("o", self._dac.iq, o_domain=d)
        m.d.comb += [adc_clk.o[0].eq(1), adc_clk.o[1].eq(0),
                     dac_clk.o[0].eq(1), dac_clk.o[1].eq(0),
                     dac_iq.o[0].eq(1), dac_iq.o[1].eq(0)]

        # Registered at the I/O: the DDR cells, then one fabric register each way.
        x = Signal(IQ(INPUT_WIDTH))
        m.d[d] += [x.re.eq(adc_data.i[0]), x.im.eq(adc_data.i[1])]
        m.d.comb += [self.adc.payload.eq(x), self.adc.valid.eq(1), self.dac.ready.eq(1)]
        y = Signal(IQ(OUTPUT_WIDTH))
        with m.If(self.dac.valid):
            m.d[d] += y.eq(self.dac.payload)
        m.d.comb += [dac_data.o[0].eq(y.re), dac_data.o[1].eq(y.im)]
        return m


class BoardCore(wiring.Component):
    """Everything of :class:`BoardTop` but the PLL, the pin requests and the
    LEDs: :class:`SampleIO` feeding a :class:`ReplaySystem`, in domain ``sync``.

    Parameters
    ----------
    clk_hz : float
        Sample clock (UART divisor, frame timeout, ``SAMPLE_RATE`` register
        unless ``sample_rate_hz`` is given).
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
        replay_kwargs.setdefault("sample_rate_hz", round(clk_hz))
        self.system = ReplaySystem(clk_hz, baud, divisor=divisor, timeout=timeout, **replay_kwargs)
        self.sample_io = SampleIO(adc_port, dac_port)
        super().__init__({"rx": In(1, init=1), "tx": Out(1, init=1), "overflow": Out(1)})

    def elaborate(self, platform):
        m = Module()
        m.submodules.system = sys_ = self.system
        m.submodules.sample_io = sio = self.sample_io
        wiring.connect(m, sio.adc, sys_.i)
        wiring.connect(m, sys_.o, sio.dac)
        m.d.comb += [sys_.rx.eq(self.rx), self.tx.eq(sys_.tx), self.overflow.eq(sys_.overflow)]
        return m


class BoardTop(Elaboratable):
    """The replay system on an ECP5 board: PLL, pins, :class:`BoardCore`, LEDs.

    Parameters
    ----------
    clock_mhz : float
        RTS sample clock made by the PLL.
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
        self.core = core = BoardCore(f, adc, dac, self.baud, sample_rate_hz=round(f),
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
