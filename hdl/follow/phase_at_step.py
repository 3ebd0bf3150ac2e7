"""A row's blade phase at a step of the scene:
``(step · inc) mod (length · 2**32)`` (``rast.model.contract.follow.follow_phase``),
worked out a bit of the step at a time."""

from amaranth.hdl import Module, Signal, Mux, Cat
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from rast.model.contract.fixedpoint import PHASE_FRAC_BITS
from rast.model.contract.follow import FOLLOW_ROW_FIELDS, FOLLOW_STEP_BITS

__all__ = ["PhaseAtStep", "LENGTH_BITS", "PHASE_BITS"]

#: Bits of a row's LENGTH, and of a phase below LENGTH · 2**32.
LENGTH_BITS = dict(FOLLOW_ROW_FIELDS)["length"]
PHASE_BITS = LENGTH_BITS + PHASE_FRAC_BITS


class PhaseAtStep(wiring.Component):
    """``phase = (step · inc) mod m``, ``m = length · 2**32``, by Horner's rule
    from the step's top bit: ``acc ← (2·acc + bit·inc) mod m``, two clocks a
    bit (the sum, then its reduction: ``t − m`` and ``t − 2m`` side by side,
    ``t < 3m`` since ``acc < m`` and ``inc < 2**32 ≤ m``), so that no clock
    holds more than one carry chain of the 58-bit values.

    Members
    -------
    start : In(1)
        Takes ``step``, ``inc`` and ``length`` (ignored while ``busy``).
    step : In(FOLLOW_STEP_BITS), inc : In(32), length : In(LENGTH_BITS)
        ``length`` at least 1.
    busy : Out(1)
    done : Out(1)
        One clock, ``latency`` clocks after ``start``; ``phase`` holds the
        result from then until the next start.
    phase : Out(PHASE_BITS)
    """

    #: Clocks from ``start`` to ``done``.
    latency = 2 * FOLLOW_STEP_BITS

    def __init__(self):
        super().__init__({
            "start": In(1), "step": In(FOLLOW_STEP_BITS), "inc": In(PHASE_FRAC_BITS),
            "length": In(LENGTH_BITS),
            "busy": Out(1), "done": Out(1), "phase": Out(PHASE_BITS),
        })

    def elaborate(self, platform):
        m = Module()
        W = PHASE_BITS + 2                           # t < 3m < 2**(PHASE_BITS + 2)
        modulus = Signal(W)
        inc = Signal(PHASE_FRAC_BITS)
        bits = Signal(FOLLOW_STEP_BITS)              # the step, its next bit at the top
        left = Signal(range(FOLLOW_STEP_BITS + 1))   # bits still to take
        reduce = Signal()                            # the second clock of a bit
        acc = self.phase
        t = Signal(W)
        less_m = Signal(W + 1)
        less_2m = Signal(W + 1)
        m.d.comb += [less_m.eq(t - modulus), less_2m.eq(t - (modulus << 1))]
        m.d.sync += self.done.eq(0)
        with m.If(self.start & ~self.busy):
            m.d.sync += [modulus.eq(Cat(Signal(PHASE_FRAC_BITS), self.length)), inc.eq(self.inc),
                         bits.eq(self.step), left.eq(FOLLOW_STEP_BITS), acc.eq(0), reduce.eq(0),
                         self.busy.eq(1)]
        with m.Elif(self.busy & ~reduce):
            m.d.sync += [t.eq((acc << 1) + Mux(bits[-1], inc, 0)), bits.eq(bits << 1), reduce.eq(1)]
        with m.Elif(self.busy):
            m.d.sync += [acc.eq(Mux(~less_2m[-1], less_2m, Mux(~less_m[-1], less_m, t))),
                         left.eq(left - 1), reduce.eq(0)]
            with m.If(left == 1):
                m.d.sync += [self.busy.eq(0), self.done.eq(1)]
        return m
