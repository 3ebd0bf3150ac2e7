"""8N1 UART transmitter and receiver, one clock domain, fixed divisor."""

from amaranth.hdl import Module, Signal, Cat, Const
from amaranth.lib import wiring
from amaranth.lib.cdc import FFSynchronizer
from amaranth.lib.wiring import In, Out

__all__ = ["UARTRx", "UARTTx", "divisor"]


def divisor(clk_hz: float, baud: int) -> int:
    """Clock cycles per bit, ``round(clk_hz / baud)``; rejects rates off by over 2 %."""
    if not isinstance(baud, int) or isinstance(baud, bool) or baud <= 0:
        raise TypeError(f"Baud rate must be a positive integer, not {baud!r}")
    d = round(clk_hz / baud)
    if d < 4:
        raise ValueError(f"Baud rate {baud} is too fast for a {clk_hz / 1e6:g} MHz clock "
                         f"(needs at least 4 cycles per bit)")
    err = abs(clk_hz / d - baud) / baud
    if err > 0.02:
        raise ValueError(f"Baud rate {baud} is {err:.1%} off with a {clk_hz / 1e6:g} MHz clock "
                         f"(divisor {d}); at most 2 % is allowed")
    return d


#: The fewest clocks per bit the receiver and transmitter take (the
#: simulations' line runs at this, the fastest).
MIN_DIVISOR = 4


def _check_divisor(divisor):
    if not isinstance(divisor, int) or isinstance(divisor, bool) or divisor < MIN_DIVISOR:
        raise ValueError(f"UART divisor must be an integer of at least {MIN_DIVISOR}, not {divisor!r}")

class UARTRx(wiring.Component):
    """Receiver: ``data`` is valid in the cycle ``stb`` is high (and until the
    next frame's first data bit).

    The line goes through a two-register synchroniser and one more register
    (which the placer can put beside the receiver rather than beside the
    pin); a start bit is confirmed at its middle, each data bit sampled at
    its middle, and a frame without its stop bit is dropped (``err``
    pulses). The bit timer's expiry is a flag registered a clock ahead
    (the timer only reaches 0 by counting down from 1): its compare and
    the data register's enables in one clock were the latest path of a
    200 MHz build (7.1 ns).

    Members
    -------
    rx : In(1)
        The line (idle high).
    data : Out(8)
    stb : Out(1)
    err : Out(1)
    """

    rx: In(1, init=1)
    data: Out(8)
    stb: Out(1)
    err: Out(1)

    def __init__(self, divisor):
        _check_divisor(divisor)
        self._divisor = divisor
        super().__init__()

    def elaborate(self, platform):
        m = Module()
        d = self._divisor
        synced = Signal(init=1)
        m.submodules.sync = FFSynchronizer(self.rx, synced, init=1)
        rx = Signal(init=1)
        m.d.sync += rx.eq(synced)
        timer = _BitTimer(m, d)
        bits = Signal(4)
        shreg = Signal(8)
        # The pulses in registers without the domain's reset (the FSM is
        # reset to IDLE, so they are 0 from a reset's second clock on): with
        # it, the reset and the stop bit's decode met in a LUT into the
        # register's LSR, which the placer put 47 rows from the register at
        # seed 1 of the 64-channel build (7.6 ns, its only failing path).
        stb, err = Signal(name="stb_q", reset_less=True), Signal(name="err_q", reset_less=True)
        m.d.comb += [self.stb.eq(stb), self.err.eq(err)]
        m.d.sync += [stb.eq(0), err.eq(0)]
        # ``data`` follows the shift register, without an enable (the stop
        # bit's decode into the enables of its 8 bits was among a
        # 64-channel build's late paths, 5.5 ns): in STOP, the clock before
        # ``stb``, the register holds the frame's byte, and it shifts again
        # only a bit and a half after the stop bit's middle.
        m.d.sync += self.data.eq(shreg)
        # The shift's enable, a register of its own set a clock ahead (in
        # DATA, exactly when the timer expires there): from the state's
        # decode and the expiry into its 8 enables was a 64-channel build's
        # latest path at seed 1 (5.8 ns).
        shift = Signal()
        m.d.sync += shift.eq(0)
        with m.If(shift):
            m.d.sync += shreg.eq(Cat(shreg[1:], rx))
        with m.FSM():
            with m.State("IDLE"):
                with m.If(~rx):
                    timer.load(d // 2 - 1)
                    m.next = "START"
            with m.State("START"):
                with m.If(timer.expired):
                    with m.If(rx):
                        m.next = "IDLE"               # a glitch, not a start bit
                    with m.Else():
                        timer.load(d - 1)
                        m.d.sync += bits.eq(0)
                        m.next = "DATA"
                with m.Else():
                    timer.count()
            with m.State("DATA"):
                with m.If(timer.expired):
                    timer.load(d - 1)
                    m.d.sync += bits.eq(bits + 1)
                    with m.If(bits == 7):
                        m.next = "STOP"
                with m.Else():
                    timer.count()
                    m.d.sync += shift.eq(timer.value == 1)
            with m.State("STOP"):
                with m.If(timer.expired):
                    with m.If(rx):
                        m.d.sync += stb.eq(1)
                    with m.Else():
                        m.d.sync += err.eq(1)
                    m.next = "IDLE"
                with m.Else():
                    timer.count()
        return m


class _BitTimer:
    """A down-counter of clocks with its expiry (the count at 0) as a
    register of its own, set a clock ahead from ``count == 1``: every load
    is of at least 1, so the count reaches 0 only by counting down."""

    def __init__(self, m, divisor):
        self._m = m
        self.value = Signal(range(divisor))
        self.expired = Signal(init=1)

    def load(self, clocks):
        assert clocks >= 1
        self._m.d.sync += [self.value.eq(clocks), self.expired.eq(0)]

    def count(self):
        self._m.d.sync += [self.value.eq(self.value - 1), self.expired.eq(self.value == 1)]


class UARTTx(wiring.Component):
    """Transmitter: a byte is taken in a clock with ``ready``, which is high
    when the line is idle and ``valid`` was up in the clock before (``valid``
    goes through a register of its own, so it must stay up until its byte is
    taken, as a FIFO's ``r_rdy`` does; a clock with ``ready`` then has
    ``valid`` too).

    Members
    -------
    data : In(8)
    valid : In(1)
    ready : Out(1)
    tx : Out(1)
        The line (idle high).
    """

    data: In(8)
    valid: In(1)
    ready: Out(1)
    tx: Out(1, init=1)

    def __init__(self, divisor):
        _check_divisor(divisor)
        self._divisor = divisor
        super().__init__()

    def elaborate(self, platform):
        m = Module()
        d = self._divisor
        timer = _BitTimer(m, d)
        shreg = Signal(10, init=0x3FF)
        left = Signal(4)
        # ready is left == 0, a register of its own set with the last bit's
        # count (the compare into the reply queue's level, through its read
        # enable, was among a 200 MHz build's late paths)
        idle = Signal(init=1)
        # valid a clock late, from a register (the reply queue's level
        # through its r_rdy into the shift register's enables was among the
        # 16-channel build's late paths, 4.97-5.15 ns): the shift register
        # loads from two flip-flops. A byte is at least ten bit times long,
        # so the next take sees a valid that is current.
        valid = Signal()
        m.d.sync += valid.eq(self.valid)
        take = Signal()
        m.d.comb += [take.eq(idle & valid), self.ready.eq(take)]
        # the line from a register of its own, a clock behind the shift
        # register, free to sit by the pin (as the shift register's bit,
        # enabled from the bit timer, it was among the 16-channel build's
        # paths at 4.9-5.0 ns)
        m.d.sync += self.tx.eq(shreg[0])
        with m.If(idle):
            with m.If(take):
                m.d.sync += [shreg.eq(Cat(Const(0, 1), self.data, Const(1, 1))), left.eq(10), idle.eq(0)]
                timer.load(d - 1)
        with m.Elif(timer.expired):
            m.d.sync += [shreg.eq(Cat(shreg[1:], Const(1, 1))), left.eq(left - 1), idle.eq(left == 1)]
            timer.load(d - 1)
        with m.Else():
            timer.count()
        return m
