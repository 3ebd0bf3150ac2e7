"""The stream pool's SDRAM back end: the block-RAM pool's interface over LiteDRAM's native port."""

from amaranth.hdl import Cat, Module, Mux, Signal
from amaranth.lib import data, stream, wiring
from amaranth.lib.cdc import FFSynchronizer
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from .crossing_queue import CrossingQueue

__all__ = ["native_port_signature", "SDRAMStreamPool", "WORD_WIDTH"]

#: A stream word: I in the low 16 bits, Q in the high 16 (model/contract/fixedpoint.py's STREAM_WIDTH × 2).
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

    * fetches ``r_valid``/``r_ready``/``r_addr``/``r_tag``, a ``lib.stream``
      handshake: once raised, ``r_valid`` (and the fetch) stays until
      ``r_ready``; ``rd_valid`` and ``w_valid`` the same. The pool decides
      from registers only, for a 200 MHz fabric: in one clock it grants an
      access (fetch, host read or host write) by the valids it sees, in the
      next ``r_ready``, ``rd_ready`` or ``w_ready`` is that grant's register
      and the access goes into the queues. A clock with a grant decides
      nothing, so an access is taken at most every other clock (100 M
      accesses/s at 200 MHz; the SDRAM serves 25 M words/s). No read is
      granted while ``queue_depth`` reads are outstanding (issued and not
      yet answered; counted a clock before, so a grant may wait a clock
      longer).
    * answers ``d_valid``/``d_tag``/``d_data``: one per taken fetch, **in the
      order taken**, ``d_tag`` the fetch's tag. No back-pressure (the engine
      takes every answer; room for all outstanding answers is reserved).
    * host writes ``w_valid``/``w_ready``/``w_addr``/``w_data`` and host reads
      ``rd_valid``/``rd_ready``/``rd_addr`` → ``rd_data_valid``/``rd_data``
      (read-back for verification). Fetches, host reads and host writes go
      through one queue in the order taken, so a host read or a fetch taken
      after a write of the same address returns the new word. Priority of a
      grant: fetch, then host read, then host write, except that a host
      operation kept waiting by a granted fetch gets the next grant it can
      use, so neither side starves. A fetch is queued behind at most
      ``2 * queue_depth`` host writes.
    * ``lost``: sticky, a read answer or an access arrived at a full queue
      (cannot happen while the reservations hold; tests assert it stays 0).

    SDRAM side: ``native`` (:func:`native_port_signature`) in ``sdram_domain``.
    Each queue is a :class:`~rast.hdl.crossing_queue.CrossingQueue`: the
    commands' read by the controller's handshake, the answers' taken by the
    engine side at most every other clock (far above the SDRAM's rate).

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
        # commands: written from the grant registers, never gated (the
        # reservations below keep room; an AsyncFIFO's full compare in front
        # of its write pointer and memory was 6.8 ns at a 200 MHz fabric)
        m.submodules.cmd_q = cmd_q = CrossingQueue(cmd_layout.size, 4 * Q, w_domain="sync", r_domain=sd,
                                                   reader="stream")
        # answers: taken by the engine side on its own, from registers (an
        # AsyncFIFO's read enable in front of its memory's address was 9.3 ns
        # at a 200 MHz fabric)
        m.submodules.ans_q = ans_q = CrossingQueue(WORD_WIDTH, 2 * Q, w_domain=sd, r_domain="sync")
        # Tag and kind (1 = host read) of every outstanding read, in order: a
        # ring of Q, written with each read granted and read with each answer
        # taken. Reads outstanding never exceed Q (``room`` below) and an
        # answer never comes before its read's tag, so the ring needs no level
        # (a SyncFIFO's level and its compares were 5.3-5.7 ns in 200 MHz
        # SDRAM builds).
        m.submodules.tag_ring = tag_ring = Memory(shape=self._tag_width + 1, depth=Q, init=[],
                                                  attrs={"ram_style": "distributed"})
        tag_w, tag_r = tag_ring.write_port(), tag_ring.read_port(domain="comb")
        tag_w_at, tag_r_at = Signal(range(Q), name="tag_w_at"), Signal(range(Q), name="tag_r_at")

        # --- engine side (sync) -------------------------------------------------
        # Every decision here is taken from registers: a grant is a one-hot
        # register per kind, decided from the valids and the room registers,
        # and in its clock the access goes into the queues, selected by the
        # grant registers alone. (The take decoded from the valids into a
        # stage register was 7.1 ns at a 200 MHz SDRAM build, straight into
        # the queues 9.1 ns.)
        outstanding = Signal(range(Q + 1))
        # room: fewer than Q reads outstanding, from the count a clock before
        # (fewer than Q - 1 then, as one may have been taken since): reads
        # outstanding reach Q, never more, so the tag queue (Q) never fills
        # and the answer queue (2Q) has room for every answer.
        room = Signal()
        m.d.sync += room.eq(outstanding < Q - 1)
        # The command queue holds 4Q; reads are at most Q of it and host writes
        # are granted while it held fewer than 2Q - 2 two clocks before (its
        # level is a clock late, this register another; one access taken in
        # those clocks, one by the grant), so at most 2Q: neither ever finds
        # it full. A write burst delays a fetch (by 2Q writes at most), never
        # refuses it, and outstanding reads never block a write.
        write_room = Signal()
        m.d.sync += write_room.eq(cmd_q.w_level < 2 * Q - 2)
        # Fetches first, except that a host operation kept waiting by a granted
        # fetch gets the next grant it can use (host_turn): under any fetch
        # load the host is served at least every other access. A host read
        # goes before a host write.
        grant_fetch, grant_hread, grant_write = Signal(), Signal(), Signal()
        # any grant; a fetch's or a host read's: ORs of the grants above, kept
        # as registers of their own so that the queues' write enables and the
        # outstanding count start at a flip-flop, not at a LUT after three
        granted, read_granted = Signal(), Signal()
        host_turn = Signal()
        want_hread = self.rd_valid & room
        want_write = ~self.rd_valid & self.w_valid & write_room
        want_fetch = self.r_valid & room
        fetch_first = want_fetch & ~(host_turn & (want_hread | want_write))
        m.d.sync += [
            grant_fetch.eq(~granted & fetch_first),
            grant_hread.eq(~granted & want_hread & ~fetch_first),
            grant_write.eq(~granted & want_write & ~fetch_first),
            granted.eq(~granted & (want_fetch | want_hread | want_write)),
            read_granted.eq(~granted & (fetch_first | want_hread)),
        ]
        with m.If(grant_hread | grant_write):
            m.d.sync += host_turn.eq(0)
        with m.Elif(grant_fetch & (self.rd_valid | self.w_valid)):
            m.d.sync += host_turn.eq(1)
        # a grant's access is taken into the queues in the grant's clock (its
        # valid is still up: valids stay until ready)
        command = cmd_layout(cmd_q.w_data)
        m.d.comb += [
            self.r_ready.eq(grant_fetch), self.rd_ready.eq(grant_hread), self.w_ready.eq(grant_write),
            cmd_q.w_en.eq(granted), command.we.eq(grant_write), command.data.eq(self.w_data),
            command.addr.eq(Mux(grant_fetch, self.r_addr, Mux(grant_hread, self.rd_addr, self.w_addr))),
            tag_w.en.eq(read_granted), tag_w.addr.eq(tag_w_at),
            tag_w.data.eq(Mux(grant_fetch, Cat(self.r_tag, 0), 1 << self._tag_width)),
        ]
        with m.If(read_granted):
            m.d.sync += tag_w_at.eq(tag_w_at + 1)
        # Answers: the tag queue pops with each answer taken (a read's tag is
        # in its queue long before its answer is in the answer queue);
        # outputs registered.
        pop = ans_q.r_take
        m.d.comb += tag_r.addr.eq(tag_r_at)
        with m.If(pop):
            m.d.sync += tag_r_at.eq(tag_r_at + 1)
        host = tag_r.data[self._tag_width]
        m.d.sync += [
            self.d_valid.eq(pop & ~host), self.d_tag.eq(tag_r.data[:self._tag_width]),
            self.d_data.eq(ans_q.r_data),
            self.rd_data_valid.eq(pop & host), self.rd_data.eq(ans_q.r_data),
        ]
        with m.If(read_granted & ~pop):
            m.d.sync += outstanding.eq(outstanding + 1)
        with m.Elif(~read_granted & pop):
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
        answer_lost = Signal()
        if sd == "sync":
            m.d.comb += answer_lost.eq(ans_q.overflow)
        else:
            m.submodules.lost_sync = FFSynchronizer(ans_q.overflow, answer_lost, o_domain="sync")
        m.d.comb += self.lost.eq(answer_lost | cmd_q.overflow)
        return m
