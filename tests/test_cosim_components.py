"""Cosimulation of the replay block's components: generated Verilog vs the bit-exact model.

Each test builds (once, cached) the component's Verilog, runs a cocotb
testbench of ``sim/tb_components.py`` and compares every output as an integer.
"""

import pytest

from rast.hdl.cmult import ComplexMultiplier
from rast.hdl.delay_line import DelayLine
from rast.model.fixedpoint import stream_latency
from rast.sim.pooled_stream import PooledStream
from rast.sim.pytest_support import SIMULATOR_PARAMS, cocotb_run, verilog_of

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
# max_delay=0 is left out: its port `delay` is 0 bits wide and Amaranth writes
# `input [-1:0] delay`, which Verilator rejects (ASCRANGE); see the report.
@pytest.mark.parametrize("max_delay", [1, 6])   # RAM depth 4 with slack; depth 8 = max + 2 exactly
@pytest.mark.parametrize("en_pattern", ["none", "10", "random"])
def test_delay_line(simulator, max_delay, en_pattern):
    dut = DelayLine(32, max_delay)
    cocotb_run({"delay_line.v": verilog_of(dut, "delay_line")}, "delay_line", MODULE, "delay_line",
               simulator=simulator, name=f"delay-{max_delay}-{en_pattern}",
               label=f"delay_line{max_delay}",
               tb_params=dict(width=32, max_delay=max_delay, n=900, seed=5 + max_delay,
                              en_pattern=en_pattern))


@pytest.mark.parametrize("simulator", SIMULATOR_PARAMS)
@pytest.mark.parametrize("interpolation", ["hold", "linear"])
@pytest.mark.parametrize("en_pattern", ["none", "1000", "random"])
@pytest.mark.parametrize("rates", [
    # (length1, inc1, length2, inc2): a rate that does not divide 2**32 and a
    # non-power-of-two length, then the fastest rate (just below one word per
    # sample) on a short bank; then a slow one
    (13, int(0.37 * 2 ** 32), 7, 2 ** 32 - 1),
    (64, 2 ** 31 + 12345, 3, int(0.05 * 2 ** 32)),
], ids=["frac-then-max", "full-then-slow"])
def test_stream_replay(simulator, interpolation, en_pattern, rates):
    depth = 128                                # the two streams in its two halves
    dut = PooledStream(depth, interpolation=interpolation)
    L1, inc1, L2, inc2 = rates
    name = f"stream_{interpolation}"
    R = dut.stream.refill_samples
    # long enough to pass several wraps of stream 1, the switch, and wraps of stream 2
    n1 = 2 * R + int(3 * L1 * 2 ** 32 / inc1) + 10
    n2 = R + int(L1 * 2 ** 32 / inc1) + int(3 * L2 * 2 ** 32 / inc2) + 10
    cocotb_run({f"{name}.v": verilog_of(dut, name)}, name, MODULE, "stream_replay",
               simulator=simulator, name=f"{name}-{en_pattern}-{L1}-{L2}",
               tb_params=dict(depth=depth, interpolation=interpolation, latency=stream_latency(interpolation),
                              length1=L1, inc1=inc1, length2=L2, inc2=inc2, n1=n1, n2=n2, refill=R,
                              seed=3, en_pattern=en_pattern))
