"""The loader: each entry of the assigner's becomes a channel playing its
turbine from the phase the turbine has reached; each exit, a channel at
gain 0 (docs/beam_following.md; the rule ``rast.model.contract.follow``)."""

from amaranth.hdl import Module, Signal, Mux, Const, Array
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from rast.model.contract.fixedpoint import PHASE_FRAC_BITS
from rast.model.contract.follow import (FOLLOW_ROW_FIELDS, FOLLOW_ROW_WORDS, FOLLOW_STEP_BITS,
                                        LOAD_WRITES_BEFORE, follow_lead_steps, follow_switch_margin_steps)
from rast.model.contract.regmap import FOLLOW_SWITCH_STEP_BITS, RegisterMap
from ..registers import BusSignature
from .assigner import follow_event_layout
from .phase_at_step import PhaseAtStep
from .table import TurbineTable

__all__ = ["FollowLoader", "ROW_LAYOUT"]

#: A turbine table row's fields, from bit 0 up.
ROW_LAYOUT = data.StructLayout(dict(FOLLOW_ROW_FIELDS))
#: The writes of an entry, in order (the first LOAD_WRITES_BEFORE need no
#: phase): register, and whether it is the channel's.
ENTRY_WRITES = (("AZIMUTH", True), ("GAIN", True), ("DELAY", True), ("APPLY", False), ("LENGTH", True),
                ("PHASE_INC", True), ("BASE", True), ("START", True), ("FOLLOW_SWITCH", False))
assert ENTRY_WRITES[LOAD_WRITES_BEFORE - 1][0] == "PHASE_INC"
assert TurbineTable.latency == 2            # (READ, then ROW)


class FollowLoader(wiring.Component):
    """Takes the assigner's events one at a time and writes the registers
    they need through the register bus (beside the host's).

    An entry of row r into channel c: the row is read; the switch's step is
    ``follow_lead_steps(M)`` steps ahead (``steps_lo`` and ``scene`` count
    the same steps); the row's phase at that step plus the switch's refill
    (when the channel next plays) is worked out (:class:`PhaseAtStep`)
    while AZIMUTH, GAIN, DELAY (with APPLY), LENGTH and PHASE_INC are written;
    then BASE (the row's, moved by the phase's whole words: the stream is
    held rolled), START (its fraction) and FOLLOW_SWITCH naming the step.
    The loader waits for that step (one switch is held at a time). A switch
    whose step is too near to land in time is not written: ``late`` strikes
    and the phase is worked out again for a later step. An exit: GAIN 0.

    Members
    -------
    event : In(stream.Signature(follow_event_layout(rows, C)))
    row_addr : Out(range(rows)), row_data : In(128)
        The table's row read port (two clocks: :attr:`TurbineTable.latency`).
    scene : In(48), steps_lo : In(8)
        The scene's step number, and the low bits of the step number
        FOLLOW_SWITCH names, of the steps accepted before this clock.
    bus : Out(BusSignature)
    late : Out(1)
        One clock per switch retimed.
    """

    def __init__(self, rmap: RegisterMap):
        c = rmap.contract
        if not c.follow_rows:
            raise ValueError("FollowLoader needs a contract with follow_rows")
        self._rmap, self._c = rmap, c
        self.lead = follow_lead_steps(c.slots)
        super().__init__({
            "event": In(stream.Signature(follow_event_layout(c.follow_rows, c.channels))),
            "row_addr": Out(range(c.follow_rows)), "row_data": In(32 * FOLLOW_ROW_WORDS),
            "scene": In(FOLLOW_STEP_BITS), "steps_lo": In(FOLLOW_SWITCH_STEP_BITS),
            "bus": Out(BusSignature(rmap.addr_width)), "late": Out(1),
        })

    def _address(self, name, channel, per_channel):
        r = self._rmap.reg(name, 0 if per_channel else None)
        return r.addr + (channel * self._rmap.channel_stride if per_channel else 0)

    def elaborate(self, platform):
        m = Module()
        c, rmap = self._c, self._rmap
        m.submodules.phase = phase = PhaseAtStep()
        ev = Signal(self.event.payload.shape())
        row = Signal(ROW_LAYOUT)
        target = Signal(FOLLOW_SWITCH_STEP_BITS)
        k = Signal(range(len(ENTRY_WRITES)))
        have_phase = Signal()
        m.d.sync += have_phase.eq(Mux(phase.start, 0, have_phase | phase.done))   # (start: below)
        bits = 1 << FOLLOW_SWITCH_STEP_BITS
        # the switch's write lands REGISTER_STAGING clocks after it is taken;
        # whether the step named is that far ahead, in a register (a clock
        # old: one step more asked), not in the clock that offers the write
        # (the subtraction, the compares and the retiming in one clock were
        # the first following build's latest path, 10.9 ns)
        min_ahead = follow_switch_margin_steps(c.slots)
        ahead = Signal(FOLLOW_SWITCH_STEP_BITS)
        too_near = Signal()
        m.d.comb += ahead.eq(target - self.steps_lo)
        m.d.sync += too_near.eq((ahead < min_ahead) | (ahead >= bits // 2))
        values = {
            "AZIMUTH": row.azimuth, "GAIN": row.gain, "DELAY": row.delay, "APPLY": Const(1, 32),
            "LENGTH": row.length, "PHASE_INC": row.phase_inc,
            "BASE": (row.base + phase.phase[PHASE_FRAC_BITS:])[:c.pool_address_width],
            "START": phase.phase[:PHASE_FRAC_BITS],
            "FOLLOW_SWITCH": ev.channel | (target << rmap.reg("FOLLOW_SWITCH").field("step").lsb),
        }
        addrs = Array(self._address(name, ev.channel, own) for name, own in ENTRY_WRITES)
        datas = Array(values[name] for name, _ in ENTRY_WRITES)
        # the bus from registers: each write's address and data loaded a clock
        # before it is offered (the 9:1 selection beside the register file's
        # input register would be a long path into it)
        bus = self.bus
        addr_q, data_q, stb_q = Signal.like(bus.addr), Signal.like(bus.w_data), Signal()
        m.d.comb += [bus.addr.eq(addr_q), bus.w_data.eq(data_q), bus.w_stb.eq(stb_q)]
        taken = stb_q & bus.ready
        with m.If(taken):
            m.d.sync += stb_q.eq(0)

        def offer(addr, value):
            m.d.sync += [addr_q.eq(addr), data_q.eq(value), stb_q.eq(1)]

        # the phase's product started from registers, a clock after its step is set
        go, play_step = Signal(), Signal(FOLLOW_STEP_BITS)
        m.d.sync += go.eq(0)
        m.d.comb += [phase.start.eq(go), phase.step.eq(play_step), phase.inc.eq(row.phase_inc),
                     phase.length.eq(row.length)]

        def retarget():
            """The switch's step ``lead`` steps on, and the phase for it plus the refill."""
            m.d.sync += [target.eq(self.steps_lo + self.lead), go.eq(1),
                         play_step.eq(self.scene + self.lead + c.refill_samples)]

        last = k == len(ENTRY_WRITES) - 1
        with m.FSM():
            with m.State("IDLE"):
                m.d.comb += self.event.ready.eq(1)
                with m.If(self.event.valid):
                    m.d.sync += [ev.eq(self.event.payload), k.eq(0)]
                    m.d.comb += self.row_addr.eq(self.event.payload.row)
                    m.next = "READ"
            with m.State("READ"):                      # (the table's word: two clocks)
                m.next = "ROW"
            with m.State("ROW"):
                m.d.sync += row.eq(self.row_data)
                m.next = "DECIDE"
            with m.State("DECIDE"):
                with m.If(ev.enter):
                    retarget()
                    m.next = "WRITE"
                with m.Else():
                    offer(self._address("GAIN", ev.channel, True), 0)
                    m.next = "LEAVE"
            with m.State("WRITE"):
                with m.If(taken):
                    m.d.sync += k.eq(k + 1)
                    with m.If(last):
                        m.next = "SWITCH"
                with m.Elif(~stb_q & ~go & ((k < LOAD_WRITES_BEFORE) | have_phase)):
                    with m.If(last & too_near):
                        m.d.comb += self.late.eq(1)     # too near, or past: the phase for a later step
                        m.d.sync += k.eq(LOAD_WRITES_BEFORE)
                        retarget()
                    with m.Else():
                        offer(addrs[k], datas[k])
            with m.State("SWITCH"):
                # the switch has fired once the step named is past
                passed = Signal(FOLLOW_SWITCH_STEP_BITS)
                m.d.comb += passed.eq(self.steps_lo - target)
                with m.If((passed != 0) & (passed < bits // 2)):
                    m.next = "IDLE"
            with m.State("LEAVE"):
                with m.If(taken):
                    m.next = "IDLE"
        return m
