"""pytest side of the cosimulation: simulator parameters, ``--waves``, one-call runs."""

from __future__ import annotations

import json
import os
import shutil

import pytest

from . import runner

__all__ = ["SIMULATOR_PARAMS", "pytest_addoption", "pytest_configure", "cocotb_run", "verilog_of"]


def _icarus_mark():
    return pytest.mark.skipif(shutil.which("iverilog") is None,
                              reason="Icarus Verilog is not installed (sim/install_iverilog.sh installs it)")


#: ``@pytest.mark.parametrize("simulator", SIMULATOR_PARAMS)``: Verilator always,
#: Icarus when installed (skipped with the reason otherwise).
SIMULATOR_PARAMS = [pytest.param("verilator", id="verilator"),
                    pytest.param("icarus", id="icarus", marks=_icarus_mark())]


def pytest_addoption(parser):
    parser.addoption("--waves", action="store_true", default=False,
                     help="cosimulation: build with tracing and dump waves (VCD/FST); the path is printed "
                          "(same as RAST_WAVES=1)")


def pytest_configure(config):
    if config.getoption("--waves", default=False):
        os.environ["RAST_WAVES"] = "1"
    # the suite's bulk builds at -O1: compiled in 60 % of -O3's time, run
    # about as fast (rast.sim.runner.CFLAGS_ENV); a value set outside wins
    os.environ.setdefault(runner.CFLAGS_ENV, "-O1")


def verilog_of(component, name: str) -> str:
    """Amaranth component to Verilog text (no source paths in the output)."""
    from amaranth.back import verilog
    return verilog.convert(component, name=name, emit_src=False)


def cocotb_run(sources: dict, toplevel: str, module: str, testcase: str, *, simulator: str,
               name: str, tb_params: dict | None = None, extra_env: dict | None = None,
               label: str | None = None, bulk: bool = False):
    """Build (cached) and run one cocotb test; raises with the scoreboard's report on failure.

    ``bulk=True`` for the bulk wrapper (see ``rast.sim.runner.build``)."""
    b = runner.build(sources, toplevel, simulator=simulator, label=label or toplevel,
                     bulk=bulk)
    env = {"RAST_TB_PARAMS": json.dumps(tb_params or {}), **(extra_env or {})}
    return runner.run(b, module, name=name, testcase=testcase, extra_env=env, quiet=True)
