"""A pipeline's slot schedule: which slot's registers are read in which
clock, which slot visits, and the period's step."""

from amaranth.hdl import Module, Signal, Mux, Array, Cat
from amaranth.lib import wiring, data
from amaranth.lib.wiring import In, Out

from rast.model.contract.fixedpoint import ReplayContract, visit_cycles
from ..register_chain import delayed

__all__ = ["SlotSchedule", "RegisterSelect", "accept_clock"]


def accept_clock(slots: int) -> int:
    """The clock of a pipeline's period in which its ``accept`` comes: the
    first (0) at M <= 2; the second (1) from M = 3, where the step flag is
    first needed at the visit, two clocks after the period start. The top
    then sends the accept strobe from its register beside the input's pins
    to the pipelines through two levels of registered copies (one copy for
    seven pipelines spread over the device was the 64-channel build's worst
    path, 8.3 ns, 6.8 of it one route)."""
    return 0 if visit_cycles(slots) < 2 else 1


class SlotSchedule(wiring.Component):
    """The slot counters of one pipeline and its period's step.

    The period starts (``rslot`` 0) ACCEPT_LAG clocks after the top's
    accepting clock, first in the clock after reset; slot s's registers are
    read in the period's clock s and it visits ``visit_cycles`` clocks later
    (``vslot``). ``accept`` comes in the period's clock ``accept_clock``; the
    step flag and the step's number (counted in the window's depth) are held
    from then for the period's visits.

    Members
    -------
    accept : In(1)
        The period carries an input sample (only in clock ``accept_clock``).
    offer : In(1)
        The fetch scan offers the pipeline's slots a fetch this period.
    rslot, vslot : Out(range(max(2, M)))
        The slot whose registers are read, the slot that visits.
    at_slot : Out(M)
        ``rslot`` one-hot, from registers of its own.
    step_start : Out(1)
        The period's step is accepted in this clock (clock ``accept_clock``).
    held_index : Out(range(window depth))
        The step's number, from the clock after ``step_start``.
    step, step_index : Out(1), Out(range(window depth))
        The visiting slot's period is a step, and its number.
    offer_visit : Out(1)
        ``offer`` as the visiting slot sees it.
    """

    def __init__(self, contract: ReplayContract):
        if not isinstance(contract, ReplayContract):
            raise TypeError(f"Contract must be a ReplayContract, not {contract!r}")
        self._c = contract
        M, W = contract.slots, contract.window_depth
        super().__init__({
            "accept": In(1), "offer": In(1),
            "rslot": Out(range(max(2, M)), init=M - 1), "vslot": Out(range(max(2, M))),
            "at_slot": Out(M, init=1 << (M - 1)),
            "step_start": Out(1), "held_index": Out(range(W)),
            "step": Out(1), "step_index": Out(range(W)), "offer_visit": Out(1),
        })

    @property
    def visit_cycles(self) -> int:
        """Clocks from a slot's register read to its visit."""
        return visit_cycles(self._c.slots)

    @property
    def accept_clock(self) -> int:
        return accept_clock(self._c.slots)

    def elaborate(self, platform):
        m = Module()
        M, V, A = self._c.slots, self.visit_cycles, self.accept_clock
        rslot = self.rslot
        if M > 1:
            m.d.sync += rslot.eq(Mux(rslot == M - 1, 0, rslot + 1))
        m.d.comb += self.vslot.eq(delayed(m, rslot, V, "vslot"))
        # rslot == s, one-hot in registers of their own: a slot's command
        # acknowledge and the step flag's load (from the compare, each was a
        # latest path of the 64-channel build, into the register file's
        # command flags and the step count's enable, 6.8-7.2 ns)
        m.d.sync += self.at_slot.eq(self.at_slot.rotate_left(1))
        # The period's step flag and step number, loaded in its clock A and
        # held for the period's M visits (V clocks after the period start,
        # V - 1 - A delays later).
        astart = self.at_slot[A]
        count = Signal(range(self._c.window_depth))
        step_h = Signal()
        with m.If(astart):
            m.d.sync += [step_h.eq(self.accept), self.held_index.eq(count)]
            with m.If(self.accept):
                m.d.sync += count.eq(count + 1)
        m.d.comb += [self.step_start.eq(astart & self.accept),
                     self.step.eq(delayed(m, step_h, V - 1 - A, "step_v")),
                     self.step_index.eq(delayed(m, self.held_index, V - 1 - A, "nidx_v")),
                     self.offer_visit.eq(delayed(m, self.offer, V - 1, "offer"))]
        return m


class RegisterSelect(wiring.Component):
    """The register read: the slot ``rslot``'s registers, registered, at its
    visit (``visit_cycles`` clocks later). The flip-flop part (``regs``):
    one multiplexer at V = 1; at V = 2 groups of 4 slots by the low bits,
    registered, then the group (one select fanning out to every bit in one
    clock was the 20-channel slice's critical path, 8.7 ns). The RAM part
    (``values``) comes registered from the register file; V - 1 registers
    more. The command's decisions come in flip-flops of their own
    (``channel_regs_layout``), so that each selected bit is a multiplexer of
    register outputs.

    Members
    -------
    regs : In(regs_layout).array(M), values : In(values_layout), rslot : In
    rsel : Out(regs_layout + values_layout)
        The visiting slot's registers.
    length_early : Out(length)
        Its LENGTH a clock before the visit (V >= 2; the stream switch's
        length - 1 and restart index are computed from it).
    """

    def __init__(self, contract: ReplayContract, regs_layout, values_layout):
        self._c = contract
        self._rl, self._vl = regs_layout, values_layout
        M = contract.slots
        super().__init__({
            "regs": In(regs_layout).array(M), "values": In(values_layout), "rslot": In(range(max(2, M))),
            "rsel": Out(data.StructLayout({**dict(regs_layout.members), **dict(values_layout.members)})),
            "length_early": Out(values_layout.members["length"]),
        })

    def elaborate(self, platform):
        m = Module()
        M, V = self._c.slots, visit_cycles(self._c.slots)
        rl, rslot = self._rl, self.rslot
        flags = Signal(rl, name="rsel_flags")
        m.d.comb += self.rsel.as_value().eq(Cat(flags, delayed(m, self.values, V - 1, "rsel_values")))
        if M == 1:
            m.d.sync += flags.eq(self.regs[0])
        elif V == 1:
            m.d.sync += flags.eq(Array(self.regs)[rslot])
        else:
            groups = []
            for g in range(0, M, 4):
                part = Signal(rl, name=f"rsel_g{g // 4}")
                members = list(self.regs)[g:g + 4]
                m.d.sync += part.eq(Array(members)[rslot[:2]] if len(members) > 1 else members[0])
                groups.append(part)
            if len(groups) > 1:
                m.d.sync += flags.eq(Array(groups)[delayed(m, rslot[2:], 1, "rslot_hi")])
            else:
                m.d.sync += flags.eq(groups[0])
        if V >= 2:
            m.d.comb += self.length_early.eq(delayed(m, self.values, V - 2, "rsel_early").length)
        return m
