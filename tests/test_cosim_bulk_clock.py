"""The bulk wrapper's two Verilator clockings do the same computation.

``rast.sim.runner.build(..., bulk=True)`` clocks the wrapper in bursts (every
change of ``tick`` runs ``BURST_CYCLES`` cycles inside one evaluation, the
default) or one cycle per period on ``clk`` (with waves). The same job on
both must pass the same scoreboard (every output sample against the model)
and end with the same summary: cycle count, sample counts and checksums of
every output. A burst that lost, added or reordered a cycle would change the
cycle count or the stall pattern's place in the run, and with it the
checksums' position weights.
"""

import json

import pytest

from rast.sim import bulk, runner
from rast.sim.scenario import TEST_CONTRACT
from rast.sim.top import top_sources

#: Cosimulations: left out of `make test-fast`, run by `make test` and CI.
pytestmark = pytest.mark.slow


#: One engine shape: the clocking is the wrapper's, the same whatever the DUT; M = 4 makes the
#: cycle count differ from the sample count, so a lost cycle cannot hide in a sample.
@pytest.mark.parametrize("slots", [4])
def test_burst_clock_and_clock_per_cycle_agree(slots):
    sources, top = top_sources(4, slots=slots, **TEST_CONTRACT)
    params = dict(kind="random", channels=4, seed=61 + slots, gap_thresh=48, stall_thresh=48,
                  interpolation="fir", pulses=20, contract=dict(TEST_CONTRACT, slots=slots))
    summaries = {}
    for clock in ("burst", "clk"):
        b = runner.build(sources, top, simulator="verilator", waves=False, bulk=True, bulk_clock=clock,
                         label=f"top4m{slots}fir")
        assert b.clock == clock
        run_dir = runner.run(b, "rast.sim.tb_top", name=f"clock-{clock}-m{slots}", testcase="replay_bulk",
                             extra_env={"RAST_TB_PARAMS": json.dumps(params)}, quiet=True)
        s = json.loads((run_dir / "perf.json").read_text())
        summaries[clock] = {k: v for k, v in s.items() if k not in ("wall_s", "cpu_s")}
    burst, per_cycle = summaries["burst"], summaries["clk"]
    assert burst == per_cycle
    # the job is long enough that the burst clock ran many bursts
    assert burst["cycles"] > 20 * bulk.BURST_CYCLES


def test_build_refuses_an_unknown_clock():
    with pytest.raises(ValueError, match=r"^bulk_clock must be 'burst' or 'clk', not 'fast'$"):
        runner.build({"x.v": "module x; endmodule\n"}, "x", simulator="verilator", bulk=True, bulk_clock="fast")
