"""UART host bridge: the register-bus initiator behind ``rast load``.

Protocol: :mod:`rast.model.hostproto` (the host side, shared by the loader and
the simulation tests). The bridge is the only master of the replay block's
register bus (:class:`rast.hdl.registers.BusSignature`).
"""

from amaranth.hdl import Module, Signal, Cat, Const
from amaranth.lib import wiring
from amaranth.lib.fifo import SyncFIFO
from amaranth.lib.wiring import In, Out

from ..hdl.ecp5_primitives import kept_register
from ..hdl.registers import BusSignature
from ..model.hostproto import (CMD_WRITE, CMD_BURST, CMD_READ, CMD_VERSION, ACK, BRIDGE_ID,
                               TX_FIFO_DEPTH)
from .uart import UARTRx, UARTTx

__all__ = ["UARTBridge"]


class UARTBridge(wiring.Component):
    """Parses host frames from ``rx``, drives ``bus``, answers on ``tx``.

    Parameters
    ----------
    addr_width : int
        Width of the register bus address (the frame's 16-bit address is
        truncated to it).
    divisor : int
        Clock cycles per UART bit.
    timeout : int
        Cycles without a received byte after which a partial frame is dropped.

    The bus it drives must never be ready in two clocks running (the replay
    block takes it at most once in TAKE_SPACING clocks).

    Members
    -------
    rx : In(1), tx : Out(1)
        UART lines (8N1, idle high).
    bus : Out(BusSignature(addr_width))
    frames : Out(16)
        Frames executed (wraps), for a status LED or a test.
    """

    def __init__(self, addr_width, divisor, timeout):
        if not isinstance(addr_width, int) or isinstance(addr_width, bool) or not 1 <= addr_width <= 16:
            raise ValueError(f"Address width must be an integer in [1, 16], not {addr_width!r}")
        if not isinstance(timeout, int) or isinstance(timeout, bool) or timeout < 20 * divisor:
            raise ValueError(f"Timeout must be an integer of at least two bytes' time "
                             f"({20 * divisor} cycles), not {timeout!r}")
        self._addr_width = addr_width
        self._divisor = divisor
        self._timeout = timeout
        super().__init__({
            "rx": In(1, init=1),
            "tx": Out(1, init=1),
            "bus": Out(BusSignature(addr_width)),
            "frames": Out(16),
        })

    @property
    def timeout(self):
        return self._timeout

    def elaborate(self, platform):
        m = Module()
        m.submodules.urx = urx = UARTRx(self._divisor)
        m.submodules.utx = utx = UARTTx(self._divisor)
        m.submodules.txq = txq = SyncFIFO(width=8, depth=TX_FIFO_DEPTH)
        m.d.comb += [urx.rx.eq(self.rx), self.tx.eq(utx.tx),
                     utx.data.eq(txq.r_data), utx.valid.eq(txq.r_rdy), txq.r_en.eq(utx.ready)]

        # The received byte a clock later, with its decoding beside it in
        # registers (the byte's compares into the state were a 200 MHz
        # build's late path, 6.1 ns)
        byte, stb = Signal(8), Signal()
        starts_frame, is_version, is_read, is_burst = Signal(), Signal(), Signal(), Signal()
        m.d.sync += [byte.eq(urx.data), stb.eq(urx.stb),
                     starts_frame.eq((urx.data == CMD_WRITE) | (urx.data == CMD_BURST) | (urx.data == CMD_READ)),
                     is_version.eq(urx.data == CMD_VERSION), is_read.eq(urx.data == CMD_READ),
                     is_burst.eq(urx.data == CMD_BURST)]
        cmd_read, cmd_burst = Signal(), Signal()
        # The reply queue has room for a byte in this clock, from a register
        # (the queue's level into the state was a latest path of a
        # 16-channel, 100 MS/s build, 7.1 ns). A byte put in the queue enters
        # it a clock later, from registers (the state's decode into the
        # queue's level was 6.1 ns at 16 channels), so room is counted a
        # clock before for three: the two in flight and this one.
        room = Signal()
        m.d.sync += room.eq(txq.level < TX_FIFO_DEPTH - 2)
        put, put_byte = Signal(), Signal(8)
        tx_put, tx_byte = Signal(), Signal(8)
        m.d.sync += [tx_put.eq(put), tx_byte.eq(put_byte)]
        m.d.comb += [txq.w_en.eq(tx_put), txq.w_data.eq(tx_byte)]
        addr = Signal(16)
        count = Signal(16)
        # count changes a clock after the state decides it, from three
        # strobe registers (the state's decode into the enables of count's
        # 16 bits was among a 16-channel build's late paths, 5.4-5.6 ns);
        # ``byte`` holds until the next byte, many clocks later.
        count_set_one, count_shift, count_down = Signal(), Signal(), Signal()
        m.d.sync += [count_set_one.eq(0), count_shift.eq(0), count_down.eq(0)]
        with m.If(count_set_one):
            m.d.sync += count.eq(1)
        with m.Elif(count_shift):
            m.d.sync += count.eq(Cat(count[8:], byte))
        with m.Elif(count_down):
            m.d.sync += count.eq(count - 1)
        # count == 1, a clock behind count: read only in WRITE, which a DATA
        # byte (many clocks) separates from every change of count
        count_one = Signal()
        m.d.sync += count_one.eq(count == 1)
        # count's high byte is 0, a clock behind count: read only with the
        # count's second byte, a byte after its first (a burst of no words
        # is answered at once; the 16-bit compare in front of the state was
        # among a 16-channel build's late paths)
        count_hi_zero = Signal()
        m.d.sync += count_hi_zero.eq(count[8:] == 0)
        # ... and with the byte now received: a burst of no words (one flag
        # register into the state, not two)
        burst_empty = Signal()
        m.d.sync += burst_empty.eq(count_hi_zero & (urx.data == 0))
        # ``data`` gathers a write's bytes, ``reply`` holds the answer: each
        # register loaded in one state only (one register for both, loaded in
        # three states, was a two-pipeline build's worst path, 5.9 ns).
        # ``reply`` loads on registers alone: a read's answer wherever it
        # comes (only in READ_DATA: the bus answers the bridge's read only),
        # the version in VERSION, from a flag set on the way in (the state's
        # decode into its 32 enables was a 64-channel build's late path,
        # 5.8 ns).
        data = Signal(32)
        reply = Signal(32)
        load_version = Signal()
        n = Signal(2)
        # ``timed_out`` is ``idle == timeout``, from a register of its own (the
        # 16-bit compare in front of the state was a 200 MHz build's worst path)
        idle = Signal(range(self._timeout + 1))
        timed_out = Signal()
        with m.If(stb):
            m.d.sync += [idle.eq(0), timed_out.eq(0)]
        with m.Elif(~timed_out):
            m.d.sync += [idle.eq(idle + 1), timed_out.eq(idle == self._timeout - 1)]

        # Every bus output comes straight from a flip-flop: the bus fans out to
        # all channels' registers across the device (timing, see docs/bitstream.md).
        bus = self.bus
        # The write data has a register of its own: the shift register ``data``
        # also takes read answers and feeds the reply, and as the bus's data
        # (placed by the registers it feeds) it closed a 7.6 ns path from the
        # reply FIFO's level through its input multiplexer.
        w_stb = Signal()
        r_stb = Signal()
        # w_data follows the gathered bytes while no write waits, and holds
        # while one does (its enable one flip-flop: the state's decode into
        # the enables of w_data, placed by the register file, was among a
        # 64-channel build's late paths, 5.8 ns)
        w_data = Signal(32)
        with m.If(~w_stb):
            m.d.sync += w_data.eq(Cat(data[8:], byte))
        m.d.comb += [bus.addr.eq(addr), bus.w_data.eq(w_data), bus.w_stb.eq(w_stb),
                     bus.r_stb.eq(r_stb)]
        # The bus's ready, r_valid and r_data are acted on a clock late, from
        # registers of the bridge's own: they come from the register file
        # across the device, and straight into the state they were among the
        # 200 MHz builds' late paths (docs/bitstream.md). The strobe stays
        # high a clock after the take, a clock in which ready is low (the bus
        # is never ready in two clocks running). ``taken`` and ``r_valid``
        # are kept: as plain registers Yosys merged ``taken`` with the
        # register file's first stage's valid (the same input), placed by
        # the register file, and from there into the state's enable was
        # among the 16-channel builds' late paths (5.1 ns).
        r_data = Signal(32)
        taken = kept_register(m, platform, bus.ready & (w_stb | r_stb), "taken", reset=True)
        r_valid = kept_register(m, platform, bus.r_valid, "r_valid", reset=True)
        m.d.sync += r_data.eq(bus.r_data)

        with m.If(r_valid):
            m.d.sync += reply.eq(r_data)
        with m.Elif(load_version):
            m.d.sync += reply.eq(BRIDGE_ID)

        with m.FSM():
            with m.State("IDLE"):
                with m.If(stb):
                    m.d.sync += [cmd_read.eq(is_read), cmd_burst.eq(is_burst), n.eq(0)]
                    with m.If(starts_frame):
                        m.next = "ADDR"
                    with m.Elif(is_version):
                        m.d.sync += load_version.eq(1)
                        m.next = "VERSION"
            with m.State("VERSION"):
                m.d.sync += load_version.eq(0)
                m.next = "REPLY"
            with m.State("ADDR"):
                with m.If(timed_out):
                    m.next = "IDLE"
                with m.Elif(stb):
                    m.d.sync += [addr.eq(Cat(addr[8:], byte)), n.eq(n + 1)]
                    with m.If(n == 1):
                        m.d.sync += n.eq(0)
                        with m.If(cmd_read):
                            m.d.sync += r_stb.eq(1)
                            m.next = "READ"
                        with m.Elif(cmd_burst):
                            m.next = "COUNT"
                        with m.Else():
                            m.d.sync += count_set_one.eq(1)
                            m.next = "DATA"
            with m.State("COUNT"):
                with m.If(timed_out):
                    m.next = "IDLE"
                with m.Elif(stb):
                    m.d.sync += [count_shift.eq(1), n.eq(n + 1)]
                    with m.If(n == 1):
                        m.d.sync += n.eq(0)
                        with m.If(burst_empty):
                            m.next = "ACK"
                        with m.Else():
                            m.next = "DATA"
            with m.State("DATA"):
                with m.If(timed_out):
                    m.next = "IDLE"
                with m.Elif(stb):
                    m.d.sync += [data.eq(Cat(data[8:], byte)), n.eq(n + 1)]
                    with m.If(n == 3):
                        m.d.sync += w_stb.eq(1)
                        m.next = "WRITE"
            with m.State("WRITE"):                   # w_stb is high until the block takes it
                with m.If(taken):
                    m.d.sync += [w_stb.eq(0), count_down.eq(1)]
                    with m.If(count_one):
                        m.next = "ACK"
                    with m.Else():
                        m.next = "DATA"
            with m.State("READ"):                    # r_stb is high until the block takes it
                with m.If(taken):
                    m.d.sync += r_stb.eq(0)
                    m.next = "READ_DATA"
            with m.State("READ_DATA"):
                with m.If(r_valid):
                    m.next = "REPLY"
            with m.State("REPLY"):
                # the byte selected by n, the word held: the reply queue's
                # readiness enables two bits, not the whole word (bridge.data
                # was among the 200 MHz build's late endpoints)
                m.d.comb += [put_byte.eq(reply.word_select(n, 8)), put.eq(room)]
                with m.If(room):
                    m.d.sync += n.eq(n + 1)
                    with m.If(n == 3):
                        m.d.sync += [n.eq(0), self.frames.eq(self.frames + 1)]
                        m.next = "IDLE"
            with m.State("ACK"):
                m.d.comb += [put_byte.eq(ACK), put.eq(room)]
                with m.If(room):
                    m.d.sync += self.frames.eq(self.frames + 1)
                    m.next = "IDLE"
        return m
