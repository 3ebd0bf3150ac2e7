"""Cosimulation of the replay engine with its stream pool in SDRAM
(``WindFarmReplay(pool="sdram")`` on LiteDRAM's simulation core, controller
clock = fabric / 4 as on the 200 MHz board, or / 3.2 as on the 160 MHz one)
against the bit-exact model: streams loaded through the
bus into the SDRAM while the engine runs (each checked by its CRC-32 before
its switch, a quarter of the mid-run reloads damaged and refused), reloads
and forced switches mid-run, refresh running, valid gaps and ready stalls.
Every output sample is compared as an integer; the pool's error flag (a
fetch or word without room, an answer lost) must stay low.

The model knows nothing of SDRAM: it plays each stream after the contract's
refill (``ReplayContract(pool="sdram").refill_samples``), so a word that
arrives later than the contract's bound shows up as a mismatch.
"""

import json
from pathlib import Path

import pytest

from rast.sim import runner
from rast.sim.pytest_support import cocotb_run
from rast.sim.scenario import TEST_CONTRACT
from rast.sim.top import sdram_engine_top_sources

#: Cosimulations: left out of `make test-fast`, run by `make test` and CI.
pytestmark = pytest.mark.slow

MODULE = "rast.sim.tb_top"


def _run(channels, kind, seed, *, slots, pulses, gaps=(48, 48), model_pool="sdram", interpolation="fir",
         sample_rate_hz=0, fabric_per_sdram=None):
    contract = dict(TEST_CONTRACT, slots=slots, sample_rate_hz=sample_rate_hz)
    sources, top = sdram_engine_top_sources(channels, interpolation=interpolation,
                                            fabric_per_sdram=fabric_per_sdram, **contract)
    ratio = f"r{fabric_per_sdram}".replace("/", "_") if fabric_per_sdram is not None else ""
    cocotb_run(sources, top, MODULE, "replay_bulk_sdram", simulator="verilator", bulk=True,
               label=f"sdram_engine{channels}m{slots}{interpolation}{sample_rate_hz or ''}{ratio}", name=f"sdram-{kind}-{channels}ch-m{slots}-s{seed}",
               tb_params=dict(kind=kind, channels=channels, seed=seed, gap_thresh=gaps[0],
                              stall_thresh=gaps[1], pulses=pulses, interpolation=interpolation, contract=dict(contract, pool=model_pool)))


@pytest.mark.parametrize("kind, seed, pulses", [("random", 71, 60), ("farm", 72, 30)])
def test_engine_on_sdram_time_multiplexed(kind, seed, pulses):
    _run(5, kind, seed, slots=4, pulses=pulses)


def test_a_model_that_expects_block_ram_latency_sees_the_sdram_one():
    """The same gateware scoreboarded against a model with the block-RAM
    pool's contract (its refill of a few samples after a switch): the SDRAM's
    latency must show as mismatches, so the comparison above can fail."""
    with pytest.raises(runner.SimulationFailed, match=r"mismatch|differ"):
        _run(5, "random", 71, slots=4, pulses=60, model_pool="bram")


def test_worst_fetch_schedule_starves_no_channel():
    """docs/sdram.md's worst case: 12 channels (3 pipelines of 4 slots) all at
    the highest stream rate, which for linear interpolation is the SDRAM
    bandwidth bound; every cache refilled at once twice; a quarter-pool
    stream written back to back by the host while all play. A word later
    than the contract's bound would be a mismatch."""
    _run(12, "worst", 73, slots=4, pulses=80, gaps=(0, 0), interpolation="linear")


def test_worst_fetch_schedule_at_the_160_mhz_board_clocks():
    """The same worst case for the 160 MHz board (`rast build --sdram
    --clock-mhz 160`: 8 slots at 20 MS/s, the controller at 50 MHz): the
    contract's bounds scale by 160 / 50 = 3.2 fabric clocks a controller
    clock, so its highest stream rate and refill are those of that board, and
    the simulated controller runs at that ratio (five clocks in every 16
    fabric clocks), not at the 200 MHz board's 4."""
    _run(12, "worst", 74, slots=8, pulses=80, gaps=(0, 0), interpolation="linear",
         sample_rate_hz=20_000_000)


def test_a_prefetch_below_the_bound_raises_the_underflow_flag():
    """The engine built for a 1 MHz fabric (250 kS/s x 4 slots), so that its
    contract counts on an SDRAM 50 times faster than the fabric (a fetch
    bound of 34 clocks, a refill of 102 samples), run with the controller at
    a quarter of the fabric clock: after the switches at the start the words
    come later than the refill, the channels read them before they are there,
    and STATUS.underflow says so (the flag is checked before the samples)."""
    with pytest.raises(runner.SimulationFailed, match=r"underflow': 1"):
        _run(5, "random", 71, slots=4, pulses=60, sample_rate_hz=250_000, fabric_per_sdram=4)


@pytest.mark.slow
def test_64_realistic_turbines_play_from_sdram(tmp_path, capsys):
    """examples/farm_sdram_64.toml (64 x 3 blades x 15 scatterers, flashes, a
    tower: 200,320 stream words, more than a block-RAM pool of the 85F holds)
    loaded through the bus into the simulated SDRAM while LiteDRAM starts and
    refreshes, then played by 8 pipelines of 8 slots (the board's SDRAM build):
    every output equal to
    the model, no underflow, no pool error (docs/sdram.md has the 0.2 s run)."""
    from rast.cli import main
    config = Path(__file__).resolve().parent.parent / "examples" / "farm_sdram_64.toml"
    out = tmp_path / "sdram64"
    assert main(["cosim", str(config), "--slots", "8", "--sdram", "--seconds", "0.005", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "64 channel(s) in 8 pipeline(s) of 8 slot(s), pool words 262144 in SDRAM" in text
    rep = json.loads((out / "report.json").read_text())
    assert rep["failure"] is None and rep["mismatches"] == 0
    assert rep["checksummed"] == rep["samples"] >= 50 * 2000
    assert len(rep["gates_km"]) == 64 and rep["compared"] == 64 * 50


def test_a_preloaded_sdram_plays_bit_exact_and_a_damaged_image_is_caught(tmp_path, capsys):
    """`rast cosim --sdram --preload`: the streams put in the simulated SDRAM's
    bank arrays at the start (rast.sim.sdram_top.sdram_image: two 16-bit beats
    a word, LiteDRAM's row | bank | column mapping) and every register at its
    power-up value, the engine held until LiteDRAM's init_done: every output
    equal to the model's (which starts from the same power-up state), no
    underflow. The same build with one preloaded bit flipped (bit 14 of the
    first stream's first word) must mismatch:
    the words played are the image's."""
    from rast.cli import main
    from rast.sim.e2e import prepare
    config = Path(__file__).resolve().parent.parent / "examples" / "two_windmills.toml"
    out = tmp_path / "pre"
    assert main(["cosim", str(config), "--sdram", "--preload", "--seconds", "0.002", "--out", str(out)]) == 0
    capsys.readouterr()
    rep = json.loads((out / "report.json").read_text())
    assert rep["failure"] is None and rep["mismatches"] == 0 and rep["compared"] == 40 * len(rep["gates_km"]) > 0

    e = prepare(config, 0.002, pool="sdram", preload=True)
    assert e.scenario.job.regs == [] and len(e.scenario.job.images) == 4
    c = e.scenario.contract
    sources, top = sdram_engine_top_sources(c.channels, slots=c.slots, pool_words=c.pool_words,
                                            max_delay=c.max_delay, max_tap=c.max_tap,
                                            interpolation=c.interpolation, init=tuple(e.scenario.inits),
                                            init_common_delay=e.scenario.common_delay)
    b = runner.build(sources, top, simulator="verilator", bulk=True)
    assert b.build_seconds == 0                                  # the build rast cosim made
    params = dict(config=str(config), seconds=0.002, pool="sdram", preload=True, damage_image=True)
    with pytest.raises(runner.SimulationFailed, match="(?i)mismatch"):
        runner.run(b, "rast.sim.tb_e2e", name="preload-damaged", testcase="e2e", quiet=True,
                   extra_env={"RAST_TB_PARAMS": json.dumps(params)})
