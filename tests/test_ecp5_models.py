"""The ECP5 primitive models (sim/ecp5/DP16KD.v, MULT18X18D.v) against hand-worked cases,
and their refusal of modes they do not implement."""

import pytest

from rast.sim import runner
from rast.sim.netlist import MODELS_DIR

MODULE = "rast.sim.tb_ecp5"


def _sources():
    return {name: (MODELS_DIR / name).read_text() for name in ("DP16KD.v", "MULT18X18D.v", "models_tb.v")}


@pytest.mark.parametrize("case", ["dp16kd_x18_outreg", "dp16kd_cross_port_collision", "dp16kd_x2_chip_select",
                                  "dp16kd_initval_writethrough", "mult_signed_registered", "mult_sign_modes"])
def test_model_case(case):
    b = runner.build(_sources(), "ecp5_models_tb", simulator="verilator", label="ecp5-models")
    runner.run(b, MODULE, name=case, testcase=case, quiet=True)


@pytest.mark.slow
@pytest.mark.parametrize("top, message", [
    ("ecp5_unmodelled_dp16kd", "DATA_WIDTH_A=9 differs from DATA_WIDTH_B=18"),
    ("ecp5_unmodelled_mult", "HIGHSPEED_CLK=CLK0 is not modelled"),
])
def test_unmodelled_mode_stops(top, message):
    b = runner.build(_sources(), top, simulator="verilator", label=top)
    before = set((b.build_dir / "runs").glob(f"{top}-*"))
    # the simulator stops with $fatal before cocotb's test can report: the runner
    # raises as for any simulator that exits with an error
    with pytest.raises((runner.SimulationFailed, RuntimeError)):
        runner.run(b, MODULE, name=top, testcase="unmodelled_mode", quiet=True)
    run_dir, = set((b.build_dir / "runs").glob(f"{top}-*")) - before
    log = (run_dir / "sim.log").read_text(errors="replace")
    assert message in log, log[-2000:]
