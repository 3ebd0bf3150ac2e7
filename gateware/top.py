"""Board top: PLL, ADC/DAC I/Q ports, UART host bridge and the replay block.

:class:`ReplaySystem` is the board-independent part (bridge + replay block);
the simulation tests drive it directly. :class:`BoardTop` adds the clocking
and the I/O of a board (:mod:`rast.gateware.platforms`).

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
from ..model.fixedpoint import INPUT_WIDTH, OUTPUT_WIDTH
from .bridge import UARTBridge
from .pll import ECP5PLL, pll_params
from .uart import divisor as uart_divisor

__all__ = ["ReplaySystem", "BoardTop", "DEFAULT_BAUD"]

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
        Passed to :class:`WindFarmReplay` (``channels``, ``stream_depth``, ...).

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


class BoardTop(Elaboratable):
    """The replay system on an ECP5 board.

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
        self.pll = None

    def elaborate(self, platform):
        m = Module()
        clk_res = platform.lookup(platform.default_clk)
        f_in = clk_res.clock.frequency / 1e6
        clk_in = platform.request(platform.default_clk, 0)
        self.pll = pll_params(f_in, self.clock_mhz)
        m.submodules.pll = pll = ECP5PLL(clk_in.i, self.pll, domain="sync")
        f = self.pll.f_out_mhz * 1e6
        # The SAMPLE_RATE register states the rate the PLL really makes.
        self.system = sys_ = ReplaySystem(f, self.baud, sample_rate_hz=round(f), **self.replay_kwargs)
        m.submodules.system = sys_

        uart = platform.request("uart", 0)
        m.d.comb += [sys_.rx.eq(uart.rx.i), uart.tx.o.eq(sys_.tx)]

        adc = platform.request("rts_adc", 0, dir="-")
        dac = platform.request("rts_dac", 0, dir="-")
        m.submodules.adc_data = adc_data = io.DDRBuffer("i", adc.data, i_domain="sync")
        m.submodules.adc_clk = adc_clk = io.DDRBuffer("o", adc.clk, o_domain="sync")
        m.submodules.dac_data = dac_data = io.DDRBuffer("o", dac.data, o_domain="sync")
        m.submodules.dac_clk = dac_clk = io.DDRBuffer("o", dac.clk, o_domain="sync")
        m.submodules.dac_iq = dac_iq = io.DDRBuffer("o", dac.iq, o_domain="sync")
        m.d.comb += [adc_clk.o[0].eq(1), adc_clk.o[1].eq(0),
                     dac_clk.o[0].eq(1), dac_clk.o[1].eq(0),
                     dac_iq.o[0].eq(1), dac_iq.o[1].eq(0)]

        # Registered at the I/O: the DDR cells, then one fabric register each way.
        x = Signal(IQ(INPUT_WIDTH))
        m.d.sync += [x.re.eq(adc_data.i[0]), x.im.eq(adc_data.i[1])]
        m.d.comb += [sys_.i.payload.eq(x), sys_.i.valid.eq(1), sys_.o.ready.eq(1)]
        y = Signal(IQ(OUTPUT_WIDTH))
        with m.If(sys_.o.valid):
            m.d.sync += y.eq(sys_.o.payload)
        m.d.comb += [dac_data.o[0].eq(y.re), dac_data.o[1].eq(y.im)]

        # Status LEDs, where the board has them: overflow (sticky), PLL lock.
        leds = [r for r in platform.resources if r[0] == "led"]
        if len(leds) >= 2:
            m.d.comb += [platform.request("led", 0).o.eq(sys_.overflow),
                         platform.request("led", 1).o.eq(pll.locked)]
        return m
