"""Cosimulation of the wind-farm top (1, 4 and 8 channels) against the bit-exact model.

Random farms from the golden model, random register sequences with stream
reloads mid-run, full-scale stimulus driving saturation; valid gaps and
ready stalls of random length. Every output sample is compared as an integer.
"""

import pytest

from rast.sim.pytest_support import SIMULATOR_PARAMS, cocotb_run
from rast.sim.scenario import TEST_CONTRACT
from rast.sim.top import top_sources

MODULE = "rast.sim.tb_top"

#: (gap_thresh, stall_thresh) in 1/256: no gaps, some, many
STALLS = {"nogaps": (0, 0), "gaps": (48, 48), "heavy": (160, 128)}


def _run(simulator, channels, kind, seed, stalls, interpolation="fir"):
    sources, top = top_sources(channels, interpolation=interpolation, **TEST_CONTRACT)
    g, s = STALLS[stalls]
    cocotb_run(sources, top, MODULE, "replay_bulk", simulator=simulator, bulk=True,
               label=f"top{channels}{interpolation}",
               name=f"{kind}-{channels}ch-{stalls}-s{seed}",
               tb_params=dict(kind=kind, channels=channels, seed=seed, gap_thresh=g,
                              stall_thresh=s, interpolation=interpolation))


@pytest.mark.parametrize("simulator", SIMULATOR_PARAMS)
@pytest.mark.parametrize("channels", [1, 4, 8])
@pytest.mark.parametrize("kind, stalls, seed", [
    ("random", "gaps", 1),
    ("random", "nogaps", 2),
    ("random", "heavy", 3),
    ("farm", "gaps", 4),
    ("saturate", "gaps", 5),
])
def test_top(simulator, channels, kind, stalls, seed):
    _run(simulator, channels, kind, seed + 10 * channels, stalls)


@pytest.mark.parametrize("simulator", SIMULATOR_PARAMS)
def test_top_interpolating(simulator):
    _run(simulator, 4, "random", 77, "gaps", interpolation="linear")
