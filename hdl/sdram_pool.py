"""The stream pool's SDRAM back end: the block-RAM pool's interface over LiteDRAM's native port."""

from amaranth.hdl import Module, Signal, Cat
from amaranth.lib import data, stream, wiring
from amaranth.lib.cdc import FFSynchronizer
from amaranth.lib.fifo import AsyncFIFO, SyncFIFO
from amaranth.lib.wiring import In, Out

from .crossing_queue import CrossingQueue

__all__ = ["native_port_signature", "SDRAMStreamPool", "WORD_WIDTH"]

#: A stream word: I in the low 16 bits, Q in the high 16 (model/fixedpoint.py's STREAM_WIDTH × 2).
WORD_WIDTH = 32


def native_port_signature(addr_width, data_width):
    """LiteDRAM's native user port as seen from its user (the initiator):
    ``cmd`` (``we``, word ``addr``), ``wdata`` (``data``, byte enables ``we``)
    out, ``rdata`` in, each a ``lib.stream`` with LiteDRAM's valid/ready rules.
    Read data comes back in command order."""
    return wiring.Signature({
        "cmd": Out(stream.Signature(data.StructLayout({"we": 1, "addr": addr_width}))),
        "wdata": Out(stream.Signature(data.StructLayout({"data": data_width, "we": data_width // 8}))),
        "rdata": In(stream.Signature(data_width)),
    })


def _positive_int(v):
    return isinstance(v, int) and not isinstance(v, bool) and v > 0


class SDRAMStreamPool(wiring.Component):
    """The stream pool's interface (that of :class:`rast.hdl.stream_pool.StreamPool`,
    with ``r_ready`` and a variable latency) served from SDRAM through LiteDRAM's
    native user port (32-bit words: the generator's port converter splits each
    into two 16-bit beats at consecutive SDRAM addresses, I first).

    Engine side, all in ``sync``:

    * fetches ``r_valid``/``r_ready``/``r_addr``/``r_tag``: a fetch is taken
      when ``r_valid & r_ready``; a refused one is the engine's to retry.
      ``r_ready`` is low while ``queue_depth`` reads are outstanding (issued and
      not yet answered; counted a clock before, so it may stay low a clock
      longer). A taken access enters the queues a clock later, from a
      register: every decision here is taken from registers, for a 200 MHz
      fabric.
    * answers ``d_valid``/``d_tag``/``d_data``: one per taken fetch, **in the
      order taken**, ``d_tag`` the fetch's tag. No back-pressure (the engine
      takes every answer; room for all outstanding answers is reserved).
    * host writes ``w_valid``/``w_ready``/``w_addr``/``w_data`` and host reads
      ``rd_valid``/``rd_ready``/``rd_addr`` → ``rd_data_valid``/``rd_data``
      (read-back for verification). Fetches, host reads and host writes go
      through one queue in the order taken, so a host read or a fetch taken
      after a write of the same address returns the new word. Priority in one
      clock: fetch, then host read, then host write, except that a host
      operation kept waiting by a taken fetch goes first at its next chance
      (``r_ready`` is then low for that clock), so neither side starves. A
      fetch is queued behind at most ``2 * queue_depth`` host writes.
    * ``lost``: sticky, a read answer arrived with no room (cannot happen while
      the reservation above holds; tests assert it stays 0).

    SDRAM side: ``native`` (:func:`native_port_signature`) in ``sdram_domain``;
    with a domain other than ``sync`` the command queue is an
    :class:`~amaranth.lib.fifo.AsyncFIFO`, otherwise a
    :class:`~amaranth.lib.fifo.SyncFIFO`; the answer queue is a
    :class:`~rast.hdl.crossing_queue.CrossingQueue` (the engine side takes
    an answer at most every other clock, far above the SDRAM's rate).

    Parameters
    ----------
    addr_width : int
        Word address bits of the pool and of the native port (LiteDRAM's for
        the ULX3S's 32 MB with a 32-bit port: 23).
    tag_width : int
    queue_depth : int
        Reads outstanding at most (a power of two, at least 2). The command
        queue holds ``4 * queue_depth`` entries, of which host writes take at
        most ``2 * queue_depth``; the answer queue ``2 * queue_depth``.
    sdram_domain : str
        Clock domain of the native port.

    Members
    -------
    r_valid : In(1), r_ready : Out(1), r_addr : In(addr_width), r_tag : In(tag_width)
    d_valid : Out(1), d_tag : Out(tag_width), d_data : Out(32)
    w_valid : In(1), w_ready : Out(1), w_addr : In(addr_width), w_data : In(32)
    rd_valid : In(1), rd_ready : Out(1), rd_addr : In(addr_width)
    rd_data_valid : Out(1), rd_data : Out(32)
    lost : Out(1)
    native : Out(native_port_signature(addr_width, 32))
    """

    def __init__(self, addr_width=23, tag_width=6, *, queue_depth=16, sdram_domain="sdram"):
        if not _positive_int(addr_width):
            raise TypeError(f"Address width must be a positive integer, not {addr_width!r}")
        if not _positive_int(tag_width):
            raise TypeError(f"Tag width must be a positive integer, not {tag_width!r}")
        if not (_positive_int(queue_depth) and queue_depth >= 2 and not queue_depth & (queue_depth - 1)):
            raise ValueError(f"Queue depth must be a power of two of at least 2, not {queue_depth!r}")
        if not (isinstance(sdram_domain, str) and sdram_domain):
            raise TypeError(f"SDRAM domain must be a domain name, not {sdram_domain!r}")
        self._addr_width, self._tag_width = addr_width, tag_width
        self._queue_depth, self._sdram_domain = queue_depth, sdram_domain
        aw = addr_width
        super().__init__({
            "r_valid": In(1), "r_ready": Out(1), "r_addr": In(aw), "r_tag": In(tag_width),
            "d_valid": Out(1), "d_tag": Out(tag_width), "d_data": Out(WORD_WIDTH),
            "w_valid": In(1), "w_ready": Out(1), "w_addr": In(aw), "w_data": In(WORD_WIDTH),
            "rd_valid": In(1), "rd_ready": Out(1), "rd_addr": In(aw),
            "rd_data_valid": Out(1), "rd_data": Out(WORD_WIDTH),
            "lost": Out(1),
            "native": Out(native_port_signature(aw, WORD_WIDTH)),
        })

    @property
    def addr_width(self):
        return self._addr_width

    @property
    def tag_width(self):
        return self._tag_width

    @property
    def queue_depth(self):
        return self._queue_depth

    @property
    def sdram_domain(self):
        return self._sdram_domain

    def elaborate(self, platform):
        m = Module()
        aw, Q, sd = self._addr_width, self._queue_depth, self._sdram_domain
        cmd_layout = data.StructLayout({"we": 1, "addr": aw, "data": WORD_WIDTH})
        if sd == "sync":
            m.submodules.cmd_q = cmd_q = SyncFIFO(width=cmd_layout.size, depth=4 * Q)
        else:
            m.submodules.cmd_q = cmd_q = AsyncFIFO(width=cmd_layout.size, depth=4 * Q,
                                                   w_domain="sync", r_domain=sd)
        # answers: taken by the engine side on its own, from registers (an
        # AsyncFIFO's read enable in front of its memory's address was 9.3 ns
        # at a 200 MHz fabric)
        m.submodules.ans_q = ans_q = CrossingQueue(WORD_WIDTH, 2 * Q, w_domain=sd, r_domain="sync")
        # Tag and kind (1 = host read) of every outstanding read, in order.
        m.submodules.tag_q = tag_q = SyncFIFO(width=self._tag_width + 1, depth=Q)

        # --- engine side (sync) -------------------------------------------------
        # At a 200 MHz fabric every decision here is taken from registers, and
        # a taken access reaches the queues a clock later from a stage
        # register (the take decoded from the requests straight into the
        # queues' write ports was a 200 MHz SDRAM build's latest path, 9.1 ns).
        outstanding = Signal(range(Q + 1))
        # room: fewer than Q reads outstanding, from the count a clock before
        # (fewer than Q - 1 then, as one may have been taken since): reads
        # outstanding reach Q, never more, so the tag queue (Q) never fills
        # and the answer queue (2Q) has room for every answer.
        room = Signal()
        m.d.sync += room.eq(outstanding < Q - 1)
        # The command queue holds 4Q; reads are at most Q of it and host writes
        # are taken while it held fewer than 2Q - 2 a clock before (a clock of
        # this register's, one of the stage's), so at most 2Q: neither ever
        # finds it full. A write burst delays a fetch (by 2Q writes at most),
        # never refuses it, and outstanding reads never block a write.
        write_room = Signal()
        m.d.sync += write_room.eq(cmd_q.w_level < 2 * Q - 2)
        # Fetches first, except that a host operation kept waiting by a taken
        # fetch gets the next clock it can use (host_turn): under any fetch load
        # the host is served at least every other accepted operation.
        host_turn = Signal()
        host_can = (self.rd_valid & room) | (~self.rd_valid & self.w_valid & write_room)
        host_first = host_turn & host_can
        take_fetch = self.r_valid & room & ~host_first
        host_slot = ~self.r_valid | host_first
        take_hread = host_slot & self.rd_valid & room
        take_write = host_slot & ~self.rd_valid & self.w_valid & write_room
        m.d.comb += [
            self.r_ready.eq(room & ~host_first),
            self.rd_ready.eq(host_slot & room),
            self.w_ready.eq(host_slot & ~self.rd_valid & write_room),
        ]
        with m.If(take_hread | take_write):
            m.d.sync += host_turn.eq(0)
        with m.Elif(take_fetch & (self.rd_valid | self.w_valid)):
            m.d.sync += host_turn.eq(1)
        # the stage: the taken access's command and (a read's) tag
        cmd_stage = Signal(cmd_layout)
        cmd_stage_valid = Signal()
        tag_stage = Signal(self._tag_width + 1)
        tag_stage_valid = Signal()
        taken = take_fetch | take_hread            # a read (fetch or host read) taken
        m.d.sync += [cmd_stage_valid.eq(taken | take_write), tag_stage_valid.eq(taken)]
        with m.If(take_fetch):
            m.d.sync += [cmd_stage.we.eq(0), cmd_stage.addr.eq(self.r_addr), tag_stage.eq(Cat(self.r_tag, 0))]
        with m.Elif(take_hread):
            m.d.sync += [cmd_stage.we.eq(0), cmd_stage.addr.eq(self.rd_addr), tag_stage.eq(1 << self._tag_width)]
        with m.Else():
            m.d.sync += [cmd_stage.addr.eq(self.w_addr), cmd_stage.data.eq(self.w_data), cmd_stage.we.eq(1)]
        m.d.comb += [
            cmd_q.w_en.eq(cmd_stage_valid), cmd_q.w_data.eq(cmd_stage),
            tag_q.w_en.eq(tag_stage_valid), tag_q.w_data.eq(tag_stage),
        ]
        # Answers: the tag queue pops with each answer taken (a read's tag is
        # in its queue long before its answer is in the answer queue);
        # outputs registered.
        pop = ans_q.r_take
        m.d.comb += tag_q.r_en.eq(pop)
        host = tag_q.r_data[self._tag_width]
        m.d.sync += [
            self.d_valid.eq(pop & ~host), self.d_tag.eq(tag_q.r_data[:self._tag_width]),
            self.d_data.eq(ans_q.r_data),
            self.rd_data_valid.eq(pop & host), self.rd_data.eq(ans_q.r_data),
        ]
        with m.If(taken & ~pop):
            m.d.sync += outstanding.eq(outstanding + 1)
        with m.Elif(~taken & pop):
            m.d.sync += outstanding.eq(outstanding - 1)

        # --- SDRAM side ---------------------------------------------------------
        cmd_out = cmd_layout(cmd_q.r_data)
        wdata = Signal(WORD_WIDTH)
        n = self.native
        with m.FSM(domain=sd):
            with m.State("CMD"):
                m.d.comb += [n.cmd.valid.eq(cmd_q.r_rdy), n.cmd.payload.we.eq(cmd_out.we),
                             n.cmd.payload.addr.eq(cmd_out.addr)]
                with m.If(n.cmd.valid & n.cmd.ready):
                    m.d.comb += cmd_q.r_en.eq(1)
                    with m.If(cmd_out.we):
                        m.d[sd] += wdata.eq(cmd_out.data)
                        m.next = "WDATA"
            with m.State("WDATA"):
                m.d.comb += [n.wdata.valid.eq(1), n.wdata.payload.data.eq(wdata),
                             n.wdata.payload.we.eq(-1)]
                with m.If(n.wdata.ready):
                    m.next = "CMD"
        # Room for every outstanding read's answer is reserved on the engine side
        # (outstanding <= Q, answer queue 2Q), so rdata is always taken.
        m.d.comb += [n.rdata.ready.eq(1), ans_q.w_en.eq(n.rdata.valid), ans_q.w_data.eq(n.rdata.payload)]
        if sd == "sync":
            m.d.comb += self.lost.eq(ans_q.overflow)
        else:
            m.submodules.lost_sync = FFSynchronizer(ans_q.overflow, self.lost, o_domain="sync")
        return m
