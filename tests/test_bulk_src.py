"""src.hex holds one pulse when every pulse is the same, and the wrapper's
reading of it (in order, wrapping at its end, ``active`` words per PRI) gives
the DUT the job's input sequence either way."""

import numpy as np

from rast.sim import bulk
from rast.sim.bulk import BulkJob
from rast.sim.scenario import job_inputs


def _read_as_wrapper(directory, job):
    """The input words the wrapper feeds, from the files write_job wrote."""
    cfg = [int(x, 16) for x in (directory / "cfg.hex").read_text().split()]
    n_src = cfg[bulk.CFG_FIELDS.index("n_src")]
    src = np.array([int(x, 16) for x in (directory / "src.hex").read_text().split()], dtype=np.int64)
    assert len(src) == n_src
    words = np.zeros(job.n_in, dtype=np.int64)
    ptr = 0
    for p in range(job.pulses):
        for k in range(job.active):
            words[p * job.pri + k] = src[ptr]
            ptr = 0 if ptr + 1 == n_src else ptr + 1
    return words


def _job(src, active=5, pri=12, pulses=7):
    return BulkJob(src=np.asarray(src, dtype=np.uint64), active=active, pri=pri, pulses=pulses, flush=3)


def _fed(job):
    i, q = job_inputs(job)
    return (i & 0xFFFF) | ((q & 0xFFFF) << 16)


def test_identical_pulses_are_written_once(tmp_path):
    rng = np.random.default_rng(3)
    pulse = rng.integers(0, 1 << 32, 5, dtype=np.uint64)
    job = _job(np.tile(pulse, 7))
    bulk.write_job(job, tmp_path)
    assert len((tmp_path / "src.hex").read_text().split()) == 5
    assert np.array_equal(_read_as_wrapper(tmp_path, job), _fed(job))


def test_pulses_that_differ_are_written_whole(tmp_path):
    rng = np.random.default_rng(4)
    src = np.tile(rng.integers(0, 1 << 32, 5, dtype=np.uint64), 7)
    src[-1] ^= np.uint64(1)                      # the last pulse differs in one bit
    job = _job(src)
    bulk.write_job(job, tmp_path)
    assert len((tmp_path / "src.hex").read_text().split()) == 35
    assert np.array_equal(_read_as_wrapper(tmp_path, job), _fed(job))


def test_a_src_shorter_than_the_pulses_is_kept(tmp_path):
    job = _job(np.arange(3, dtype=np.uint64) + 1)      # wraps within each pulse: not a pulse per period
    assert np.array_equal(bulk.src_words(job), job.src)
    bulk.write_job(job, tmp_path)
    assert np.array_equal(_read_as_wrapper(tmp_path, job), _fed(job))
