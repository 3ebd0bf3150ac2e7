"""`rast load` through the UART into the SDRAM: the SDRAM bitstream's replay system (UART bridge
+ engine with its pool in SDRAM) on LiteDRAM's simulation core, in Verilator, samples streaming
all the while; then a second load (another farm) while the first plays, live (the first farm's
echoes go on during it), read back out of the SDRAM (`rast load --verify`). Every output sample equal to the bit-exact model given the same register
writes at the same samples, every answer of the bridge (the read-back's CRC-32s among them) the
protocol's."""

import dataclasses

import numpy as np
import pytest

from rast.cli import main
from rast.gateware.build import BuildConfig, build
from rast.load import read_manifest_dir
from rast.model.contract.fixedpoint import ReplayContract


#: The first load: two tiny turbines (300 and 539 stream words) at 2.0 and 2.9 km: the
#: shortest farm that still loads two channels and sums two echoes. A stream's words at the
#: automatic rate are 16·pi·r/(lambda·blades) whatever the rpm, and the load's time is its
#: words on the UART's simulated 3 Mbaud (two_windmills.toml's 41,264 words took 24 of this
#: test's 25 minutes; blades of 7 and 8 m, 5,683 words, 266-461 s). The live reload waits
#: for the playing streams' switch, up to their longest period: the small blades turn fast
#: (tips at 84 and 88 m/s; a period of 25 and 43 ms), which the radar time follows (at 25
#: and 35 rpm the wait was 0.8 s of the run's 0.81 s, 16 M samples, 320 s of simulation).
FIRST_CONFIG = """\
sample_rate = 20
radar_frequency = 5350
prf = 20000
pulse_width = 10
cpi = 100
output_gain_db = -4

[[windmill]]
name = "near"
range = 2.0
num_blades = 3
rpm = 800
num_rcs = 1
radius = [1.0]
rsc = [1.0]

[[windmill]]
name = "far"
range = 2.9
num_blades = 2
rpm = 700
num_rcs = 2
radius = [0.6, 1.2]
rsc = [1.0, 0.5]
"""

#: The second load: one tiny 3-blade turbine (270 stream words) at 2.5 km.
RELOAD_CONFIG = """\
sample_rate = 20
radar_frequency = 5350
prf = 20000
pulse_width = 10
cpi = 100

[[windmill]]
name = "small"
range = 2.5
num_blades = 3
rpm = 300
num_rcs = 1
radius = [0.9]
rsc = [1.0]
"""


@pytest.mark.slow
def test_rast_load_through_the_uart_into_sdram_and_a_reload_while_playing(tmp_path):
    from rast.sim.uart_chain import sdram_load_chain

    first, second = tmp_path / "first", tmp_path / "second"
    (tmp_path / "first.toml").write_text(FIRST_CONFIG)
    assert main(["stream", str(tmp_path / "first.toml"), "--out", str(first)]) == 0
    (tmp_path / "reload.toml").write_text(RELOAD_CONFIG)
    assert main(["stream", str(tmp_path / "reload.toml"), "--out", str(second)]) == 0
    # `rast build --sdram`'s build with one pipeline's channels (10 of its 64)
    cfg = dataclasses.replace(BuildConfig(pool="sdram"), channels=BuildConfig().slots)
    contract = ReplayContract.from_dict(build(cfg, tmp_path / "bit", quiet=True, run_tools=False)["build"])
    assert contract.pool == "sdram"

    run = sdram_load_chain(cfg, [first, second], tmp_path / "sim", play_between=20_000, play_after=80_000,
                           verify_last=True)
    assert run.contract == contract
    assert run.stream_words == [sum(len(w) for w in read_manifest_dir(d)[1]) for d in (first, second)]
    (_, first_to), (second_from, second_to) = run.loads
    assert second_from - first_to >= 20_000 and second_to < run.rtl.tail_from
    # both farms played: the first's echoes between the two loads and, the second load being
    # live (nothing muted, the new stream beside the old), during it; the second's in the tail
    assert run.live == [True, True]
    assert np.count_nonzero(run.y[:, first_to:second_from].any(axis=0)) > 0.1 * (second_from - first_to)
    assert np.count_nonzero(run.y[:, second_from:second_to].any(axis=0)) > 0.1 * (second_to - second_from)
    assert np.count_nonzero(run.rtl.tail.any(axis=1)) > 0.1 * len(run.rtl.tail)
