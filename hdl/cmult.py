"""Pipelined complex multiplier: full-precision product, one rounding step."""

from amaranth.hdl import Module, Signal, signed
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from .iq import IQ

__all__ = ["ComplexMultiplier"]

FORMS = ("4mult", "3mult")


class ComplexMultiplier(wiring.Component):
    """``o = round_half_up(a * b, shift)``, pipelined, advancing when ``en``.

    Parameters
    ----------
    a_width, b_width : int
        Widths of the signed parts of ``a`` and ``b``.
    shift : int
        Bits dropped by the single rounding step (round half up: add
        ``2**(shift-1)``, arithmetic shift right).
    form : str
        ``"4mult"``: four products, two additions (latency 3).
        ``"3mult"``: pre-additions, three products, two additions (latency 4).
        Both give identical integers: the products are exact.

    Members
    -------
    en : In(1)
        Clock enable: the pipeline advances one sample.
    a, b : In(IQ(a_width)), In(IQ(b_width))
    o : Out(IQ(o_width))
        ``o_width = a_width + b_width + 1 - shift`` holds every result.
    """

    def __init__(self, a_width=16, b_width=16, shift=15, form="4mult"):
        for name, v in (("Operand A width", a_width), ("Operand B width", b_width)):
            if not isinstance(v, int) or isinstance(v, bool) or v <= 0:
                raise TypeError(f"{name} must be a positive integer, not {v!r}")
        full = a_width + b_width + 1
        if not isinstance(shift, int) or isinstance(shift, bool) or not 1 <= shift < full:
            raise ValueError(f"Rounding shift must be an integer in [1, {full - 1}], not {shift!r}")
        if form not in FORMS:
            raise ValueError(f"Complex multiplier form must be one of 4mult, 3mult, not {form!r}")
        self._a_width, self._b_width, self._shift, self._form = a_width, b_width, shift, form
        self._full_width = full
        self._o_width = full - shift
        super().__init__({
            "en": In(1),
            "a": In(IQ(a_width)),
            "b": In(IQ(b_width)),
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
        """Samples from ``a``/``b`` to ``o``: 3 (``4mult``) or 4 (``3mult``)."""
        return 3 if self._form == "4mult" else 4

    def elaborate(self, platform):
        m = Module()
        fw = self._full_width
        a, b, en = self.a, self.b, self.en
        re = Signal(signed(fw))
        im = Signal(signed(fw))
        if self._form == "4mult":
            rr = Signal(signed(fw)); ii = Signal(signed(fw))
            ri = Signal(signed(fw)); ir = Signal(signed(fw))
            with m.If(en):
                m.d.sync += [rr.eq(a.re * b.re), ii.eq(a.im * b.im),
                             ri.eq(a.re * b.im), ir.eq(a.im * b.re)]
                m.d.sync += [re.eq(rr - ii), im.eq(ri + ir)]
        else:
            s1 = Signal(signed(self._a_width + 1))   # a.re + a.im
            s2 = Signal(signed(self._b_width + 1))   # b.im - b.re
            s3 = Signal(signed(self._b_width + 1))   # b.re + b.im
            ar = Signal(signed(self._a_width)); ai = Signal(signed(self._a_width))
            br = Signal(signed(self._b_width))
            k1 = Signal(signed(fw)); k2 = Signal(signed(fw)); k3 = Signal(signed(fw))
            with m.If(en):
                m.d.sync += [s1.eq(a.re + a.im), s2.eq(b.im - b.re), s3.eq(b.re + b.im),
                             ar.eq(a.re), ai.eq(a.im), br.eq(b.re)]
                m.d.sync += [k1.eq(br * s1), k2.eq(ar * s2), k3.eq(ai * s3)]
                m.d.sync += [re.eq(k1 - k3), im.eq(k1 + k2)]
        half = 1 << (self._shift - 1)
        with m.If(en):
            m.d.sync += [self.o.re.eq((re + half) >> self._shift),
                         self.o.im.eq((im + half) >> self._shift)]
        return m
