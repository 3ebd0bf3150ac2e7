"""The model's timed-write runner (``ReplayModel.run_with_writes``) gives the same integers as
running up to every write's step and then writing, and does not depend on how a run is cut."""

import numpy as np

from rast.model.contract.datapath import ONE, ReplayModel
from rast.model.contract.fixedpoint import ReplayContract, pack_iq
from rast.model.contract.loadplan import stream_writes
from rast.model.contract.regmap import CTRL_ENABLE, CTRL_SWAP
from rast.sim import scenario


def _write_by_write(contract, xi, xq, writes):
    """The reference: run up to each write's step, then write."""
    m = ReplayModel(contract)
    ys, done = [], 0
    for step, addr, value in writes:
        if step > done:
            ys.append(np.stack(m.run(xi[done:step], xq[done:step])))
            done = step
        m.write(addr, value)
    ys.append(np.stack(m.run(xi[done:], xq[done:])))
    return np.concatenate(ys, axis=1), m.overflow


def _timed(contract, xi, xq, writes):
    m = ReplayModel(contract)
    return np.stack(m.run_with_writes(xi, xq, writes)), m.overflow


def test_random_scenarios_equal_the_write_by_write_reference():
    for seed in (3, 7, 11):
        sc = scenario.random_scenario(4, seed=seed)
        xi, xq = scenario.job_inputs(sc.job)
        want, ov_want = _write_by_write(sc.contract, xi, xq, sc.job.regs)
        got, ov_got = _timed(sc.contract, xi, xq, sc.job.regs)
        assert got.shape == want.shape
        assert np.array_equal(got, want), f"seed {seed}: {np.count_nonzero((got != want).any(axis=0))} steps differ"
        assert ov_got == ov_want


def test_a_word_written_while_a_switch_is_pending_lands_at_its_step():
    """Stream B is switched to (pending until A's period ends), then one of B's words is
    overwritten after that boundary: the channel plays the word B held at the switch. Applying
    the late write early (as the runner may when no switch is pending) would change the output,
    which the first assertion shows; the runner must not."""
    c = ReplayContract(channels=1, pool_words=256, max_delay=16, max_tap=16, interpolation="hold")
    rmap = ReplayModel(c).rmap
    a = rmap.addr
    rng = np.random.default_rng(5)
    words_a = pack_iq(rng.integers(-3000, 3000, 32), rng.integers(-3000, 3000, 32))
    words_b = pack_iq(rng.integers(-3000, 3000, 40), rng.integers(-3000, 3000, 40))
    inc = ONE // 4                                       # a quarter word per sample: A's period is 128 samples
    load = ([(0, w, v) for w, v in stream_writes(rmap, 0, 0, words_a, inc)]
            + [(0, a("CTRL", 0), CTRL_SWAP), (0, a("CTRL", 0), CTRL_ENABLE), (0, a("GAIN", 0), 1 << 15)])
    switch = ([(1000, w, v) for w, v in stream_writes(rmap, 0, 100, words_b, inc)]
              + [(1000, a("CTRL", 0), CTRL_ENABLE | CTRL_SWAP)])
    late_step = 1300                                      # after A's period boundary at or after step 1000
    late = [(late_step, a("STREAM_ADDR"), 100), (late_step, a("STREAM_DATA"), int(words_b[0]) ^ 0x7FFF7FFF)]
    n = 4000
    xi = np.full(n, 9000, dtype=np.int64)
    xq = np.zeros(n, dtype=np.int64)

    want, _ = _write_by_write(c, xi, xq, load + switch + late)
    early, _ = _write_by_write(c, xi, xq, load + switch + [(1000, addr, v) for _, addr, v in late])
    assert not np.array_equal(want, early), "the case does not tell a late write from an early one"
    got, _ = _timed(c, xi, xq, load + switch + late)
    assert np.array_equal(got, want)


def test_a_run_cut_in_pieces_gives_the_same_integers(monkeypatch):
    sc = scenario.random_scenario(4, seed=3)
    whole = scenario.model_outputs(sc)
    monkeypatch.setattr(ReplayModel, "CHUNK", 743)
    pieces = scenario.model_outputs(sc)
    assert len(whole[0]) > 10 * 743
    np.testing.assert_array_equal(whole[0], pieces[0])
    np.testing.assert_array_equal(whole[1], pieces[1])
    assert whole[2] == pieces[2]
