"""Stream replay: one period of a windmill's modulation, replayed forever."""

from amaranth.hdl import Module, Signal, Cat, Mux, signed, unsigned
from amaranth.lib import wiring, data
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from .iq import IQ
from .ecp5_primitives import RegisteredRAM
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
        """Samples from the phase register to ``o``: 3, or 6 with interpolation."""
        return stream_latency(self._interpolate)

    def elaborate(self, platform):
        m = Module()
        D, F = self._depth, PHASE_FRAC_BITS
        en = self.en
        # Both banks in one RAM whose read data passes the block RAM's output
        # register (DP16KD OUTREG on ECP5); with interpolation a second copy
        # serves the second read port (both copies see every write).
        # The read address passes a register of its own next to the block RAMs
        # (``addr_reg``: one more sample of stream latency), so the phase logic
        # is not pulled towards the sixteen block RAMs it addresses (timing).
        rams = [RegisteredRAM(2 * STREAM_WIDTH, 2 * D, init=self._init, addr_reg=True)
                for _ in range(2 if self._interpolate else 1)]
        for k, ram in enumerate(rams):
            m.submodules[f"mem{k}" if k else "mem"] = ram
            m.d.comb += [ram.w_addr.eq(Cat(self.wr_addr, self.wr_bank)), ram.w_data.eq(self.wr_data),
                         ram.w_en.eq(self.wr_en)]

        idx = self.index
        # The active length is kept as ``length - 1`` (``len_m1``), so the wrap
        # test is an equality of two registers; ``active_length`` is derived.
        len_m1 = Signal(range(D), init=self._init_length - 1)
        m.d.comb += self.active_length.eq(len_m1 + 1)
        bank, pending = self.bank, self.pending
        frac = Signal(F)
        inc = Signal(F, init=self._init_increment)

        idx_n = Signal.like(idx); frac_n = Signal.like(frac); len_n = Signal.like(len_m1)
        inc_n = Signal.like(inc); bank_n = Signal(); pend_n = Signal()
        # ``acc`` is a register holding ``frac + inc`` (its successor computed
        # from registers), so the carry that decides a step or a wrap comes
        # straight from a flip-flop rather than from the end of a carry chain.
        acc = Signal(F + 1, init=self._init_increment)
        acc_n = Signal(F + 1)
        step = Signal(F + 1)
        carry = acc[F]
        wrap = Signal()
        wrap_swap = Signal()
        # (Timing: the compare against ``length - 1`` behind the carry chain
        # of ``frac + inc`` limited the block to 87 MHz.)
        m.d.comb += [acc_n.eq(acc), step.eq(acc[:F] + inc)]
        m.d.comb += [wrap.eq(carry & (idx == len_m1)),
                     wrap_swap.eq(en & pending & wrap),
                     idx_n.eq(idx), frac_n.eq(frac), len_n.eq(len_m1), inc_n.eq(inc),
                     bank_n.eq(bank), pend_n.eq(pending),
                     self.pending_next.eq(pending & ~wrap_swap),
                     self.bank_next.eq(bank ^ wrap_swap)]

        def switch(new_bank):
            return [bank_n.eq(new_bank), len_n.eq(self.length - 1), inc_n.eq(self.increment),
                    idx_n.eq(0), frac_n.eq(0), pend_n.eq(0), acc_n.eq(self.increment)]

        with m.If(en):
            with m.If(wrap_swap):
                m.d.comb += switch(~bank)
            with m.Elif(wrap):
                m.d.comb += [idx_n.eq(0), frac_n.eq(acc[:F]), acc_n.eq(step)]
            with m.Else():
                m.d.comb += [idx_n.eq(idx + carry), frac_n.eq(acc[:F]), acc_n.eq(step)]
        with m.If(self.swap_force):
            m.d.comb += switch(~self.bank_next)
        with m.Elif(self.swap_req):
            m.d.comb += pend_n.eq(1)
        m.d.sync += [idx.eq(idx_n), frac.eq(frac_n), len_m1.eq(len_n), inc.eq(inc_n),
                     bank.eq(bank_n), pending.eq(pend_n), acc.eq(acc_n)]

        w0 = Signal(IQ(STREAM_WIDTH))
        m.d.comb += [rams[0].r_addr.eq(Cat(idx, bank)), rams[0].r_en.eq(en), w0.eq(rams[0].r_data)]
        if not self._interpolate:
            m.d.comb += self.o.eq(w0)
            return m

        # Interpolation: a second read port at idx + 1 (mod length), itself a register.
        idx1 = Signal(range(D))
        m.d.sync += idx1.eq(Mux(idx_n == len_n, 0, idx_n + 1))
        w1 = Signal(IQ(STREAM_WIDTH))
        m.d.comb += [rams[1].r_addr.eq(Cat(idx1, bank)), rams[1].r_en.eq(en), w1.eq(rams[1].r_data)]
        # The fraction follows the words through the RAM's stages (one per
        # RAM latency sample), then meets the difference of the words.
        fds = [Signal(INTERP_FRAC_BITS, name=f"fd{k}") for k in range(rams[0].latency + 1)]
        fa = fds[-1]
        W = STREAM_WIDTH
        with m.If(en):
            m.d.sync += [fds[0].eq(frac[F - INTERP_FRAC_BITS:])]
            m.d.sync += [fds[k].eq(fds[k - 1]) for k in range(1, len(fds))]
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
