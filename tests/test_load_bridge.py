"""The host protocol (rast.model.contract.hostproto, rast load) against the UART bridge
and replay block in the Amaranth simulator: the same Python code that drives
a serial port drives the simulated UART line.

The end-to-end test loads a manifest while samples stream through the block,
records the step at which every bus write took effect, replays those writes
into the bit-exact model at the same steps and compares every output sample.
"""

import json
import struct

import numpy as np
import pytest

from rast.gateware.simuart import SimUART
from rast.gateware.top import ReplaySystem
from rast.errors import UserError
from rast.load import read_contract, load_manifest, read_status, LoadError
from rast.model.contract.datapath import ReplayModel
from rast.model.contract.fixedpoint import ReplayContract, WRITE_STAGING, pack_iq
from rast.model.contract.hostproto import (HostBridge, BRIDGE_ID, ProtocolError, encode_write, CMD_BURST,
                                           encode_read, encode_burst, group_writes, CMD_WRITE, ACK)
from rast.model.contract.regmap import ID_VALUE, register_map, stream_crc32

#: Cosimulations: left out of `make test-fast`, run by `make test` and CI.
pytestmark = pytest.mark.slow

DIV = 4            # cycles per UART bit in simulation (the bridge's minimum)
TIMEOUT = 400      # bridge frame timeout, cycles
KW = dict(channels=2, pool_words=64, max_delay=60, max_tap=14)


def make_system(slots=1):
    return ReplaySystem(100e6, divisor=DIV, timeout=TIMEOUT, slots=slots, **KW)


def test_encoding():
    assert encode_write(0x13, 0xDEADBEEF) == bytes([0x57, 0x13, 0, 0xEF, 0xBE, 0xAD, 0xDE])
    assert encode_read(0x102) == bytes([0x52, 0x02, 0x01])
    assert encode_burst(7, [1, 2]) == bytes([0x42, 7, 0, 2, 0, 1, 0, 0, 0, 2, 0, 0, 0])
    frames = group_writes([(1, 5), (7, 1), (7, 2), (7, 3), (2, 9)])
    assert [f[0] for f in frames] == [CMD_WRITE, 0x42, CMD_WRITE]
    with pytest.raises(ValueError, match=r"^Register value must be an integer in \[0, 0xffffffff\], not -1$"):
        encode_write(0, -1)


@pytest.mark.parametrize("slots", [1, 3])
def test_version_id_and_registers(slots):
    """The bridge sees the bus's ready and answers a clock late: still every
    write taken once, at M = 1 (a take in 8 clocks) as at M = 3 (9)."""
    sys_ = make_system(slots)
    uart = SimUART(sys_, DIV)
    br = HostBridge(uart)
    assert br.version() == BRIDGE_ID
    rmap = sys_.replay.register_map
    assert br.read(rmap.addr("ID")) == ID_VALUE
    c = read_contract(br)
    assert c == ReplayContract(**KW, slots=slots)
    br.write(rmap.addr("GAIN", 1), 0x1ABCD)
    br.write(rmap.addr("DELAY", 1), 15)                     # clamped to max_tap (14)
    br.burst(rmap.addr("STREAM_DATA"), [1, 2, 3])
    assert br.read(rmap.addr("GAIN", 1)) == 0x1ABCD
    assert br.read(rmap.addr("DELAY", 1)) == KW["max_tap"]
    assert br.read(rmap.addr("STREAM_ADDR")) == 3           # the burst advanced the address
    assert br.read(rmap.addr("STREAM_COUNT")) == 3          # ... by one word per word sent
    assert br.read(rmap.addr("STREAM_CRC")) == stream_crc32([1, 2, 3])


def test_burst_count_of_zero_and_of_256():
    """A burst's word count is two bytes, low first: a count of 0 is answered
    at once and writes nothing; 1 (high byte 0) and 256 (low byte 0) wait for
    their words (here none and one, then the frame times out), so neither
    byte alone decides."""
    sys_ = make_system()
    uart = SimUART(sys_, DIV)
    br = HostBridge(uart)
    rmap = sys_.replay.register_map
    data = rmap.addr("STREAM_DATA")
    uart.write(struct.pack("<BHH", CMD_BURST, data, 0))
    assert uart.read(1) == bytes([ACK])
    assert br.read(rmap.addr("STREAM_COUNT")) == 0
    uart.write(struct.pack("<BHH", CMD_BURST, data, 1))
    uart.idle(TIMEOUT + 50)
    assert uart.read(1) == b""                              # no answer to the cut-off burst
    uart.write(struct.pack("<BHHI", CMD_BURST, data, 256, 7))
    uart.idle(TIMEOUT + 50)
    assert uart.read(1) == b""                              # no answer to the cut-off burst
    assert br.read(rmap.addr("STREAM_COUNT")) == 1          # its one word was written


def test_garbage_and_timeout_resync():
    sys_ = make_system()
    uart = SimUART(sys_, DIV)
    br = HostBridge(uart)
    rmap = sys_.replay.register_map
    uart.write(b"\x00\xff\x13")                             # unknown commands: ignored
    assert br.read(rmap.addr("ID")) == ID_VALUE
    uart.write(encode_write(rmap.addr("GAIN", 0), 0x1234)[:4])   # cut off mid-frame
    uart.idle(TIMEOUT + 50)
    assert br.read(rmap.addr("GAIN", 0)) == 0              # the partial write was dropped
    assert br.read(rmap.addr("ID")) == ID_VALUE            # and the parser is back in step


def test_missing_reply_is_reported():
    class Dead:
        def write(self, data): pass
        def read(self, n): return b""
    with pytest.raises(ProtocolError, match=r"^Timed out waiting for the bridge version"):
        HostBridge(Dead()).version()


def _manifest(tmp_path, rng):
    """A two-windmill manifest in `rast stream`'s format, with short streams."""
    lengths = [40, 23]
    wms, chans = [], []
    for k, n in enumerate(lengths):
        i = rng.integers(-30000, 30000, n)
        q = rng.integers(-30000, 30000, n)
        (tmp_path / f"wm{k}.hex").write_text("".join(f"{int(w):08x}\n" for w in pack_iq(i, q)))
        wms.append({"name": f"wm{k}", "hex_file": f"wm{k}.hex", "length": n, "crc32": stream_crc32(pack_iq(i, q))})
        chans.append({"windmill": f"wm{k}", "enable": 1, "length": n,
                      "phase_increment": [0x0055_5555, 0x0050_0000][k],   # FIR: <= 5592405
                      "gain": [0xC000, 0x10000][k], "delay_samples": [40, 49][k]})
    (tmp_path / "manifest.json").write_text(json.dumps(
        {"format": "rast-manifest/2", "windmills": wms, "registers": {"channels": chans}}))


@pytest.mark.parametrize("streams", [True, False])
def test_load_manifest_end_to_end(tmp_path, streams):
    rng = np.random.default_rng(5)
    _manifest(tmp_path, rng)
    sys_ = make_system()
    uart = SimUART(sys_, DIV)
    bus = sys_.bridge.bus
    T = 40000                    # enough input for the load; the run stops 2000 steps after it
    xi = rng.integers(-20000, 20000, T)
    xq = rng.integers(-20000, 20000, T)
    state = {"n": 0, "stop": T, "writes": [], "y": []}

    async def samples(ctx):
        # Continuous input (valid every cycle, as from an ADC); record every bus
        # write with the step at which it takes effect (the inputs accepted
        # before its landing clock, WRITE_STAGING clocks after its take), and
        # every output.
        ctx.set(sys_.o.ready, 1)
        landing = []                 # (landing clock, addr, data)
        clock = 0
        while True:
            n = state["n"]
            ctx.set(sys_.i.valid, n < state["stop"])
            if n < state["stop"]:
                ctx.set(sys_.i.payload.re, int(xi[n]))
                ctx.set(sys_.i.payload.im, int(xq[n]))
            _, _, ce, taken, addr, data, ov, yre, yim = await ctx.tick().sample(
                sys_.i.valid & sys_.i.ready, bus.w_stb & bus.ready, bus.addr, bus.w_data,
                sys_.o.valid, sys_.o.payload.re, sys_.o.payload.im)
            while landing and landing[0][0] == clock:
                state["writes"].append((state["n"], *landing.pop(0)[1:]))
            if taken:
                landing.append((clock + WRITE_STAGING, addr, data))
            if ce:
                state["n"] += 1
            clock += 1
            if ov:
                state["y"].append((yre, yim))

    uart.add_process(samples)
    br = HostBridge(uart)
    c = read_contract(br)
    res = load_manifest(br, tmp_path, c, streams=streams)
    assert res["stream_words"] == (63 if streams else 0)
    st = read_status(br, c)
    assert [ch["bank"] for ch in st["channels"]] == ([1, 1] if streams else [0, 0])
    assert [ch["enable"] for ch in st["channels"]] == [1, 1]
    assert state["n"] < T - 2000, "the input ran out before the load finished"
    T = state["stop"] = state["n"] + 2000
    uart.run_cycles(T - state["n"] + c.latency + 100)
    xi, xq = xi[:T], xq[:T]

    # The model, given the same writes at the same steps.
    model = ReplayModel(c)
    want = np.stack(model.run_with_writes(xi, xq, state["writes"]), axis=1)
    got = np.array(state["y"][:T], dtype=np.int64)
    assert len(got) == T
    bad = np.nonzero((got != want).any(axis=1))[0]
    assert bad.size == 0, (f"{bad.size} samples differ, first at step {bad[0]}: "
                           f"gateware {got[bad[0]]}, model {want[bad[0]]}")
    if streams:
        assert np.abs(got[-1000:]).max() > 0                # the loaded streams are playing
    else:
        assert not got.any()                                # bank 0 was never written


def test_load_rejects_wrong_bitstream():
    class Fake:
        """A bridge that answers every read with 0."""
        def version(self): return BRIDGE_ID
        def read(self, addr): return 0
        def resync(self): pass
    with pytest.raises(LoadError, match=r"^Register ID reads 0x00000000"):
        read_contract(Fake())


def _refused(tmp_path, edit, sample_rate_hz=100_000_000):
    """Load a manifest changed by ``edit`` into a block built for ``sample_rate_hz``:
    the refusal's message, and the bus writes that reached the block (none)."""
    rng = np.random.default_rng(9)
    _manifest(tmp_path, rng)
    path = tmp_path / "manifest.json"
    manifest = json.loads(path.read_text())
    edit(manifest, tmp_path)
    path.write_text(json.dumps(manifest))
    sys_ = ReplaySystem(100e6, divisor=DIV, timeout=TIMEOUT, sample_rate_hz=sample_rate_hz, **KW)
    uart = SimUART(sys_, DIV)
    writes = []

    async def watch(ctx):
        async for _, _, stb in ctx.tick().sample(sys_.bridge.bus.w_stb):
            if stb:
                writes.append(1)

    uart.add_process(watch)
    br = HostBridge(uart)
    c = read_contract(br)
    assert c.sample_rate_hz == sample_rate_hz           # read from the SAMPLE_RATE register
    with pytest.raises(UserError) as info:
        load_manifest(br, tmp_path, c)
    return str(info.value), writes


def test_load_refuses_a_manifest_for_another_sample_rate(tmp_path):
    msg, writes = _refused(tmp_path, lambda m, _: m.update(sample_rate_hz=20e6, interpolation="fir"))
    assert "20 MHz (sample_rate_hz 20000000)" in msg and "runs at 100 MHz (100000000)" in msg
    assert "5x too high" in msg and not writes


def test_load_refuses_streams_that_do_not_fit(tmp_path):
    def longer(m, folder):
        m["registers"]["channels"][0]["length"] = 65
        m["windmills"][0]["length"] = 65
        m["windmills"][0]["crc32"] = stream_crc32([1] * 65)
        (folder / "wm0.hex").write_text("00000001\n" * 65)
    msg, writes = _refused(tmp_path, longer)
    assert "pool words 64" in msg and "must be in [8, 64] words, not 65" in msg and not writes


def test_load_refuses_streams_made_for_another_interpolation(tmp_path):
    msg, writes = _refused(tmp_path, lambda m, _: m.update(interpolation="hold"))
    assert "made for hold interpolation" in msg and "interpolates with fir" in msg and not writes


def test_a_word_damaged_on_the_line_is_refused_then_sent_again(tmp_path):
    """One bit of one stream word flipped on the line (the frame still well
    formed): the block refuses that channel's switch by the stream's CRC-32,
    ``rast load`` sees it (CTRL.rejected, PLAYED not the stream's CRC), sends
    the stream again and is done once both channels play their streams."""
    rng = np.random.default_rng(5)
    _manifest(tmp_path, rng)
    sys_ = make_system()
    uart = SimUART(sys_, DIV)

    class Damaging:
        """The line: flips bit 2 of the 3rd word of the first stream burst."""
        def __init__(self, line):
            self.line, self.hit = line, False

        def write(self, frame):
            if not self.hit and frame[:1] == bytes([CMD_BURST]):
                frame = bytearray(frame)
                frame[5 + 4 * 2] ^= 0x04
                frame, self.hit = bytes(frame), True
            return self.line.write(frame)

        def read(self, n):
            return self.line.read(n)

    line = Damaging(uart)
    br = HostBridge(line)
    c = read_contract(br)
    res = load_manifest(br, tmp_path, c)
    assert line.hit and res["retries"] == ["channel 0's stream (refused: the words it received differ "
                                           "from the stream)"]
    st = read_status(br, c)
    assert [ch["rejected"] for ch in st["channels"]] == [0, 0]
    assert [ch["bank"] for ch in st["channels"]] == [1, 1]
    crcs = [w["crc32"] for w in json.loads((tmp_path / "manifest.json").read_text())["windmills"]]
    assert [ch["played"] for ch in st["channels"]] == crcs


@pytest.mark.parametrize("pool, pool_words", [("bram", 81920), ("sdram", 1 << 23)])
def test_the_contract_read_from_a_board_is_the_board_s(pool, pool_words):
    """rast load rebuilds the contract from the capability registers: an SDRAM
    bitstream's (whose pool may be larger than any block-RAM pool) included."""
    from rast.sim.uart_chain import ModelBoard
    c = ReplayContract(channels=64, slots=10, pool=pool, pool_words=pool_words, max_delay=8190, max_tap=2046,
                       sample_rate_hz=20_000_000)
    assert read_contract(HostBridge(ModelBoard(ReplayModel(c)))) == c
