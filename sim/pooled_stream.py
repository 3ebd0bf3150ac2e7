"""One :class:`StreamReplay` with a stream pool of its own, for unit tests.

The replay top serves many channels from one pool through a fetch scan; this
wrapper gives a single channel the same path (request register, the pool,
answer register), granting every clock, and exposes the pool's write port, so
the stream logic can be tested on its own (Amaranth simulator and cocotb).
"""

from amaranth.hdl import Module
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from rast.hdl.iq import IQ
from rast.hdl.stream_pool import StreamPool
from rast.hdl.stream_replay import StreamReplay, FETCH_TAG
from rast.model.fixedpoint import STREAM_WIDTH, PHASE_FRAC_BITS

__all__ = ["PooledStream"]


class PooledStream(wiring.Component):
    """A stream replay and its pool (``pool`` words, ``init`` from address 0).

    Members
    -------
    en, base, length, increment, swap_req, swap_force : In, as :class:`StreamReplay`
    wr_en : In(1), wr_addr : In(pool address), wr_data : In(32)
        The pool's write port.
    o, index, bank, pending, active_length : Out, as :class:`StreamReplay`
    """

    def __init__(self, pool_words, *, interpolation="fir", init=(), init_base=0, init_length=None,
                 init_increment=0):
        self.stream = StreamReplay(pool_words, channels=1, interpolation=interpolation,
                                   init_base=init_base, init_length=init_length,
                                   init_increment=init_increment)
        self.pool = StreamPool(pool_words, FETCH_TAG.size, init=init)
        aw = (pool_words - 1).bit_length()
        s = self.stream
        super().__init__({
            "en": In(1), "base": In(aw, init=init_base),
            "length": In(range(pool_words + 1), init=s.active_length.init),
            "increment": In(PHASE_FRAC_BITS, init=init_increment),
            "swap_req": In(1), "swap_force": In(1),
            "wr_en": In(1), "wr_addr": In(aw), "wr_data": In(2 * STREAM_WIDTH),
            "o": Out(IQ(STREAM_WIDTH)), "index": Out(range(pool_words)), "bank": Out(1),
            "pending": Out(1), "active_length": Out(range(pool_words + 1), init=s.active_length.init),
        })

    @property
    def latency(self):
        return self.stream.latency

    def elaborate(self, platform):
        m = Module()
        m.submodules.stream = s = self.stream
        m.submodules.pool = p = self.pool
        m.d.comb += [s.en.eq(self.en), s.base.eq(self.base), s.length.eq(self.length),
                     s.increment.eq(self.increment), s.swap_req.eq(self.swap_req),
                     s.swap_force.eq(self.swap_force), s.fetch_grant.eq(1),
                     p.w_en.eq(self.wr_en), p.w_addr.eq(self.wr_addr), p.w_data.eq(self.wr_data),
                     self.o.eq(s.o), self.index.eq(s.index), self.bank.eq(s.bank),
                     self.pending.eq(s.pending), self.active_length.eq(s.active_length)]
        # request register, the pool, answer register: as in the replay top
        m.d.sync += [p.r_valid.eq(s.fetch_want), p.r_addr.eq(s.fetch_addr), p.r_tag.eq(s.fetch_tag),
                     s.fill_en.eq(p.d_valid), s.fill_tag.eq(p.d_tag), s.fill_data.eq(p.d_data)]
        return m
