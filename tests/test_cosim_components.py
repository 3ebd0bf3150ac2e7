"""Cosimulation of the replay block's components (the complex multiplier, the
delay line): generated Verilog vs the bit-exact model. The stream replay is
the engine's pipeline and is cosimulated in the top (tests/test_cosim_top.py).

Each test builds (once, cached) the component's Verilog, runs a cocotb
testbench of ``sim/tb_components.py`` and compares every output as an integer.
"""

import pytest

from rast.hdl.cmult import ComplexMultiplier
from rast.hdl.delay_line import DelayLine
from rast.sim.pytest_support import SIMULATOR_PARAMS, cocotb_run, verilog_of

#: Cosimulations: left out of `make test-fast`, run by `make test` and CI.
pytestmark = pytest.mark.slow

MODULE = "rast.sim.tb_components"


@pytest.mark.parametrize("simulator", SIMULATOR_PARAMS)
@pytest.mark.parametrize("form", ["4mult", "3mult"])
@pytest.mark.parametrize("en_pattern", ["none", "1110", "random"])
def test_cmult(simulator, form, en_pattern):
    dut = ComplexMultiplier(16, 16, 15, form)
    cocotb_run({"cmult.v": verilog_of(dut, "cmult")}, "cmult", MODULE, "cmult",
               simulator=simulator, name=f"cmult-{form}-{en_pattern}",
               tb_params=dict(width=16, shift=15, latency=dut.latency, form=form,
                              n=1500, seed=11, en_pattern=en_pattern))


@pytest.mark.parametrize("simulator", SIMULATOR_PARAMS)
# max_delay=0 is left out: its port `r_delay` is 0 bits wide and Amaranth writes
# `input [-1:0] r_delay`, which Verilator rejects (ASCRANGE).
@pytest.mark.parametrize("max_delay, lag", [(1, 1), (6, 1), (6, 2)])   # RAM depth 4, 8 (= max + 2), 8
@pytest.mark.parametrize("en_pattern", ["none", "10", "random"])
def test_delay_line(simulator, max_delay, lag, en_pattern):
    dut = DelayLine(32, max_delay, lag)
    cocotb_run({"delay_line.v": verilog_of(dut, "delay_line")}, "delay_line", MODULE, "delay_line",
               simulator=simulator, name=f"delay-{max_delay}-{lag}-{en_pattern}",
               label=f"delay_line{max_delay}_{lag}",
               tb_params=dict(width=32, max_delay=max_delay, lag=lag, depth=dut.depth, latency=dut.latency,
                              n=900, seed=5 + max_delay, en_pattern=en_pattern))
