"""Pipelined complex multiplier: full-precision product, one rounding step."""

from amaranth.hdl import C, Cat, Module, Signal, Mux, signed
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from .iq import IQ
from .ecp5_primitives import RegisteredMultiplier, kept_register
from rast.model.contract.fixedpoint import CMULT_CYCLES

__all__ = ["ComplexMultiplier"]

FORMS = ("4mult", "3mult")


class ComplexMultiplier(wiring.Component):
    """``o = round_half_up(a * b, shift)``, pipelined, advancing when ``en``.

    Stage by stage (``4mult``): the operands into the multipliers' input
    registers, the products into their output registers (``MULT18X18D`` on
    ECP5), the products again into fabric registers (the multiplier's output
    routed straight into a carry chain limited a 200 MHz build), the
    difference and sum, the rounding: ``latency`` = CMULT_CYCLES["4mult"].
    ``3mult`` adds a fabric stage for its pre-additions in front. Both forms
    give identical integers: the products are exact.

    With ``operand_registers`` the operands are taken a clock earlier, into
    registers of the multiplier's own: at ``4mult`` each part of ``a`` and
    ``b`` feeds two multipliers, and one register for both was the latest
    path of a 16-channel build (6.6 ns, most of it the route to the farther
    multiplier). Each multiplier then has a copy of its two operands, kept
    apart in synthesis, beside it; ``latency`` is one more.

    Parameters
    ----------
    a_width, b_width : int
        Widths of the signed parts of ``a`` and ``b``.
    shift : int
        Bits dropped by the single rounding step (round half up: add
        ``2**(shift-1)``, arithmetic shift right).
    form : str
        ``"4mult"`` (four products) or ``"3mult"`` (pre-additions, three
        products).
    operand_registers : bool
        Register the operands first, a copy per multiplier (above).
    second_b : bool
        Take ``b`` twice (``b`` and ``b2``, the same value from logic of the
        caller's own): at ``4mult``, ``b`` feeds the ``rr`` and ``ii``
        products and ``b2`` the ``ir`` and ``ri``, so that each part of each
        copy feeds one multiplier. A caller whose ``b`` ends in an adder
        gives each multiplier's operand an adder beside it (one adder into
        two operand copies was among 16-channel builds' late paths, 5.4 ns).
        ``3mult`` takes ``b`` alone.

    Members
    -------
    en : In(1)
        Clock enable: the pipeline advances one step.
    a, b : In(IQ(a_width)), In(IQ(b_width))
    b2 : In(IQ(b_width))
        With ``second_b``: ``b`` again.
    o : Out(IQ(o_width))
        ``o_width = a_width + b_width + 1 - shift`` holds every result.
    """

    def __init__(self, a_width=16, b_width=16, shift=15, form="4mult", *, operand_registers=False,
                 second_b=False):
        for name, v in (("Operand A width", a_width), ("Operand B width", b_width)):
            if not isinstance(v, int) or isinstance(v, bool) or v <= 0:
                raise TypeError(f"{name} must be a positive integer, not {v!r}")
        full = a_width + b_width + 1
        # (a shift of full - 1 leaves a 1-bit result, and the largest sum,
        # 2**(a_width + b_width - 1), rounds up to 1: not a 1-bit signed value)
        if not isinstance(shift, int) or isinstance(shift, bool) or not 1 <= shift <= full - 2:
            raise ValueError(f"Rounding shift must be an integer in [1, {full - 2}], not {shift!r}")
        if form not in FORMS:
            raise ValueError(f"Complex multiplier form must be one of 4mult, 3mult, not {form!r}")
        if not isinstance(operand_registers, bool):
            raise TypeError(f"Operand registers must be a bool, not {operand_registers!r}")
        if not isinstance(second_b, bool):
            raise TypeError(f"Second B operand must be a bool, not {second_b!r}")
        self._a_width, self._b_width, self._shift, self._form = a_width, b_width, shift, form
        self._operand_registers = operand_registers
        self._second_b = second_b
        self._full_width = full
        self._o_width = full - shift
        super().__init__({
            "en": In(1),
            "a": In(IQ(a_width)),
            "b": In(IQ(b_width)),
            **({"b2": In(IQ(b_width))} if second_b else {}),
            "o": Out(IQ(self._o_width)),
        })

    @property
    def form(self):
        return self._form

    @property
    def shift(self):
        return self._shift

    @property
    def o_width(self):
        return self._o_width

    @property
    def latency(self):
        """Steps from ``a``/``b`` to ``o`` (CMULT_CYCLES of the form, one
        more with ``operand_registers``)."""
        return CMULT_CYCLES[self._form] + self._operand_registers

    def elaborate(self, platform):
        m = Module()
        a, b, en = self.a, self.b, self.en

        def operand(x, name):
            """``x`` as a multiplier takes it: with operand registers, from a
            register of its own that loads when ``en``."""
            if not self._operand_registers:
                return x
            held = Signal.like(x, name=f"{name}_held")
            q = kept_register(m, platform, Mux(en, x, held), name)
            m.d.comb += held.eq(q)
            return q.as_signed()

        def mul(name, x, y):
            unit = RegisteredMultiplier(len(x), len(y), input_reg=True)
            m.submodules[f"mul_{name}"] = unit
            m.d.comb += [unit.en.eq(en), unit.a.eq(x), unit.b.eq(y)]
            # the product again in a fabric register, next to the adders
            q = Signal.like(unit.o, name=f"p_{name}", reset_less=True)
            with m.If(en):
                m.d.sync += q.eq(unit.o)
            return q

        if self._form == "4mult":
            def product(name, x, y):
                return mul(name, operand(x, f"a_{name}"), operand(y, f"b_{name}"))
            b2 = self.b2 if self._second_b else b
            rr, ii = product("rr", a.re, b.re), product("ii", a.im, b.im)
            ri, ir = product("ri", a.re, b2.im), product("ir", a.im, b2.re)
            re_v, im_v = (rr, ii, True), (ri, ir, False)
        else:
            # each pre-addition's register feeds one multiplier already
            a_re, a_im = operand(a.re, "a_re"), operand(a.im, "a_im")
            b_re, b_im = operand(b.re, "b_re"), operand(b.im, "b_im")
            s1 = Signal(signed(self._a_width + 1), reset_less=True)   # a.re + a.im
            s2 = Signal(signed(self._b_width + 1), reset_less=True)   # b.im - b.re
            s3 = Signal(signed(self._b_width + 1), reset_less=True)   # b.re + b.im
            ar = Signal(signed(self._a_width), reset_less=True)
            ai = Signal(signed(self._a_width), reset_less=True)
            br = Signal(signed(self._b_width), reset_less=True)
            with m.If(en):
                m.d.sync += [s1.eq(a_re + a_im), s2.eq(b_im - b_re), s3.eq(b_re + b_im),
                             ar.eq(a_re), ai.eq(a_im), br.eq(b_re)]
            k1, k2, k3 = mul("k1", br, s1), mul("k2", ar, s2), mul("k3", ai, s3)
            re_v, im_v = (k1, k3, True), (k1, k2, False)

        # round_half_up((x -/+ y) / 2**s) = floor((x -/+ y + 2**(s-1)) / 2**s)
        # in two registered steps, each one carry chain: the low s bits'
        # sum and the high bits' sum side by side, then the high sum plus
        # the low sum's carry. The rounding constant rides in them: x_l +
        # 2**(s-1) is x_l with bit s-1 flipped plus x[s-1] at bit s, and
        # y_l - 2**(s-1) likewise, so x[s-1] (the sum) or not y[s-1] (the
        # difference, with -y = ~y + 1) is the high chain's carry in, and
        # the low sum is below 2**(s+1): its carry (bit s) is all the last
        # step adds. A carry in c is the bottom bit of both operands, the
        # sum taken from bit 1 (one chain, not an adder behind an adder).
        # The difference's are written as subtractions: high = x_h - y_h -
        # y[s-1], low = x_l - y_l + 2**(s-1) + y[s-1] * 2**s (the subtrahend
        # y_l - 2**(s-1) - y[s-1] * 2**s, modulo 2**(s+2), is y_l with bit
        # s-1 inverted and two ones above).
        # The last step adding floor((d + 2**(s-1)) / 2**s), -1 to 2 from
        # the low difference d's top bits, was a 16-channel build's latest
        # path at seed 3 (5.6 ns, 17 endpoints).
        s = self._shift
        for part, (x, y, subtract) in (("re", re_v), ("im", im_v)):
            low = Signal(s + 1, name=f"{part}_low", reset_less=True)
            high = Signal(signed(self._full_width - s + 1), name=f"{part}_high", reset_less=True)
            x_l, y_l, x_h, y_h = x[:s], y[:s], x >> s, y >> s
            if subtract:
                # (ECP5's carry cells invert a subtrahend themselves, while
                # an inverted operand of a sum is a LUT in front of the chain:
                # p_ii -> LUT -> the high chain was among the 16-channel
                # builds' latest paths at every seed, 5.0-5.4 ns)
                high_next = (Cat(C(0, 1), x_h).as_signed() - Cat(y[s - 1], y_h).as_signed()) >> 1
                low_next = Cat(x_l, C(0, 2)) - Cat(y_l[:s - 1], ~y_l[s - 1], C(0b11, 2))
            else:
                cin = x[s - 1]
                high_next = (Cat(cin, x_h).as_signed() + Cat(cin, y_h).as_signed()) >> 1
                low_next = Cat(x_l[:s - 1], ~x_l[s - 1]) + y_l
            with m.If(en):
                m.d.sync += [low.eq(low_next), high.eq(high_next),
                             getattr(self.o, part).eq(high + low[s])]
        return m
