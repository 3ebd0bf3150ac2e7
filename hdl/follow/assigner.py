"""Which channel each turbine of the table takes as the beam turns, and
when: the queue of entries and exits (``rast.model.contract.follow.Follower``,
docs/beam_following.md)."""

from amaranth.hdl import Module, Signal, Mux, Cat
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from rast.model.contract.scan import AZIMUTH_BITS

__all__ = ["BeamAssigner", "follow_settings_layout", "follow_event_layout"]


def follow_settings_layout(rows: int) -> data.StructLayout:
    """What the host sets (from ``FollowWindow`` and the guard): the rows in
    the table, ``entry_off = lo − guard`` and ``exit_off = hi + 1`` (mod
    2**16), ``width`` W and ``guard`` (codes)."""
    return data.StructLayout({"rows": range(rows + 1), "entry_off": AZIMUTH_BITS, "exit_off": AZIMUTH_BITS,
                              "width": AZIMUTH_BITS + 1, "guard": AZIMUTH_BITS})


def follow_event_layout(rows: int, channels: int) -> data.StructLayout:
    """An entry (``enter`` 1: ``row`` takes ``channel``; ``late``: the beam was
    ``guard`` codes past its entry code) or an exit (``row`` frees ``channel``)."""
    return data.StructLayout({"enter": 1, "row": range(max(2, rows)), "channel": range(max(2, channels)),
                              "late": 1})


def _mod(value):
    return value[:AZIMUTH_BITS]


class BeamAssigner(wiring.Component):
    """The rows' entries and exits as the beam turns, one event at a time.

    ``start`` seeds: the table is read once for the first row whose entry
    code lies after ``beam − W`` (``rows`` clocks), then the rows held at
    that beam enter. After that, whenever ``beam`` differs from the code
    last swept, a pass takes the beam there: the next entry's and the next
    exit's codes are compared with the span swept, the earlier (an exit at a
    tie) is offered on ``event``, and the pass goes on until neither lies in
    the span. The j-th entry takes channel ``j mod C``, the j-th exit frees
    it. A pass takes the beam it found at its beginning; a beam that moves
    meanwhile is the next pass's.

    Parameters
    ----------
    rows : int
        The table's largest number of rows.
    channels : int
        C.

    Members
    -------
    settings : In(follow_settings_layout(rows))
        Read at ``start`` and through every pass (hold them while running).
    start : In(1)
        A strobe; taken between events.
    beam : In(16)
        The beam's code.
    az_addr : Out(range(rows)), az_data : In(16)
        A read port on the rows' azimuth codes, its data READ_LATENCY clocks
        after the address (a block RAM's output register).
    event : Out(stream.Signature(follow_event_layout(rows, channels)))
    held : Out(range(rows + 1))
        Rows holding a channel.
    overrun : Out(1)
        An entry found all C channels held (a scene the host should have
        refused); cleared by ``start``.
    seeding : Out(1)
        From ``start`` until the rows held at its beam have entered.
    """

    #: Clocks from ``az_addr`` to ``az_data``.
    READ_LATENCY = 2

    def __init__(self, *, rows: int, channels: int):
        for name, value in (("rows", rows), ("channels", channels)):
            if not isinstance(value, int) or isinstance(value, bool) or value < 1:
                raise ValueError(f"{name} must be a positive integer, not {value!r}")
        self._rows, self._channels = rows, channels
        super().__init__({
            "settings": In(follow_settings_layout(rows)), "start": In(1), "beam": In(AZIMUTH_BITS),
            "az_addr": Out(range(rows)), "az_data": In(AZIMUTH_BITS),
            "event": Out(stream.Signature(follow_event_layout(rows, channels))),
            "held": Out(range(rows + 1)), "overrun": Out(1), "seeding": Out(1),
        })

    def elaborate(self, platform):
        m = Module()
        s = self.settings
        rows, C = self._rows, self._channels
        start_due = Signal()
        m.d.sync += start_due.eq(start_due | self.start)
        pos, target = Signal(AZIMUTH_BITS), Signal(AZIMUTH_BITS)       # swept to; this pass's beam
        next_in, next_out = Signal(range(rows)), Signal(range(rows))
        ch_in, ch_out = Signal(range(C)), Signal(range(C))
        az_in, az_out = Signal(AZIMUTH_BITS), Signal(AZIMUTH_BITS)
        # the seed's search: a row's address, its word READ_LATENCY clocks
        # later, its key in a register, then the compare (each a stage)
        addr = Signal(range(rows + 1))
        lat = self.READ_LATENCY
        valid = [Signal(name=f"seed_valid{j}") for j in range(lat + 1)]
        row_of = [Signal(range(rows), name=f"seed_row{j}") for j in range(lat + 1)]
        best_key, best_row, key = Signal(AZIMUTH_BITS), Signal(range(rows)), Signal(AZIMUTH_BITS)
        first = Signal()
        # a pass's comparisons (registered in EVAL, decided in DECIDE)
        d_in, d_out, span, past = (Signal(AZIMUTH_BITS) for _ in range(4))
        can_in = (d_in < span) & (self.held < s.rows)
        can_out = (d_out < span) & (self.held != 0)
        payload = self.event.payload

        def wrap(counter, top):
            return Mux(counter == top - 1, 0, counter + 1)

        with m.FSM():
            with m.State("WAIT"):
                with m.If(start_due):
                    m.d.sync += [start_due.eq(self.start), target.eq(self.beam), pos.eq(self.beam - s.width),
                                 addr.eq(0), self.held.eq(0), ch_in.eq(0), ch_out.eq(0), first.eq(1),
                                 self.overrun.eq(0), self.seeding.eq(1), *(v.eq(0) for v in valid)]
                    m.next = "SEED"
                with m.Elif(self.beam != pos):
                    m.d.sync += target.eq(self.beam)
                    m.next = "EVAL"
            with m.State("SEED"):
                m.d.comb += self.az_addr.eq(addr)
                m.d.sync += [valid[0].eq(addr < s.rows), row_of[0].eq(addr)]
                m.d.sync += [x.eq(y) for x, y in zip(valid[1:], valid[:-1])]
                m.d.sync += [x.eq(y) for x, y in zip(row_of[1:], row_of[:-1])]
                with m.If(addr < s.rows):
                    m.d.sync += addr.eq(addr + 1)
                # the word of valid[lat - 1]'s row is here: its key into a register
                m.d.sync += key.eq(_mod(self.az_data + s.entry_off - pos - 1))
                with m.If(valid[lat] & (first | (key < best_key))):
                    m.d.sync += [best_key.eq(key), best_row.eq(row_of[lat]), first.eq(0)]
                with m.If(~(addr < s.rows) & ~Cat(*valid).any()):
                    m.d.sync += [next_in.eq(Mux(s.rows == 0, 0, best_row)), next_out.eq(Mux(s.rows == 0, 0, best_row))]
                    m.next = "FETCH_IN"
            # the next entry's and the next exit's azimuths, READ_LATENCY clocks each
            with m.State("FETCH_IN"):
                m.d.comb += self.az_addr.eq(next_in)
                m.next = "FETCH_OUT"
            with m.State("FETCH_OUT"):
                m.d.comb += self.az_addr.eq(next_out)
                m.next = "FETCH_A"
            with m.State("FETCH_A"):
                m.d.sync += az_in.eq(self.az_data)
                m.next = "FETCH_B"
            with m.State("FETCH_B"):
                m.d.sync += az_out.eq(self.az_data)
                m.next = "EVAL"
            with m.State("EVAL"):
                m.d.sync += [d_in.eq(_mod(az_in + s.entry_off - pos - 1)), d_out.eq(_mod(az_out + s.exit_off - pos - 1)),
                             span.eq(_mod(target - pos)), past.eq(_mod(target - az_in - s.entry_off))]
                m.next = "DECIDE"
            with m.State("DECIDE"):
                with m.If(can_out & ((d_out <= d_in) | ~can_in)):
                    m.d.sync += [payload.enter.eq(0), payload.row.eq(next_out), payload.channel.eq(ch_out),
                                 payload.late.eq(0)]
                    m.next = "EMIT"
                with m.Elif(can_in):
                    m.d.sync += [payload.enter.eq(1), payload.row.eq(next_in), payload.channel.eq(ch_in),
                                 payload.late.eq(~self.seeding & (past >= s.guard))]
                    with m.If(self.held >= C):
                        m.d.sync += self.overrun.eq(1)
                    m.next = "EMIT"
                with m.Else():
                    m.d.sync += [pos.eq(target), self.seeding.eq(0)]
                    m.next = "WAIT"
            with m.State("EMIT"):
                m.d.comb += self.event.valid.eq(1)
                with m.If(self.event.ready):
                    with m.If(payload.enter):
                        m.d.sync += [next_in.eq(wrap(next_in, s.rows)), ch_in.eq(wrap(ch_in, C)),
                                     self.held.eq(self.held + 1)]
                    with m.Else():
                        m.d.sync += [next_out.eq(wrap(next_out, s.rows)), ch_out.eq(wrap(ch_out, C)),
                                     self.held.eq(self.held - 1)]
                    m.next = "FETCH_IN"
        return m
