"""Stream replay: one period of a windmill's modulation, replayed forever."""

from amaranth.hdl import Module, Signal, Cat, Mux, signed, unsigned
from amaranth.lib import wiring, data
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from .iq import IQ
from ..model.fixedpoint import STREAM_WIDTH, PHASE_FRAC_BITS, INTERP_FRAC_BITS, stream_latency

__all__ = ["StreamReplay"]


class StreamReplay(wiring.Component):
    """Double-buffered stream RAM read by a rate accumulator.

    The phase ``idx + frac/2**32`` (words) advances by ``increment/2**32``
    per enabled sample (``increment < 2**32``: at most one word per sample)
    and wraps exactly at the active length: when ``frac + inc`` carries
    and ``idx == length - 1`` the index returns to 0. The word at ``idx``
    (linearly interpolated towards ``idx + 1`` with the top 16 fraction
    bits when ``interpolate``) is presented ``latency`` samples later on
    ``o`` and held between steps.

    Bank switch: ``swap_req`` marks a switch pending; it happens in the
    sample at which the active stream wraps (the period boundary).
    ``swap_force`` switches at once. A switch toggles the bank, latches
    ``length`` and ``increment`` and restarts the phase at 0.

    Parameters
    ----------
    depth : int
        Words per bank (power of two).
    interpolate : bool
    init : sequence of int
        Packed words of bank 0 at power-up.
    init_length, init_increment : int
        Active length and increment at power-up.

    Members
    -------
    en : In(1)
        Advance one sample.
    length : In(range(depth + 1)), increment : In(32)
        Values latched at the next bank switch (1 <= length <= depth).
    swap_req, swap_force : In(1)
    wr_en, wr_bank, wr_addr, wr_data : In
        Write port into the RAM (bank ``wr_bank``).
    o : Out(IQ(16))
    pending, bank : Out(1)
        Current state; ``pending_next``/``bank_next`` after this cycle's step.
    index, active_length : Out
        The read index and the active length (``index < active_length``).
    """

    def __init__(self, depth, *, interpolate=False, init=(), init_length=None, init_increment=0):
        if not isinstance(depth, int) or isinstance(depth, bool) or depth < 2 or depth & (depth - 1):
            raise ValueError(f"Stream depth must be a power of two of at least 2, not {depth!r}")
        if not isinstance(interpolate, bool):
            raise TypeError(f"Interpolate must be a bool, not {interpolate!r}")
        init = [int(w) & ((1 << 2 * STREAM_WIDTH) - 1) for w in init]
        if len(init) > depth:
            raise ValueError(f"Initial stream must have at most {depth} words, not {len(init)}")
        if init_length is None:
            init_length = max(1, len(init))
        if not isinstance(init_length, int) or not 1 <= init_length <= depth:
            raise ValueError(f"Initial length must be an integer in [1, {depth}], not {init_length!r}")
        if not isinstance(init_increment, int) or not 0 <= init_increment < (1 << PHASE_FRAC_BITS):
            raise ValueError(f"Initial increment must be an integer in [0, 2**{PHASE_FRAC_BITS}), "
                             f"not {init_increment!r}")
        self._depth = depth
        self._interpolate = interpolate
        self._init = init
        self._init_length = init_length
        self._init_increment = init_increment
        aw = (depth - 1).bit_length()
        super().__init__({
            "en": In(1),
            "length": In(range(depth + 1), init=init_length),
            "increment": In(PHASE_FRAC_BITS, init=init_increment),
            "swap_req": In(1),
            "swap_force": In(1),
            "wr_en": In(1),
            "wr_bank": In(1),
            "wr_addr": In(aw),
            "wr_data": In(2 * STREAM_WIDTH),
            "o": Out(IQ(STREAM_WIDTH)),
            "pending": Out(1),
            "bank": Out(1),
            "pending_next": Out(1),
            "bank_next": Out(1),
            "index": Out(range(depth)),
            "active_length": Out(range(depth + 1), init=init_length),
        })

    @property
    def depth(self):
        return self._depth

    @property
    def interpolate(self):
        return self._interpolate

    @property
    def latency(self):
        """Samples from the phase register to ``o``: 2, or 5 with interpolation."""
        return stream_latency(self._interpolate)

    def elaborate(self, platform):
        m = Module()
        D, F = self._depth, PHASE_FRAC_BITS
        en = self.en
        m.submodules.mem = mem = Memory(shape=unsigned(2 * STREAM_WIDTH), depth=2 * D,
                                        init=self._init)
        wr = mem.write_port()
        m.d.comb += [wr.addr.eq(Cat(self.wr_addr, self.wr_bank)), wr.data.eq(self.wr_data),
                     wr.en.eq(self.wr_en)]

        idx = self.index
        length = self.active_length
        bank, pending = self.bank, self.pending
        frac = Signal(F)
        inc = Signal(F, init=self._init_increment)

        idx_n = Signal.like(idx); frac_n = Signal.like(frac); len_n = Signal.like(length)
        inc_n = Signal.like(inc); bank_n = Signal(); pend_n = Signal()
        acc = Signal(F + 1)
        carry = acc[F]
        wrap = Signal()
        wrap_swap = Signal()
        m.d.comb += [acc.eq(frac + inc), wrap.eq(carry & (idx == length - 1)),
                     wrap_swap.eq(en & pending & wrap),
                     idx_n.eq(idx), frac_n.eq(frac), len_n.eq(length), inc_n.eq(inc),
                     bank_n.eq(bank), pend_n.eq(pending),
                     self.pending_next.eq(pending & ~wrap_swap),
                     self.bank_next.eq(bank ^ wrap_swap)]

        def switch(new_bank):
            return [bank_n.eq(new_bank), len_n.eq(self.length), inc_n.eq(self.increment),
                    idx_n.eq(0), frac_n.eq(0), pend_n.eq(0)]

        with m.If(en):
            with m.If(wrap_swap):
                m.d.comb += switch(~bank)
            with m.Elif(wrap):
                m.d.comb += [idx_n.eq(0), frac_n.eq(acc[:F])]
            with m.Else():
                m.d.comb += [idx_n.eq(idx + carry), frac_n.eq(acc[:F])]
        with m.If(self.swap_force):
            m.d.comb += switch(~self.bank_next)
        with m.Elif(self.swap_req):
            m.d.comb += pend_n.eq(1)
        m.d.sync += [idx.eq(idx_n), frac.eq(frac_n), length.eq(len_n), inc.eq(inc_n),
                     bank.eq(bank_n), pending.eq(pend_n)]

        rd0 = mem.read_port(domain="sync")
        w0 = Signal(IQ(STREAM_WIDTH))
        m.d.comb += [rd0.addr.eq(Cat(idx, bank)), rd0.en.eq(en)]
        # The RAM read registers have no defined power-up value (X in Icarus):
        # the first enabled sample keeps the word registers at their initial 0.
        primed = Signal()
        with m.If(en):
            m.d.sync += primed.eq(1)
            with m.If(primed):
                m.d.sync += w0.eq(rd0.data)
        if not self._interpolate:
            m.d.comb += self.o.eq(w0)
            return m

        # Interpolation: a second read port at idx + 1 (mod length), itself a register.
        idx1 = Signal(range(D))
        m.d.sync += idx1.eq(Mux(idx_n + 1 == len_n, 0, idx_n + 1))
        rd1 = mem.read_port(domain="sync")
        w1 = Signal(IQ(STREAM_WIDTH))
        m.d.comb += [rd1.addr.eq(Cat(idx1, bank)), rd1.en.eq(en)]
        fd1 = Signal(INTERP_FRAC_BITS); fd2 = Signal(INTERP_FRAC_BITS); fa = Signal(INTERP_FRAC_BITS)
        W = STREAM_WIDTH
        with m.If(en):
            m.d.sync += [fd1.eq(frac[F - INTERP_FRAC_BITS:]), fd2.eq(fd1), fa.eq(fd2)]
            with m.If(primed):
                m.d.sync += w1.eq(rd1.data)
        out = Signal(IQ(W))
        for part in ("re", "im"):
            diff = Signal(signed(W + 1), name=f"diff_{part}")
            s0a = Signal(signed(W), name=f"s0a_{part}")
            s0b = Signal(signed(W), name=f"s0b_{part}")
            prod = Signal(signed(W + 1 + INTERP_FRAC_BITS + 1), name=f"prod_{part}")
            with m.If(en):
                m.d.sync += [diff.eq(getattr(w1, part) - getattr(w0, part)),
                             s0a.eq(getattr(w0, part)),
                             prod.eq(diff * fa), s0b.eq(s0a),
                             getattr(out, part).eq(
                                 s0b + ((prod + (1 << (INTERP_FRAC_BITS - 1))) >> INTERP_FRAC_BITS))]
        m.d.comb += self.o.eq(out)
        return m
