"""RegisteredRAM's ECP5 netlist (DP16KD model) against its behavioural Verilog, cycle by cycle:
the two cases where a block RAM and the behavioural memory are most likely to part."""

import pytest

from rast.sim import runner
from rast.sim.netlist import ram_lockstep_sources

#: Cosimulations: left out of `make test-fast`, run by `make test` and CI.
pytestmark = pytest.mark.slow

MODULE = "rast.sim.tb_netlist"
# 1024 x 32: two DP16KD in x18 mode; 4096 x 8: two in x4 mode (the default build's delay lines);
# 16384 x 8: eight in x1 mode (a group of the stream pool's bank)
SHAPES = {"x18": (32, 1024), "x4": (8, 4096), "x1": (8, 16384)}


def _run(shape, addr_reg, continuous=False, output_reset=True, **tb):
    width, depth = SHAPES[shape]
    sources, top = ram_lockstep_sources(width, depth, addr_reg=addr_reg, continuous=continuous,
                                        output_reset=output_reset)
    label = f"ram-lockstep-{shape}{'-continuous' if continuous else ''}{'' if output_reset else '-noreset'}"
    b = runner.build(sources, top, simulator="verilator", label=label)
    runner.run(b, MODULE, name=label, testcase="lockstep", quiet=True,
               extra_env={"RAST_TB_PARAMS": __import__("json").dumps(dict(width=width, depth=depth, **tb))})


@pytest.mark.parametrize("shape", list(SHAPES))
@pytest.mark.parametrize("addr_reg", [False, True], ids=["latency2", "latency3"])
def test_reset_mid_run(shape, addr_reg):
    """Resets at random cycles, many while the read stage is not primed: r_data equal every cycle."""
    _run(shape, addr_reg, seed=3, cycles=3000, resets=60, same_word=0)


@pytest.mark.parametrize("addr_reg", [False, True], ids=["latency2", "latency3"])
def test_continuous_reset_mid_run(addr_reg):
    """A RAM that reads every clock (the stream pool's), its enables tied high: r_data equal
    every cycle through resets too."""
    _run("x1", addr_reg, continuous=True, seed=4, cycles=3000, resets=60, same_word=0)


@pytest.mark.parametrize("addr_reg", [False, True], ids=["latency2", "latency3"])
def test_continuous_without_output_reset_mid_run(addr_reg):
    """The same without the output register's reset (the engine's data RAMs): the block RAM's
    output and the behavioural one keep their word through a reset alike."""
    _run("x1", addr_reg, continuous=True, output_reset=False, seed=4, cycles=3000, resets=60, same_word=0)


def test_read_of_the_word_being_written_differs():
    """The behavioural RAM returns the old word; a DP16KD does not promise it (no read-before-write
    across ports): the netlist cosimulation must catch a design that relies on it."""
    with pytest.raises(runner.SimulationFailed, match="netlist r_data"):
        _run("x18", False, seed=5, cycles=400, resets=0, same_word=10)
