"""Properties of the bit-exact model itself (the gateware comparisons are in
test_hdl_replay_top.py)."""

import time

import numpy as np
import pytest

from rast.model.contract.datapath import ReplayModel
from rast.model.contract.fixedpoint import ReplayContract, pack_iq
from rast.model.contract.regmap import CTRL_ENABLE, CTRL_SWAP
from rast.model.contract.loadplan import stream_writes
from rast.model.contract.powerup import ChannelInit


def _random_session(seed, lookback=None):
    rng = np.random.default_rng(seed)
    c = ReplayContract(channels=3, pool_words=32, max_delay=30, max_tap=9,
                       interpolation=("hold", "linear", "fir")[seed % 3])
    inits = [ChannelInit(tuple(int(w) for w in pack_iq(rng.integers(-32768, 32768, 5),
                                                       rng.integers(-32768, 32768, 5))),
                         int(rng.integers(0, 1 << 32)), int(rng.integers(0, 1 << 17)),
                         int(rng.integers(0, 9)), True, 5 * l) for l in range(3)]
    m = ReplayModel(c, inits)
    if lookback is not None:
        m._lookback = lookback
    a = m.rmap.addr
    out = []
    for _ in range(150):
        n = int(rng.integers(1, 40))
        out.append(np.stack(m.run(rng.integers(-32768, 32768, n), rng.integers(-32768, 32768, n))))
        l = int(rng.integers(0, 3))
        r = rng.integers(0, 5)
        if r == 0:
            m.write(a("DELAY", l), int(rng.integers(0, 31))); m.write(a("APPLY"), 1)
        elif r == 1:
            m.write(a("GAIN", l), int(rng.integers(0, 1 << 17)))
        elif r == 2:
            n = c.min_stream_length + int(rng.integers(0, 3))
            for addr, value in stream_writes(m.rmap, l, int(rng.integers(0, 32 - n)),
                                             rng.integers(0, 1 << 32, n), int(rng.integers(0, 1 << 28))):
                m.write(addr, value)
            m.write(a("CTRL", l), CTRL_ENABLE | CTRL_SWAP)
        elif r == 3:
            m.write(a("CTRL", l), int(rng.integers(0, 4)))
    return np.concatenate(out, axis=1)


@pytest.mark.parametrize("seed", [1, 2])
def test_windowed_history_matches_full_history(seed):
    """run() only looks back a bounded number of steps; the result is the same
    as keeping the whole history."""
    assert (_random_session(seed) == _random_session(seed, lookback=10**12)).all()


def test_long_run_is_linear():
    c = ReplayContract(channels=4)
    m = ReplayModel(c, [ChannelInit((1, 2, 3), 1 << 30, 1 << 16, 5, True)] * 4)
    t0 = time.time()
    for _ in range(400):
        m.run(np.ones(1000, dtype=np.int64), np.zeros(1000, dtype=np.int64))
    assert time.time() - t0 < 20
    assert m.steps == 400_000
