"""The README's chain with its defaults: `make run`'s streams load into what
`make bitstream` builds (the build described without running the tools)."""

import re
from pathlib import Path

import numpy as np
import pytest

from rast.cli import main
from rast.gateware.build import BuildConfig, build
from rast.load import plan_writes, read_manifest_dir
from rast.model.contract.datapath import ReplayModel
from rast.model.contract.fixedpoint import ReplayContract, pack_iq
from rast.model.contract.loadplan import free_region

#: Cosimulations: left out of `make test-fast`, run by `make test` and CI.
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]


def _make_default(name):
    m = re.search(rf"^{name} \?= (\S+)$", (ROOT / "Makefile").read_text(), re.M)
    assert m, f"Makefile has no default for {name}"
    return m.group(1)


def test_default_example_loads_into_the_default_bitstream(tmp_path):
    example = ROOT / _make_default("EXAMPLE")
    out = tmp_path / "out"
    assert main(["stream", str(example), "--out", str(out)]) == 0            # make run
    report = build(BuildConfig(), tmp_path / "bit", quiet=True, run_tools=False)   # make bitstream
    contract = ReplayContract.from_dict(report["build"])
    manifest, words = read_manifest_dir(out)
    writes = plan_writes(manifest, contract, words)                          # rast load's plan
    lengths = [len(w) for w in words]
    assert sum(lengths) > 2 * 16384           # longer than any one channel's RAM could have been

    # Every word lands in the pool and each channel plays its own stream.
    m = ReplayModel(contract)
    for addr, value in writes:
        m.write(addr, value)
    for ch, w in enumerate(words):
        assert m.stream_of(ch).tolist() == [int(x) for x in w]
    # ... and one more copy of the longest fits beside them: a reload while both play.
    regions = [(m.base_act[ch], n) for ch, n in enumerate(lengths)]
    free_region(regions, max(lengths), contract.pool_words)

    # The streams play: after the refill and the farthest echo's delay, every
    # channel's echo of a constant input is nonzero.
    n = contract.refill_samples + max(w["delay_samples"] for w in manifest["windmills"]) + 4096
    yi, yq = m.run(np.full(n, 8000), np.zeros(n, dtype=np.int64))
    assert np.count_nonzero(yi[-4096:]) > 4000


@pytest.mark.slow
def test_make_run_bitstream_load_chain_through_the_uart(tmp_path):
    """`make run`, then `make bitstream`'s top, then `rast load` of the run's
    output through that top's UART bridge (Verilator), samples streaming all
    the while: the bridge answers what the protocol and the model say, and
    every output sample equals the bit-exact model given the same register
    writes at the same samples."""
    from rast.gateware.top import ReplaySystem
    from rast.gateware.uart import MIN_DIVISOR
    from rast.load import load_manifest
    from rast.model.contract.hostproto import HostBridge
    from rast.sim.uart_chain import ModelBoard, burst_train, check_chain, host_clocks, run_chain

    out = tmp_path / "out"
    assert main(["stream", str(ROOT / _make_default("EXAMPLE")), "--out", str(out)]) == 0
    # The bitstream's build with one pipeline's channels (10 of its 64: the
    # example plays 2, and 64 would be seven times the simulation)
    import dataclasses
    cfg = dataclasses.replace(BuildConfig(), channels=BuildConfig().slots)
    report = build(cfg, tmp_path / "bit", quiet=True, run_tools=False)
    contract = ReplayContract.from_dict(report["build"])
    # The bitstream's replay system, its UART at the bridge's fastest divisor (4 clocks per bit).
    system = ReplaySystem(cfg.clock_mhz * 1e6, divisor=MIN_DIVISOR, timeout=400, **cfg.replay_kwargs(),
                          sample_rate_hz=contract.sample_rate_hz)
    assert system.replay.contract == contract

    board = ModelBoard(ReplayModel(contract))
    result = load_manifest(HostBridge(board), out)                 # rast load's own code
    assert result["stream_words"] == sum(len(w) for w in read_manifest_dir(out)[1])

    xi, xq = burst_train()
    # the load takes host_clocks fabric clocks, a sample every `slots` of them; then
    # more play than the 100 k-sample tail the chain captures
    n_steps = -(-host_clocks(board.sent, system.divisor) // contract.slots) + contract.refill_samples + 120_000
    rtl = run_chain(system, board.sent, pack_iq(xi, xq), n_steps, tmp_path / "sim")
    check_chain(rtl, board, contract, xi, xq)
    # the loaded streams play: both windmills' echoes of every burst (a fifth of the time)
    assert rtl.writes[-1][0] < rtl.tail_from, "the load had not ended when the tail began"
    assert np.count_nonzero(rtl.tail.any(axis=1)) > 0.15 * len(rtl.tail)
