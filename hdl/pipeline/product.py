"""A pipeline's product stage: the tap's sample times the stream word
(complex), times the channel's gain, summed over the period's slots."""

from amaranth.hdl import Module, Signal, signed
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from rast.model.contract.fixedpoint import (ReplayContract, INPUT_WIDTH, STREAM_WIDTH, GAIN_WIDTH, PRODUCT_SHIFT,
                                            GAIN_SHIFT, SCALED_WIDTH, WORD_CYCLES, GAIN_CYCLES, CMULT_CYCLES)
from ..cmult import ComplexMultiplier
from ..ecp5_primitives import RegisteredMultiplier, kept_register
from ..iq import IQ
from ..register_chain import delayed, cleared

__all__ = ["ProductSum"]


class ProductSum(wiring.Component):
    """``q = round_half_up(cmult(t, w)·g, 16)`` per visit and the period's
    sum over the slots (the contract's "replay data path"): the complex
    product (:class:`ComplexMultiplier`, CMULT_CYCLES), the gain
    (GAIN_CYCLES), the slot accumulator (one clock).

    Members
    -------
    a : In(IQ(16)) (32 bits), b, b2 : In(IQ(16))
        The tap's sample and the stream word (two copies), the values the
        multiplier's operand registers take, WORD_CYCLES - 1 clocks after the visit.
    gain : In(GAIN_WIDTH), vslot : In
        The channel's gain (0 when disabled), ``gain_lag`` clocks after the
        visit (at most :attr:`max_gain_lag`), and the slot, at the visit.
    sum : Out(IQ(sum width))
        The period's sum, :attr:`sum_cycles` clocks after the visit of the
        period's last slot; held for M clocks.
    """

    def __init__(self, contract: ReplayContract, gain_lag: int = 0):
        if not isinstance(contract, ReplayContract):
            raise TypeError(f"Contract must be a ReplayContract, not {contract!r}")
        self._c = contract
        if not isinstance(gain_lag, int) or not 0 <= gain_lag <= self.max_gain_lag:
            raise ValueError(f"gain_lag must be an integer in [0, {self.max_gain_lag}], not {gain_lag!r}")
        self._gain_lag = gain_lag
        super().__init__({"a": In(2 * INPUT_WIDTH), "b": In(IQ(STREAM_WIDTH)), "b2": In(IQ(STREAM_WIDTH)),
                          "gain": In(GAIN_WIDTH), "vslot": In(range(max(2, contract.slots))),
                          "sum": Out(IQ(contract.sum_width))})

    @property
    def max_gain_lag(self) -> int:
        """Clocks the gain may come after the visit: it waits for the
        product that long (the word and the complex product, but the gain
        multiplier's operand registers)."""
        return WORD_CYCLES - 1 + CMULT_CYCLES[self._c.cmult_form]     # the multiplier's operand registers: + 1

    @property
    def sum_cycles(self) -> int:
        """Clocks from a visit to its q in the period's sum: the word, the
        complex product, the gain, the slot accumulator."""
        return WORD_CYCLES + CMULT_CYCLES[self._c.cmult_form] + GAIN_CYCLES + 1

    def elaborate(self, platform):
        m = Module()
        c = self._c
        # The tap's sample and the word into the multiplier's operand
        # registers, a copy for each of its multipliers (``operand_registers``).
        m.submodules.cmult = cm = ComplexMultiplier(INPUT_WIDTH, STREAM_WIDTH, PRODUCT_SHIFT, c.cmult_form,
                                                    operand_registers=True, second_b=True)
        m.d.comb += [cm.en.eq(1), cm.a.eq(self.a), cm.b.eq(self.b), cm.b2.eq(self.b2)]
        geff = self.gain
        # (its last two registers the copies below)
        assert WORD_CYCLES - 2 + cm.latency == self.max_gain_lag
        g = delayed(m, geff, self.max_gain_lag - self._gain_lag, "gain", data=True)
        q = Signal(IQ(SCALED_WIDTH), name="q", reset_less=True)
        q_sum = {}          # a kept copy of q for the period sum's adder (below)
        for part in ("re", "im"):
            mul = RegisteredMultiplier(cm.o_width, len(geff) + 1, input_reg=True)
            m.submodules[f"gain_mul_{part}"] = mul
            # the product again in a register before the multiplier (the
            # rounding's register sits with its adder, and from there into the
            # multiplier was the latest path of a 16-channel build, 6.9 ns,
            # 6.3 of it one route); the gain's last two registers a copy for
            # each multiplier (kept: with one, the route from its copy into
            # the multiplier was a 16-channel build's latest path, 5.02 ns,
            # 4.41 of it that route)
            gain_near = kept_register(m, platform, kept_register(m, platform, g, f"gain_far_{part}"),
                                      f"gain_{part}")
            m.d.comb += [mul.en.eq(1), mul.a.eq(delayed(m, getattr(cm.o, part), 1, f"gain_a_{part}", data=True)),
                         mul.b.eq(gain_near)]
            prod = delayed(m, mul.o, 1, f"gain_prod_{part}", data=True)      # in fabric, next to the adder
            rounded = Signal(signed(SCALED_WIDTH), name=f"q_next_{part}")
            m.d.comb += rounded.eq((prod + (1 << (GAIN_SHIFT - 1))) >> GAIN_SHIFT)
            m.d.sync += getattr(q, part).eq(rounded)
            q_sum[part] = kept_register(m, platform, rounded, f"q_sum_{part}").as_signed()
        assert 1 + 2 + 1 + 1 == GAIN_CYCLES
        # The period's sum: the slots' q added into an accumulator that is
        # cleared (its registers' reset) where the next clock's q is a
        # period's first, the finished sum taken into ``sum`` then. An adder
        # straight into its registers: a multiplexer after it (the first
        # slot's q or the sum) was among the 64-channel build's late paths
        # (5.9 ns). ``sum`` holds a period's sum in the clock of the next
        # period's first q and M - 1 clocks after.
        q_slot_ahead = delayed(m, self.vslot, WORD_CYCLES - 1 + cm.latency + GAIN_CYCLES - 2, "qslot")
        period_ends = Signal(name="period_ends")
        m.d.sync += period_ends.eq(q_slot_ahead == 0)
        # The period's sum from an adder of its own, beside ``sum``'s registers
        # (with q's kept copy: Yosys would merge two adders of the same
        # inputs): one adder into both the accumulator and ``sum`` had two
        # registers per bit to place by one carry chain, and the
        # accumulator's, put away from it, was a route of 1.7 ns back into
        # the chain (5.03-5.28 ns, the latest path at two of three seeds of
        # 16-channel builds).
        for part in ("re", "im"):
            s_ = getattr(self.sum, part)
            acc = Signal.like(s_, name=f"slot_acc_{part}", reset_less=True)
            m.d.sync += acc.eq(cleared(acc + getattr(q, part), period_ends))
            with m.If(period_ends):
                m.d.sync += s_.eq(acc + q_sum[part])
        return m
