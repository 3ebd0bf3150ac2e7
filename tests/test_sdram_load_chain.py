"""`rast load` through the UART into the SDRAM: the SDRAM bitstream's replay system (UART bridge
+ engine with its pool in SDRAM) on LiteDRAM's simulation core, in Verilator, samples streaming
all the while; then a second load (another farm) while the first plays. Every output sample equal
to the bit-exact model given the same register writes at the same samples."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from rast.cli import main
from rast.gateware.build import BuildConfig, build
from rast.load import load_manifest, read_manifest_dir
from rast.model.datapath import ReplayModel
from rast.model.fixedpoint import ReplayContract, pack_iq
from rast.model.hostproto import HostBridge

ROOT = Path(__file__).resolve().parents[1]

#: The second load: one small 3-blade turbine (1795 stream words) at 2.5 km.
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
rpm = 30
num_rcs = 1
radius = [6.0]
rsc = [1.0]
"""


#: Samples the first farm plays alone before the host sends the second.
PLAY_FIRST = 20_000


@pytest.mark.slow
def test_rast_load_through_the_uart_into_sdram_and_a_reload_while_playing(tmp_path):
    from rast.sim.sdram_top import SDRAMSystemTop
    from rast.gateware.sdram.generate import generate_core
    from rast.sim.uart_chain import ModelBoard, burst_train, check_chain, host_clocks, run_chain

    first, second = tmp_path / "first", tmp_path / "second"
    assert main(["stream", str(ROOT / "examples" / "two_windmills.toml"), "--out", str(first)]) == 0
    (tmp_path / "reload.toml").write_text(RELOAD_CONFIG)
    assert main(["stream", str(tmp_path / "reload.toml"), "--out", str(second)]) == 0
    # `rast build --sdram`'s build with one pipeline's channels (10 of its 64)
    cfg = dataclasses.replace(BuildConfig(pool="sdram"), channels=BuildConfig().slots)
    contract = ReplayContract.from_dict(build(cfg, tmp_path / "bit", quiet=True, run_tools=False)["build"])
    assert contract.pool == "sdram"
    system = SDRAMSystemTop(generate_core(sim=True), cfg.clock_mhz * 1e6, divisor=4, timeout=400,
                            **{k: v for k, v in cfg.replay_kwargs().items() if k != "pool"},
                            sample_rate_hz=contract.sample_rate_hz)
    assert system.system.replay.contract == contract

    board = ModelBoard(ReplayModel(contract))
    bridge = HostBridge(board)
    loaded = [load_manifest(bridge, first)["stream_words"]]          # rast load's own code
    n_first = len(board.applied)
    board.idle(PLAY_FIRST * contract.slots // system.divisor)   # the first farm plays alone a while
    loaded.append(load_manifest(bridge, second)["stream_words"])
    assert loaded == [sum(len(w) for w in read_manifest_dir(d)[1]) for d in (first, second)]
    assert board.model.enable[:2] == [1, 0]               # the second farm: channel 0 only

    xi, xq = burst_train()
    # the host starts once the SDRAM is initialised; its bytes then take host_clocks fabric
    # clocks, a sample every `slots` of them; then more play than the 60 k-sample tail
    init_steps = 40_000
    n_steps = (init_steps + -(-host_clocks(board.sent, system.divisor) // contract.slots)
               + contract.refill_samples + 80_000)
    rtl = run_chain(system, board.sent, pack_iq(xi, xq), n_steps, tmp_path / "sim", tail=60_000)
    assert rtl.sums["init_done"] == 1 and rtl.sums["init_error"] == 0
    assert rtl.sums["init_step"] < init_steps, f"LiteDRAM took {rtl.sums['init_step']} samples to initialise"
    assert rtl.sums["pool_error"] == 0
    y = check_chain(rtl, board, contract, xi, xq)
    assert rtl.writes[-1][0] < rtl.tail_from, "the second load had not ended when the tail began"
    # both farms played: the first's echoes between the two loads, the second's in the tail
    first_to, second_from = rtl.writes[n_first - 1][0], rtl.writes[n_first][0]
    assert second_from - first_to >= PLAY_FIRST
    assert np.count_nonzero(y[:, first_to:second_from].any(axis=0)) > 0.1 * (second_from - first_to)
    assert np.count_nonzero(rtl.tail.any(axis=1)) > 0.1 * len(rtl.tail)
