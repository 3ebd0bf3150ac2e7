"""UART host bridge: the register-bus initiator behind ``rast load``.

Protocol: :mod:`rast.model.contract.hostproto` (the host side, shared by the loader and
the simulation tests). The bridge is the only master of the replay block's
register bus (:class:`rast.hdl.registers.BusSignature`).
"""

from types import SimpleNamespace

from amaranth.hdl import Module, Signal, Cat, Mux
from amaranth.lib import wiring
from amaranth.lib.fifo import SyncFIFO
from amaranth.lib.wiring import In, Out

from ..hdl.ecp5_primitives import kept_register
from ..hdl.registers import BusSignature
from rast.model.contract.hostproto import (CMD_WRITE, CMD_BURST, CMD_READ, CMD_VERSION, ACK, BRIDGE_ID,
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
        env = SimpleNamespace(m=m, platform=platform)
        self._line(env)
        self._fields(env)
        self._bus(env)
        self._states(env)
        return m

    def _line(self, env):
        """The UART's receiver, transmitter and reply queue; the received byte
        and its decoding a clock later; the queue's room and its input."""
        m = env.m
        m.submodules.urx = urx = UARTRx(self._divisor)
        m.submodules.utx = utx = UARTTx(self._divisor)
        m.submodules.txq = txq = SyncFIFO(width=8, depth=TX_FIFO_DEPTH)
        m.d.comb += [urx.rx.eq(self.rx), self.tx.eq(utx.tx),
                     utx.data.eq(txq.r_data), utx.valid.eq(txq.r_rdy), txq.r_en.eq(utx.ready)]

        # The received byte a clock later, with its decoding beside it in
        # registers (the byte's compares into the state were a 200 MHz
        # build's late path, 6.1 ns)
        byte, stb = Signal(8), Signal()
        go_frame, go_version, is_read, is_burst = Signal(), Signal(), Signal(), Signal()
        m.d.sync += [byte.eq(urx.data), stb.eq(urx.stb),
                     go_frame.eq(urx.stb & ((urx.data == CMD_WRITE) | (urx.data == CMD_BURST)
                                            | (urx.data == CMD_READ))),
                     go_version.eq(urx.stb & (urx.data == CMD_VERSION)), is_read.eq(urx.data == CMD_READ),
                     is_burst.eq(urx.data == CMD_BURST)]
        cmd_read, cmd_burst, cmd_write = Signal(), Signal(), Signal()
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
        env.__dict__.update(urx=urx, txq=txq, byte=byte, stb=stb, go_frame=go_frame, go_version=go_version,
                            is_read=is_read, is_burst=is_burst, cmd_read=cmd_read, cmd_burst=cmd_burst,
                            cmd_write=cmd_write, room=room, put=put, put_byte=put_byte)

    def _fields(self, env):
        """A frame's fields: the address, the word count, the bytes taken of
        a field (``nh``), the write's data, the reply, the timeout."""
        m, urx, byte, stb = env.m, env.urx, env.byte, env.stb
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
        # ``nh`` counts a field's bytes, one-hot (``nh[k]``: k bytes of the
        # field taken). The byte's arrival is registered with nh's value
        # beside it: nh changes only a clock after a byte (bytes are many
        # clocks apart), so it is the same a clock later. The count's second
        # byte also says whether the burst has no words (both bytes 0): one
        # flag register into the state. No reset of its own: the reset puts
        # the state in idle, which sets nh the next clock, long before a byte
        # (the reset global into nh's logic was a 64-channel build's latest
        # path, 5.5 ns of routing).
        nh = Signal(4, init=1, reset_less=True)
        byte_n1, byte_n3, byte_n1_empty, byte_n1_more = (Signal(name=f"byte_{flag}")
                                                         for flag in ("n1", "n3", "n1_empty", "n1_more"))
        count_zero = count_hi_zero & (urx.data == 0)
        m.d.sync += [byte_n1.eq(urx.stb & nh[1]), byte_n3.eq(urx.stb & nh[3]),
                     byte_n1_empty.eq(urx.stb & nh[1] & count_zero),
                     byte_n1_more.eq(urx.stb & nh[1] & ~count_zero)]
        # ``data`` gathers a write's bytes, ``reply`` holds the answer: each
        # register loaded in one state only (one register for both, loaded in
        # three states, was a two-pipeline build's worst path, 5.9 ns).
        # ``reply`` loads on registers alone: a read's answer wherever it
        # comes (only in READ_DATA: the bus answers the bridge's read only),
        # the version in VERSION, from the state's own flip-flop (a decode
        # of the state into its 32 enables was a 64-channel build's late
        # path, 5.8 ns).
        data = Signal(32)
        reply = Signal(32)
        rh = Signal(4, init=1)
        # ``timed_out``: ``timeout`` clocks without a byte. It is the sign bit
        # of a count down from timeout - 1 (-1 after ``timeout`` clocks), the
        # carry chain's own last bit: no compare behind the count (a 16-bit
        # compare into the state was a 200 MHz build's worst path; registered
        # into a flag of its own, it was still a 16-channel build's latest
        # path, 5.10 ns, 3.7 of it routing)
        idle_left = Signal(range(-1, self._timeout), init=self._timeout - 1)
        timed_out = idle_left[-1]
        with m.If(stb):
            m.d.sync += idle_left.eq(self._timeout - 1)
        with m.Elif(~timed_out):
            m.d.sync += idle_left.eq(idle_left - 1)
        env.__dict__.update(addr=addr, count_set_one=count_set_one, count_shift=count_shift,
                            count_down=count_down, count_one=count_one, nh=nh, byte_n1=byte_n1,
                            byte_n3=byte_n3, byte_n1_empty=byte_n1_empty, byte_n1_more=byte_n1_more,
                            data=data, reply=reply, rh=rh, timed_out=timed_out)

    def _bus(self, env):
        """The register bus's outputs from flip-flops, its answers registered."""
        m, platform, addr, data, byte = env.m, env.platform, env.addr, env.data, env.byte
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
        env.__dict__.update(w_stb=w_stb, r_stb=r_stb, r_data=r_data, taken=taken, r_valid=r_valid)

    def _states(self, env):
        """The frame's state machine and what each state does."""
        m, e = env.m, env
        (byte, stb, go_frame, go_version, is_read, is_burst, cmd_read, cmd_burst, cmd_write, room, put,
         put_byte) = (e.byte, e.stb, e.go_frame, e.go_version, e.is_read, e.is_burst, e.cmd_read, e.cmd_burst,
                      e.cmd_write, e.room, e.put, e.put_byte)
        (addr, count_set_one, count_shift, count_down, count_one, nh, byte_n1, byte_n3, byte_n1_empty,
         byte_n1_more, data, reply, rh, timed_out) = (e.addr, e.count_set_one, e.count_shift, e.count_down,
                                                    e.count_one, e.nh, e.byte_n1, e.byte_n3, e.byte_n1_empty,
                                                    e.byte_n1_more, e.data, e.reply, e.rh, e.timed_out)
        w_stb, r_stb, r_data, taken, r_valid = e.w_stb, e.r_stb, e.r_data, e.taken, e.r_valid
        # The state, one flip-flop per state (one-hot), each written as its
        # own equation: Amaranth's FSM gives no documented control of its
        # encoding, and as a 4-bit binary state behind enables the next state
        # was three LUT levels from nine registers, among the 16-channel
        # builds' late paths (5.0-5.35 ns). Each bit below is one or two levels,
        # DATA's three.
        s_idle = Signal(init=1)
        (s_version, s_addr, s_count, s_data, s_write, s_read, s_read_data, s_reply,
         s_ack) = (Signal(name=f"s_{state}") for state in ("version", "addr", "count", "data", "write", "read",
                                                          "read_data", "reply", "ack"))

        # the reply shifts a byte down as each goes out, so the queue's byte
        # is its low byte: a byte select by a count was two LUT levels into
        # the queue's register (6.0 ns at a 16-channel build's seed)
        with m.If(r_valid):
            m.d.sync += reply.eq(r_data)
        with m.Elif(s_version):
            m.d.sync += reply.eq(BRIDGE_ID)
        with m.Elif(s_reply & room):
            m.d.sync += reply.eq(reply >> 8)

        live = ~timed_out            # a frame's byte counts only before the timeout
        addr_done = s_addr & live & byte_n1
        m.d.sync += [
            s_idle.eq(s_idle & ~go_frame & ~go_version | (s_addr | s_count | s_data) & timed_out
                      | s_reply & room & rh[3] | s_ack & room),
            s_version.eq(s_idle & go_version),
            s_addr.eq(s_idle & go_frame | s_addr & live & ~byte_n1),
            s_count.eq(addr_done & cmd_burst | s_count & live & ~byte_n1),
            s_data.eq(addr_done & cmd_write | s_count & live & byte_n1_more
                      | s_data & live & ~byte_n3 | s_write & taken & ~count_one),
            s_write.eq(s_data & live & byte_n3 | s_write & ~taken),
            s_read.eq(addr_done & cmd_read | s_read & ~taken),
            s_read_data.eq(s_read & taken | s_read_data & ~r_valid),
            s_reply.eq(s_version | s_read_data & r_valid | s_reply & ~(room & rh[3])),
            s_ack.eq(s_count & live & byte_n1_empty | s_write & taken & count_one | s_ack & ~room),
        ]
        # A field's byte advances nh a clock later, from two registers (as
        # five conditions on the state it was three LUT levels): a field's
        # last byte back to none taken, any other one more.
        field_byte, field_last = Signal(), Signal()
        m.d.sync += [field_byte.eq((s_addr | s_count | s_data) & live & stb),
                     field_last.eq((s_addr | s_count) & live & byte_n1)]
        with m.If(s_idle | field_last):
            m.d.sync += nh.eq(1)
        with m.Elif(field_byte):
            m.d.sync += nh.eq(Cat(nh[3], nh[:3]))
        with m.If(s_idle & stb):
            m.d.sync += [cmd_read.eq(is_read), cmd_burst.eq(is_burst), cmd_write.eq(~is_read & ~is_burst)]
        with m.If(s_addr & live & stb):
            m.d.sync += addr.eq(Cat(addr[8:], byte))
        with m.If(addr_done):
            m.d.sync += [r_stb.eq(cmd_read), count_set_one.eq(cmd_write)]
        with m.If(s_count & live & stb):
            m.d.sync += count_shift.eq(1)
        with m.If(s_data & live & stb):
            m.d.sync += data.eq(Cat(data[8:], byte))
        with m.If(s_data & live & byte_n3):
            m.d.sync += w_stb.eq(1)
        with m.If(s_write & taken):                   # w_stb is high until the block takes it
            m.d.sync += [w_stb.eq(0), count_down.eq(1)]
        with m.If(s_read & taken):                    # r_stb is high until the block takes it
            m.d.sync += r_stb.eq(0)
        # REPLY: the reply's low byte, rh counting the bytes out (one-hot,
        # 1 outside REPLY); ACK: the acknowledge byte
        with m.If(~s_reply):
            m.d.sync += rh.eq(1)
        with m.Elif(room):
            m.d.sync += rh.eq(Cat(rh[3], rh[:3]))
        m.d.comb += [put_byte.eq(Mux(s_ack, ACK, reply[:8])), put.eq((s_reply | s_ack) & room)]
        with m.If(s_reply & room & rh[3] | s_ack & room):
            m.d.sync += self.frames.eq(self.frames + 1)
