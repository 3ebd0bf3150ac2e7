"""The interpolator's last stage: the stream word at the multiplier, a + round((b - a) * f, 16)."""

from amaranth.hdl import Module, Signal, Cat, Const, signed
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from rast.model.contract.fixedpoint import STREAM_WIDTH, INTERP_FRAC_BITS, WORD_CYCLES, INTERPOLATIONS
from ..ecp5_primitives import RegisteredMultiplier, kept_register
from ..iq import IQ
from ..register_chain import delayed, cleared

__all__ = ["LinearStep"]


class LinearStep(wiring.Component):
    """The word a visit plays: ``a + round_half_up((b - a)·f, 16)`` for linear
    interpolation and the FIR's second stage (``a``, ``b`` the words or U
    values around the phase, ``f`` the fraction's next 16 bits), ``a`` itself
    for hold; 0 for a muted visit. In WORD_CYCLES clocks from the visit
    (:attr:`latency`): the operands (OPERAND_CYCLES after the visit), their
    difference, the multiplier's input and output registers, the product in
    fabric, the sum; the sum and the rounding one adder of a's width,
    ``(a·2¹⁶ + 2¹⁵ + p) >> 16 = a + (p >> 16) + p[15]``, with p[15] its carry-in.
    A muted word is 0 through the synchronous resets of the last stage's
    registers (a and p), so that the sum goes straight into the complex
    multiplier's operand registers (a multiplexer after it was among a
    16-channel build's late paths, 6.2 ns).

    Members
    -------
    a, b : In(IQ(16))
        The operands, OPERAND_CYCLES after the visit.
    frac : In(16), mute : In(1)
        The fraction and the mute, at the visit.
    word, word2 : Out(IQ(16))
        The value the complex multiplier's operand registers take (two
        copies, one for each pair of its multipliers, from adders and
        registers of their own), WORD_CYCLES - 1 clocks after the visit.
    """

    #: Clocks from the visit to the operands ``a`` and ``b``.
    OPERAND_CYCLES = 2

    def __init__(self, interpolation):
        if interpolation not in INTERPOLATIONS:
            raise ValueError(f"Interpolation must be one of {', '.join(INTERPOLATIONS)}, not {interpolation!r}")
        self._interp = interpolation
        super().__init__({"a": In(IQ(STREAM_WIDTH)), "b": In(IQ(STREAM_WIDTH)), "frac": In(INTERP_FRAC_BITS),
                          "mute": In(1), "word": Out(IQ(STREAM_WIDTH)), "word2": Out(IQ(STREAM_WIDTH))})

    @property
    def latency(self) -> int:
        """Clocks from the visit to the word in the multiplier's operand registers."""
        return WORD_CYCLES

    def elaborate(self, platform):
        m = Module()
        a2, b2 = self.a, self.b
        f2 = delayed(m, self.frac, self.OPERAND_CYCLES, "word_f", data=True)
        # (the product's: its fraction operand, three clocks earlier)
        mute_early = delayed(m, self.mute, WORD_CYCLES - 5, "word_mute_early")
        mute = delayed(m, mute_early, 3, "word_mute")        # a clock before the word's last registers

        def last_register(value, name):
            reg = Signal.like(value, name=name, reset_less=True)
            m.d.sync += reg.eq(cleared(value, mute))
            return reg
        word, word2 = self.word, self.word2
        if self._interp == "hold":
            # the word itself, as late as the interpolated one would be
            m.d.comb += word.eq(last_register(delayed(m, a2, WORD_CYCLES - 4, "word_hold", data=True), "word_hold"))
            m.d.comb += word2.eq(word)
            return m
        # the fraction operand, 0 for a muted word: its product is then
        # 0 with no multiplexer after the multiplier (the multiplier's
        # output through one into its register was a 16-channel build's
        # late path, 5.3 ns); a kept copy per multiplier (one register
        # into both multipliers' input registers was a 16-channel build's
        # late route, 4.7 ns: the two DSPs are not side by side)
        for part in ("re", "im"):
            f3 = kept_register(m, platform, cleared(f2, mute_early), f"word_f3_{part}")
            diff = Signal(signed(STREAM_WIDTH + 1), name=f"word_diff_{part}", reset_less=True)
            m.d.sync += diff.eq(getattr(b2, part) - getattr(a2, part))
            mul = RegisteredMultiplier(STREAM_WIDTH + 1, INTERP_FRAC_BITS + 1, input_reg=True)
            m.submodules[f"lin_mul_{part}"] = mul
            m.d.comb += [mul.en.eq(1), mul.a.eq(diff), mul.b.eq(f3)]
            # the product again in fabric, next to the adder (0 already
            # for a muted word)
            prod = delayed(m, mul.o, 1, f"word_prod_{part}", data=True)
            # a low bit beside a, 1 on the other side, shifted out: the whole
            # 33-bit sum was the carry chain into the operand copies, 6.2 ns
            # at 16 channels. A muted word: (0 + 1) >> 1 = 0.
            a5 = delayed(m, getattr(a2, part), WORD_CYCLES - 4, f"word_a6_{part}", data=True)
            a6 = last_register(a5, f"word_a6_{part}")
            # word2's: the product and a again, kept apart from word's
            # (equal registers would be one to Yosys, and so the adders)
            prod2 = kept_register(m, platform, mul.o, f"word2_prod_{part}")
            a6_2 = kept_register(m, platform, cleared(a5, mute), f"word2_a6_{part}")
            for target, p_, a_ in ((word, prod, a6), (word2, prod2, a6_2)):
                rounded_hi = Cat(Const(1, 1), p_[INTERP_FRAC_BITS:]).as_signed()
                m.d.comb += getattr(target, part).eq(
                    (Cat(p_[INTERP_FRAC_BITS - 1], a_).as_signed() + rounded_hi) >> 1)
        # operands (address, word), difference, multiplier in and out, product, sum
        assert self.OPERAND_CYCLES + 1 + 2 + 1 + 1 == WORD_CYCLES
        return m
