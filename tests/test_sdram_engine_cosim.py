"""Cosimulation of the replay engine with its stream pool in SDRAM
(``WindFarmReplay(pool="sdram")`` on LiteDRAM's simulation core, controller
clock = fabric / 4) against the bit-exact model: streams loaded through the
bus into the SDRAM while the engine runs (each checked by its CRC-32 before
its switch, a quarter of the mid-run reloads damaged and refused), reloads
and forced switches mid-run, refresh running, valid gaps and ready stalls.
Every output sample is compared as an integer; the pool's error flag (a
fetch or word without room, an answer lost) must stay low.

The model knows nothing of SDRAM: it plays each stream after the contract's
refill (``ReplayContract(pool="sdram").refill_samples``), so a word that
arrives later than the contract's bound shows up as a mismatch.
"""

import pytest

from rast.sim import runner
from rast.sim.pytest_support import cocotb_run
from rast.sim.scenario import TEST_CONTRACT
from rast.sim.top import sdram_engine_top_sources

MODULE = "rast.sim.tb_top"


def _run(channels, kind, seed, *, slots, pulses, gaps=(48, 48), model_pool="sdram"):
    contract = dict(TEST_CONTRACT, slots=slots)
    sources, top = sdram_engine_top_sources(channels, **contract)
    cocotb_run(sources, top, MODULE, "replay_bulk_sdram", simulator="verilator", bulk=True,
               label=f"sdram_engine{channels}m{slots}", name=f"sdram-{kind}-{channels}ch-m{slots}-s{seed}",
               tb_params=dict(kind=kind, channels=channels, seed=seed, gap_thresh=gaps[0],
                              stall_thresh=gaps[1], pulses=pulses, contract=dict(contract, pool=model_pool)))


@pytest.mark.parametrize("kind, seed", [("random", 71), ("farm", 72)])
def test_engine_on_sdram_time_multiplexed(kind, seed):
    _run(5, kind, seed, slots=4, pulses=60)


def test_a_model_that_expects_block_ram_latency_sees_the_sdram_one():
    """The same gateware scoreboarded against a model with the block-RAM
    pool's contract (its refill of a few samples after a switch): the SDRAM's
    latency must show as mismatches, so the comparison above can fail."""
    with pytest.raises(runner.SimulationFailed, match=r"mismatch|differ"):
        _run(5, "random", 71, slots=4, pulses=60, model_pool="bram")
