"""The wind-farm replay block of seed Fig. 2.2: N channels, one output."""

from amaranth.hdl import Module, Signal, Mux, Cat, signed
from amaranth.lib import wiring, stream, data
from amaranth.lib.wiring import In, Out

from .iq import IQ
from .cmult import ComplexMultiplier
from .delay_line import DelayLine
from .stream_replay import StreamReplay, FETCH_TAG
from .stream_pool import StreamPool
from .registers import BusSignature, RegisterFile
from .ecp5_primitives import RegisteredMultiplier
from ..model.fixedpoint import (ReplayContract, INPUT_WIDTH, STREAM_WIDTH, OUTPUT_WIDTH,
                                PRODUCT_SHIFT, GAIN_SHIFT, SCALED_WIDTH, POOL_FETCH_LATENCY,
                                sum_latency)
from ..model.regmap import register_map
from ..model.powerup import ChannelInit, pool_contents

__all__ = ["WindFarmReplay"]


class WindFarmReplay(wiring.Component):
    """Replay block: a common delay line, then per channel a tap of the delay
    window, stream x gain; an adder tree, saturation. The streams sit in one
    pool, fetched into per-channel caches by a scan.

    The data path advances once per accepted input sample; each input sample
    gives exactly one output sample, ``latency`` (plus COMMON_DELAY and the
    channel's DELAY) samples later, whatever the gaps in ``i.valid`` or
    ``o.ready``. Each channel's window is its own RAM copy (written with the
    common line's output, read at the channel's tap), so any number of
    channels may share a tap.
    Bit-exact model: :class:`rast.model.datapath.ReplayModel`.

    Parameters
    ----------
    channels : int
        N, 1 to 64.
    pool_words, max_delay, max_tap, interpolation, cmult_form, sample_rate_hz :
        See :class:`rast.model.fixedpoint.ReplayContract`.
    init : list of ChannelInit, optional
        Power-up streams (in the pool at their bases) and register values.
    init_common_delay : int
        Power-up COMMON_DELAY.

    Members
    -------
    i : In(stream.Signature(IQ(16)))
    o : Out(stream.Signature(IQ(16)))
    bus : In(BusSignature(addr_width))
        Register access (map: ``rast.model.regmap``, ``docs/registers.md``).
    overflow : Out(1)
        Sticky saturation flag (cleared by reading STATUS).
    """

    def __init__(self, channels=4, *, pool_words=ReplayContract.pool_words,
                 max_delay=ReplayContract.max_delay, max_tap=ReplayContract.max_tap,
                 interpolation="fir", cmult_form="4mult", sample_rate_hz=0, init=None,
                 init_common_delay=0):
        self._contract = ReplayContract(channels=channels, pool_words=pool_words,
                                        max_delay=max_delay, max_tap=max_tap,
                                        interpolation=interpolation, cmult_form=cmult_form,
                                        sample_rate_hz=sample_rate_hz)
        init = list(init or [])
        if len(init) > channels:
            raise ValueError(f"Initial contents must be given for at most {channels} channels, "
                             f"not {len(init)}")
        for k, ini in enumerate(init):
            if not isinstance(ini, ChannelInit):
                raise TypeError(f"Initial contents of channel {k} must be a ChannelInit, not {ini!r}")
        self._init = init + [ChannelInit()] * (channels - len(init))
        self._pool_init = pool_contents(init, pool_words) if any(ini.words for ini in init) else []
        if not isinstance(init_common_delay, int) or not 0 <= init_common_delay <= max_delay:
            raise ValueError(f"Initial common delay must be an integer in [0, {max_delay}], "
                             f"not {init_common_delay!r}")
        self._rmap = register_map(self._contract, self._init, init_common_delay)
        super().__init__({
            "i": In(stream.Signature(IQ(INPUT_WIDTH))),
            "o": Out(stream.Signature(IQ(OUTPUT_WIDTH))),
            "bus": In(BusSignature(self._rmap.addr_width)),
            "overflow": Out(1),
        })

    @property
    def contract(self) -> ReplayContract:
        return self._contract

    @property
    def init_common_delay(self) -> int:
        """Power-up COMMON_DELAY."""
        return self._rmap.reg("COMMON_DELAY").field("delay").reset

    @property
    def register_map(self):
        return self._rmap

    @property
    def channels(self):
        return self._contract.channels

    @property
    def latency(self):
        """Fixed latency L (samples): ``6 + cmult latency + 2 + sum_latency(N)``."""
        return self._contract.latency

    def elaborate(self, platform):
        m = Module()
        c = self._contract
        N = c.channels
        m.submodules.regs = regs = RegisterFile(self._rmap)
        wiring.connect(m, wiring.flipped(self.bus), regs.bus)
        m.d.comb += self.overflow.eq(regs.overflow)

        ce = Signal()
        m.d.comb += [self.i.ready.eq(~self.o.valid | self.o.ready),
                     ce.eq(self.i.valid & self.i.ready)]
        with m.If(ce):
            m.d.sync += self.o.valid.eq(1)
        with m.Elif(self.o.ready):
            m.d.sync += self.o.valid.eq(0)

        # The pool: host writes from the register file; fetches from a scan
        # that offers each channel in turn one request per clock (one-hot
        # ``scan``), registered, and answers broadcast to the channels,
        # registered, with the channel in the tag.
        fetch_tag = data.StructLayout({"fetch": FETCH_TAG, "channel": range(max(2, N))})
        m.submodules.pool = pool = StreamPool(c.pool_words, fetch_tag.size, init=self._pool_init)
        m.d.comb += [pool.w_en.eq(regs.wr_en), pool.w_addr.eq(regs.wr_addr), pool.w_data.eq(regs.wr_data)]
        scan = Signal(N, init=1)
        m.d.sync += scan.eq(scan.rotate_left(1))
        req_valid = Signal()
        req_addr = Signal.like(pool.r_addr)
        req_tag = Signal(fetch_tag)
        fill_valid = Signal()
        fill_tag = Signal(fetch_tag)
        fill_data = Signal.like(pool.d_data)
        m.d.comb += [pool.r_valid.eq(req_valid), pool.r_addr.eq(req_addr), pool.r_tag.eq(req_tag)]
        m.d.sync += [fill_valid.eq(pool.d_valid), fill_tag.eq(pool.d_tag), fill_data.eq(pool.d_data)]
        # Grant to cache write: request register, the pool, answer register.
        assert 1 + pool.latency + 1 <= POOL_FETCH_LATENCY, "the contract's fetch latency is too short"
        grants = []

        SW = c.sum_width
        m.submodules.common = common = DelayLine(2 * INPUT_WIDTH, c.max_delay)
        m.d.comb += [common.en.eq(ce), common.i.eq(self.i.payload.as_value()),
                     common.delay.eq(regs.common_delay)]
        leaves = []
        for l in range(N):
            seg = DelayLine(2 * INPUT_WIDTH, c.max_tap)
            # Power-up BASE, LENGTH and PHASE_INC as the register map clamps them.
            sr = StreamReplay(c.pool_words, channels=N, interpolation=c.interpolation,
                              init_base=self._rmap.reg("BASE", l).field("base").reset,
                              init_length=self._rmap.reg("LENGTH", l).field("length").reset,
                              init_increment=self._rmap.reg("PHASE_INC", l).field("inc").reset)
            cm = ComplexMultiplier(INPUT_WIDTH, STREAM_WIDTH, PRODUCT_SHIFT, c.cmult_form)
            m.submodules[f"seg{l}"] = seg
            m.submodules[f"stream{l}"] = sr
            m.submodules[f"cmult{l}"] = cm
            m.d.comb += [
                seg.en.eq(ce), seg.i.eq(common.o), seg.delay.eq(regs.delay[l]),
                sr.en.eq(ce), sr.length.eq(regs.length[l]), sr.increment.eq(regs.increment[l]),
                sr.base.eq(regs.base[l]),
                sr.swap_req.eq(regs.swap_req[l]), sr.swap_force.eq(regs.swap_force[l]),
                sr.fetch_grant.eq(scan[l]),
                sr.fill_en.eq(fill_valid & (fill_tag.channel == l)),
                sr.fill_tag.eq(fill_tag.fetch), sr.fill_data.eq(fill_data),
                regs.pending_next[l].eq(sr.pending_next), regs.bank_next[l].eq(sr.bank_next),
                cm.en.eq(ce), cm.a.eq(seg.o), cm.b.eq(sr.o),
            ]
            grant = Signal(name=f"grant{l}")
            m.d.comb += grant.eq(scan[l] & sr.fetch_want)
            with m.If(grant):
                m.d.sync += [req_addr.eq(sr.fetch_addr), req_tag.fetch.eq(sr.fetch_tag),
                             req_tag.channel.eq(l)]
            grants.append(grant)

            # Gain (0 when disabled): registered product, registered rounding.
            geff = Signal(regs.gain[l].shape(), name=f"geff{l}")
            m.d.comb += geff.eq(Mux(regs.enable[l], regs.gain[l], 0))
            q = []
            for part in ("re", "im"):
                # The gain (unsigned) enters the signed multiplier with a zero sign bit.
                mul = RegisteredMultiplier(cm.o_width, geff.shape().width + 1)
                m.submodules[f"gmul{l}_{part}"] = mul
                m.d.comb += [mul.en.eq(ce), mul.a.eq(getattr(cm.o, part)), mul.b.eq(geff)]
                prod = mul.o
                qv = Signal(signed(SCALED_WIDTH), name=f"q{l}_{part}")
                with m.If(ce):
                    m.d.sync += qv.eq((prod + (1 << (GAIN_SHIFT - 1))) >> GAIN_SHIFT)
                q.append(qv)
            leaves.append(q)

        m.d.sync += req_valid.eq(Cat(*grants).any())

        # Adder tree: one registered level per halving (pairs added, an odd
        # one registered alone), at least one level; sum_latency(N) in all.
        level, depth = leaves, 0
        while depth < sum_latency(N):
            nxt = []
            for j in range(0, len(level), 2):
                pair = level[j:j + 2]
                s = [Signal(signed(SW), name=f"sum{depth}_{j // 2}_{p}") for p in ("re", "im")]
                with m.If(ce):
                    m.d.sync += [s[k].eq(sum(v[k] for v in pair)) for k in range(2)]
                nxt.append(s)
            level, depth = nxt, depth + 1
        assert len(level) == 1
        chain = level[0]

        lo, hi = -(1 << (OUTPUT_WIDTH - 1)), (1 << (OUTPUT_WIDTH - 1)) - 1
        sat = []
        for k, part in enumerate(("re", "im")):
            v = chain[k]
            over = Signal(name=f"over_{part}")
            under = Signal(name=f"under_{part}")
            m.d.comb += [over.eq(v > hi), under.eq(v < lo)]
            with m.If(ce):
                m.d.sync += getattr(self.o.payload, part).eq(
                    Mux(over, hi, Mux(under, lo, v)))
            sat.append(over | under)
        m.d.comb += regs.overflow_set.eq(ce & (sat[0] | sat[1]))
        return m
