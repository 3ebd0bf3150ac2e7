"""The SDRAM pool's read-back (PoolReadCheck, POOL_CHECK) in the Amaranth simulator against a
read port answering at random delays, and `rast load --verify` against the bit-exact model."""

import zlib
from pathlib import Path

import numpy as np
import pytest
from amaranth.sim import Simulator

from rast.hdl.pool_check import PoolReadCheck
from rast.load import LoadError, load_manifest, verify_pool
from rast.model.contract.datapath import ReplayModel
from rast.model.contract.fixedpoint import ReplayContract
from rast.model.contract.hostproto import HostBridge
from rast.cli import main
from rast.errors import UserError
from rast.sim.uart_chain import ModelBoard


def _read_back(memory, checks, seed=1, aw=10):
    """Run ``checks`` ((addr, words) each, a start while busy among them) on a
    PoolReadCheck whose read port answers 1..40 clocks after it took a request;
    returns the CRC and the number of reads of each check."""
    dut = PoolReadCheck(aw, aw + 1)
    rng = np.random.default_rng(seed)
    out = []

    async def bench(ctx):
        queue = []                          # (clock at which it answers, word)
        clock = 0
        for addr, words in checks:
            ctx.set(dut.start, 1); ctx.set(dut.addr, addr); ctx.set(dut.words, words)
            await ctx.tick()
            ctx.set(dut.start, 0)
            reads = 0
            stray_start_done = False
            while True:
                clock += 1
                ready = bool(rng.integers(0, 3))
                ctx.set(dut.rd_ready, ready)
                if queue and queue[0][0] <= clock:
                    ctx.set(dut.rd_data_valid, 1); ctx.set(dut.rd_data, queue.pop(0)[1])
                else:
                    ctx.set(dut.rd_data_valid, 0)
                if ready and ctx.get(dut.rd_valid):
                    a = ctx.get(dut.rd_addr)
                    queue.append((clock + int(rng.integers(1, 41)), memory[a]))
                    reads += 1
                if not stray_start_done and reads == 2:
                    # a start while busy is ignored
                    ctx.set(dut.start, 1); ctx.set(dut.addr, 0); ctx.set(dut.words, 1)
                    stray_start_done = True
                else:
                    ctx.set(dut.start, 0)
                busy = ctx.get(dut.busy)
                await ctx.tick()
                if not busy and not queue and reads:
                    break
            out.append((ctx.get(dut.crc), reads))

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    return out


def test_read_back_crc_equals_zlib_over_the_words_read():
    rng = np.random.default_rng(4)
    memory = [int(x) for x in rng.integers(0, 1 << 32, 1024, dtype=np.uint64)]
    checks = [(5, 17), (1000, 40), (0, 1)]            # the second wraps at the address width
    got = _read_back(memory, checks)
    for (addr, words), (crc, reads) in zip(checks, got):
        want = [memory[(addr + k) % 1024] for k in range(words)]
        assert reads == words
        assert crc == zlib.crc32(np.array(want, dtype="<u4").tobytes())


def _sdram_contract():
    return ReplayContract(channels=2, pool="sdram", pool_words=1 << 16, max_delay=1024, max_tap=32)


def _model_board(contract):
    """The bit-exact model behind the bridge protocol."""
    return ModelBoard(ReplayModel(contract))


def _two_streams(tmp_path):
    root = Path(__file__).resolve().parents[1]
    out = tmp_path / "two"
    assert main(["stream", str(root / "examples" / "two_windmills.toml"), "--out", str(out)]) == 0
    return out


def test_verify_reads_every_stream_back_and_sees_a_word_stored_wrong(tmp_path):
    out = _two_streams(tmp_path)
    board = _model_board(_sdram_contract())
    waited = []
    res = load_manifest(HostBridge(board), out, verify=True, wait=waited.append)
    assert res["verified_words"] == res["stream_words"] > 0
    assert len(waited) == 2 and all(w > 0 for w in waited)      # one read-back per stream
    # a word the SDRAM holds wrong: the next read-back names that stream
    model = board.model
    model.pool[model.base_act[1] + 7] ^= 1 << 20
    writes = [(a, v) for a, v in board.applied]
    with pytest.raises(LoadError, match=rf"words at {model.base_act[1]} .*SDRAM clock phase"):
        verify_pool(HostBridge(board), model.c, writes, wait=lambda s: None)


def test_verify_on_a_block_ram_bitstream_says_why_before_writing(tmp_path):
    out = _two_streams(tmp_path)
    board = _model_board(ReplayContract(channels=2, pool_words=81920, max_delay=1024, max_tap=32))
    with pytest.raises(UserError, match="block RAM, which has no read-back"):
        load_manifest(HostBridge(board), out, verify=True)
    assert board.applied == []
