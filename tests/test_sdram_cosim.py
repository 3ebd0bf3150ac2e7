"""Cosimulation of the SDRAM stream pool on LiteDRAM's own simulation core.

``sim/sdram_tb.py`` checks every answer (tag and word as integers, in order)
against a model memory, and every SDRAM command against the datasheet
timings, the init order and the refresh interval (see its docstring). The
injection tests show that each of those checks fails when it should.
"""

import json

import pytest

from rast.sim import runner
from rast.sim.sdram_top import TOPLEVEL, sdram_top_sources

#: Cosimulations: left out of `make test-fast`, run by `make test` and CI.
pytestmark = pytest.mark.slow

MODULE = "rast.sim.sdram_tb"


def run_pool(name, *, queue_depth=16, **tb):
    sources, core = sdram_top_sources(queue_depth=queue_depth)
    p = dict(seed=1, tags=64, stream_len=24, addr_width=core.port_addr_width, write_gap=4,
             verify_reads=64, ahead=13, play_cycles=6000, mixed_writes=False, drain_cycles=4000,
             init_timeout_cycles=200_000, tck_ns=core.timings["tck_ns"],
             timings_ns=core.timings["ns"], cl=core.cl, bankbits=core.geometry["bankbits"])
    p.update(tb)
    b = runner.build(sources, TOPLEVEL, simulator="verilator", label=f"sdram_pool_q{queue_depth}")
    run_dir = runner.run(b, MODULE, name=name, testcase="pool", quiet=True,
                         extra_env={"RAST_TB_PARAMS": json.dumps(p)})
    return json.loads((run_dir / "report.json").read_text())


def test_write_then_fetch():
    """Host writes 64 streams, host reads verify a sample, then 64 tags fetch
    (each keeping 13 ahead, so the pool is saturated and refuses): every answer
    is the word written, in order, with its tag; refresh runs throughout."""
    rep = run_pool("write_then_fetch", expect_refusals=True)
    print(json.dumps(rep, indent=1))
    assert rep["stats"]["fetches"] == rep["stats"]["answers"] > 200
    assert rep["stats"]["host_reads"] == 64
    assert rep["refreshes_after_init"] >= 10


def test_fetch_during_host_writes():
    """Fetches from 64 tags while host writes overwrite the very streams being
    fetched: each answer is the word written last before its fetch was taken."""
    rep = run_pool("mixed", mixed_writes=True, write_gap=6, seed=2, expect_refusals=True)
    print(json.dumps(rep, indent=1))
    # both saturate the pool; the host gets every other slot, neither starves
    assert rep["stats"]["play_writes"] > 50
    assert rep["stats"]["fetches"] == rep["stats"]["answers"] > 50


@pytest.mark.parametrize("inject, match", [
    ("corrupt", r"answer tag \d+ word 0x[0-9a-f]+, expected tag \d+ word"),
    ("reorder", r"answer tag \d+ word 0x[0-9a-f]+, expected tag"),
    ("timing", r"tRCD violated"),
])
def test_checks_can_fail(inject, match):
    """One wrong word, two answers swapped, a timing rule made stricter than
    LiteDRAM's schedule: each is caught."""
    extra = {"timing_scale": {"tRCD": 2.5}} if inject == "timing" else {}
    with pytest.raises(runner.SimulationFailed, match=match):
        run_pool(f"inject_{inject}", inject=inject, play_cycles=1500, **extra)


#: The engine's worst case (issue 10): fs = 20 MS/s, fclk = 200 MHz, one word
#: per channel per 768 samples at most = every 7680 engine clocks, 13 words
#: ahead in a 16-word cache, 64 channels.
ENGINE_PERIOD = 768 * 200 // 20


@pytest.mark.slow
@pytest.mark.parametrize("aligned", [False, True], ids=["staggered", "aligned"])
def test_engine_rate_with_host_write_burst(aligned):
    """64 channels at the highest stream rate, 13 words ahead, while the host
    writes back to back into the streams being played (far above the UART's
    rate) and refresh runs: no channel ever finds its cache empty. "aligned":
    all 64 channels consume in the same clock, the worst burst of fetches.
    The report (printed) gives the worst fetch latency, the worst time from a
    consumption to the cache being full again, and the least cache level."""
    rep = run_pool(f"engine_rate_{'aligned' if aligned else 'staggered'}", consume_period=ENGINE_PERIOD,
                   aligned=aligned, mixed_writes=True, write_gap=2,
                   play_cycles=2 * ENGINE_PERIOD + 40_000, drain_cycles=20_000)
    print(json.dumps({k: v for k, v in rep.items() if k != "latency_histogram"}, indent=1))
    assert rep["stats"]["consumed"] >= 2 * 64
    assert rep["stats"].get("underflows", 0) == 0
    assert rep["min_cached_at_consume"] >= 1
    # every refill well inside one word period (the deadline is 13 periods away)
    assert rep["max_refill_cycles"] < ENGINE_PERIOD


def test_underflow_is_caught():
    """The same check with one word ahead and a period far below what the pool
    can serve under a write burst: underflows are reported."""
    with pytest.raises(runner.SimulationFailed, match=r"underflows \(a channel consumed from an empty cache\)"):
        run_pool("underflow", consume_period=64, ahead=1, mixed_writes=True, write_gap=2,
                 play_cycles=6000)
