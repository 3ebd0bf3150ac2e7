"""Cosimulation of the wind-farm top against the bit-exact model: 1, 4 and 8
channels one per pipeline (M = 1), 1, M and M + 1 channels time-multiplexed
(M = 4), 66 channels in 7 pipelines of 10 slots and 64 in 8 of 8.

Random farms from the golden model (several channels on one tap), random
register sequences with stream reloads of random lengths mid-run into the
free parts of the pool, forced switches, full-scale stimulus driving
saturation; valid gaps and ready stalls of random length. Every output
sample is compared as an integer.
"""

import pytest

from rast.sim.pytest_support import SIMULATOR_PARAMS, cocotb_run
from rast.sim.scenario import TEST_CONTRACT
from rast.sim.top import top_sources

#: Cosimulations: left out of `make test-fast`, run by `make test` and CI.
pytestmark = pytest.mark.slow

MODULE = "rast.sim.tb_top"

#: (gap_thresh, stall_thresh) in 1/256: no gaps, some, many
STALLS = {"nogaps": (0, 0), "gaps": (48, 48), "heavy": (160, 128)}


def _run(simulator, channels, kind, seed, stalls, interpolation="fir", slots=1, pulses=None, pool_words=None,
         max_delay=None, max_tap=None):
    """One case (``pulses``: the scenario's own number, 30 for a farm and 40
    otherwise, unless given); on Icarus (250 to 2,400 cycles a second here)
    with an eighth of the pulses: the mid-run register writes (at random
    samples of the whole run) and the farm's reload (after its first pulse)
    land inside them all the same."""
    if pulses is None:
        pulses = 30 if kind == "farm" else 40
    if simulator == "icarus":
        pulses //= 8
    given = dict(pool_words=pool_words, max_delay=max_delay, max_tap=max_tap)
    contract = dict(TEST_CONTRACT, **{k: v for k, v in given.items() if v is not None})
    sources, top = top_sources(channels, slots=slots, interpolation=interpolation, **contract)
    g, s = STALLS[stalls]
    cocotb_run(sources, top, MODULE, "replay_bulk", simulator=simulator, bulk=True,
               label=f"top{channels}m{slots}{interpolation}",
               name=f"{kind}-{channels}ch-m{slots}-{stalls}-s{seed}",
               tb_params=dict(kind=kind, channels=channels, seed=seed, gap_thresh=g,
                              stall_thresh=s, interpolation=interpolation, pulses=pulses,
                              contract=dict(contract, slots=slots)))


def _cases(cases, icarus):
    """Every case on Verilator, the cases numbered in ``icarus`` on Icarus too:
    Icarus runs a cycle ~40 times slower, and CI has two cores for the whole
    suite, so it checks one case of each kind of simulation the second
    simulator could get wrong (the same Verilog, the same testbench)."""
    verilator, ic = SIMULATOR_PARAMS
    out = [pytest.param(verilator.values[0], *case, id=f"verilator-{'-'.join(map(str, case))}") for case in cases]
    out += [pytest.param(ic.values[0], *cases[k], marks=ic.marks, id=f"icarus-{'-'.join(map(str, cases[k]))}")
            for k in icarus]
    return out


TOP_CASES = [(ch, *kss) for ch in (1, 4, 8) for kss in [
    ("random", "gaps", 1),
    ("random", "nogaps", 2),
    ("random", "heavy", 3),
    ("farm", "gaps", 4),
    ("saturate", "gaps", 5),
]]


@pytest.mark.parametrize("simulator, channels, kind, stalls, seed", _cases(TOP_CASES, icarus=[5, 8, 9]))
def test_top(simulator, channels, kind, stalls, seed):
    _run(simulator, channels, kind, seed + 10 * channels, stalls)


TM_CASES = [(ch, *kss) for ch in (1, 4, 5) for kss in [
    ("random", "gaps", 31),
    ("farm", "heavy", 32),
    ("saturate", "gaps", 33),
]]


@pytest.mark.parametrize("simulator, channels, kind, stalls, seed", _cases(TM_CASES, icarus=[6]))
def test_top_time_multiplexed(simulator, channels, kind, stalls, seed):
    """M = 4: one pipeline part full (1), full (4), and a second pipeline (5)."""
    _run(simulator, channels, kind, seed + 10 * channels, stalls, slots=4)


@pytest.mark.slow
@pytest.mark.parametrize("channels, slots, kind, seed", [(66, 10, "random", 41), (66, 10, "farm", 42),
                                                         (64, 8, "random", 43)])
def test_top_farm_scale(channels, slots, kind, seed):
    """66 channels, 7 pipelines of 10 slots (the last with 6): the withdrawn
    200 MHz shape with more channels than it has; 64 channels in 8 pipelines
    of 8 slots, the default build's shape, with the pool and delays of
    examples/farm_atc_sband.toml's cosimulation (test_cosim_e2e's 64-turbine
    farm), whose Verilator build it shares. Verilator: on Icarus each is most
    of an hour."""
    if slots == 8:
        # the replay block `rast cosim examples/farm_atc_sband.toml --slots 8` builds
        from pathlib import Path
        from rast.sim.e2e import prepare
        atc = prepare(Path(__file__).resolve().parent.parent / "examples" / "farm_atc_sband.toml", 0.001,
                      slots=8).scenario.contract
        _run("verilator", channels, kind, seed, "gaps", slots=slots, pulses=12, pool_words=atc.pool_words,
             max_delay=atc.max_delay, max_tap=atc.max_tap)
    else:
        _run("verilator", channels, kind, seed, "gaps", slots=slots, pulses=12, pool_words=16384)


@pytest.mark.parametrize("simulator", SIMULATOR_PARAMS)
def test_top_interpolating(simulator):
    _run(simulator, 4, "random", 77, "gaps", interpolation="linear")
