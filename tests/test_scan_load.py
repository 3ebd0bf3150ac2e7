"""Loading the antenna scan: the manifest's ``scan`` (``rast stream`` of a
turning config), the writes that load it, and ``rast load`` against a block
answered by the bit-exact model (the pattern's CRC-32 checked before the scan
starts, a damaged table sent again, a block without the scan refusing a
turning manifest)."""

import json
import struct

import numpy as np
import pytest

from rast.errors import UserError
from rast.load import read_contract, load_manifest, LoadError, RETRIES
from rast.model.contract.datapath import ReplayModel
from rast.model.contract.fixedpoint import ReplayContract, pack_iq
from rast.model.contract.hostproto import HostBridge, CMD_BURST
from rast.model.contract.loadplan import manifest_to_register_writes, scan_writes
from rast.model.contract.regmap import register_map, stream_crc32
from rast.model.contract import scan as sc
from rast.model.physics.antenna import AntennaScan
from rast.sim.uart_chain import ModelBoard

FS = 20_000_000
KW = dict(channels=2, pool_words=64, max_delay=60, max_tap=14, sample_rate_hz=FS)


def scan_manifest(tmp_path, scan=None):
    """A two-windmill manifest (short streams) whose antenna turns as ``scan``."""
    scan = scan or AntennaScan(mode="free", rpm=-12.5, start_deg=30.0, beamwidth_deg=1.4)
    rng = np.random.default_rng(3)
    wms, chans = [], []
    for k, n in enumerate((20, 17)):
        words = pack_iq(rng.integers(-30000, 30000, n), rng.integers(-30000, 30000, n))
        (tmp_path / f"wm{k}.hex").write_text("".join(f"{int(w):08x}\n" for w in words))
        wms.append({"name": f"wm{k}", "hex_file": f"wm{k}.hex", "length": n, "crc32": stream_crc32(words)})
        chans.append({"windmill": f"wm{k}", "enable": 1, "length": n, "phase_increment": 0x0050_0000,
                      "gain": 0xC000, "delay_samples": 40 + 5 * k, "azimuth": [5000, 60000][k]})
    manifest = {"format": "rast-manifest/2", "sample_rate_hz": FS, "windmills": wms,
                "registers": {"channels": chans},
                "scan": {"scan_mode": scan.mode, **sc.scan_settings(scan, FS)}}
    (tmp_path / "manifest.json").write_text(json.dumps(manifest))
    return manifest


def test_scan_settings_are_the_contract_s():
    """The registers' values from the config: P samples a revolution, the
    start's code, the direction, the ACP count as a power of two, the table."""
    s = sc.scan_settings(AntennaScan(mode="free", rpm=-12.5, start_deg=90.0), FS)
    assert (s["mode"], s["anticlockwise"], s["period_samples"], s["start_code"]) == (1, 1, 96_000_000, 16384)
    a = sc.scan_settings(AntennaScan(mode="acp", rpm=5.0, acp_per_rev=16384), FS)
    assert (a["mode"], a["auto"], a["acp_log2"]) == (2, 0, 14)
    assert sc.scan_settings(AntennaScan(mode="acp", rpm=5.0, acp_per_rev="auto"), FS)["auto"] == 1
    table = sc.pattern_words(AntennaScan(mode="free", rpm=12.5))
    assert s["pattern"]["words"] == table.words.tolist() and s["pattern"]["shift"] == table.shift


def test_the_load_writes_put_the_scan_last_and_a_block_without_it_refuses(tmp_path):
    manifest = scan_manifest(tmp_path)
    c = ReplayContract(**KW, scan=True)
    rmap = register_map(c)
    w = manifest_to_register_writes(manifest, c, stream_dir=tmp_path)
    load, start = scan_writes(rmap, manifest["scan"])
    assert w[-len(load) - len(start):] == load + start and w[-1][0] == rmap.addr("SCAN_CTRL")
    assert (rmap.addr("AZIMUTH", 1), 60000) in w
    with pytest.raises(ValueError, match="no antenna scan: build it with --scan"):
        manifest_to_register_writes(manifest, ReplayContract(**KW), stream_dir=tmp_path)
    model = ReplayModel(c)
    for addr, value in w:
        model.write(addr, value)
    assert model.table.tolist() == manifest["scan"]["pattern"]["words"]
    assert (model.beam.mode, model.beam.anticlockwise, model.beam.period) == (1, True, 96_000_000)
    assert model.azimuth == [5000, 60000]
    assert model.read(rmap.addr("PATTERN_CRC")) == stream_crc32(manifest["scan"]["pattern"]["words"])


class Damaging:
    """The line to a model board, flipping one bit of the first ``times``
    bursts of PATTERN_DATA words."""

    def __init__(self, board, pattern_addr, times=1):
        self.board, self.addr, self.left = board, pattern_addr, times

    def write(self, frame):
        if self.left and frame[:1] == bytes([CMD_BURST]) and struct.unpack_from("<H", frame, 1)[0] == self.addr:
            frame = bytearray(frame)
            frame[5 + 4 * 100] ^= 0x10
            frame, self.left = bytes(frame), self.left - 1
        return self.board.write(frame)

    def read(self, n):
        return self.board.read(n)


def test_rast_load_checks_the_pattern_s_crc_before_the_scan_starts(tmp_path):
    manifest = scan_manifest(tmp_path)
    model = ReplayModel(ReplayContract(**KW, scan=True))
    line = Damaging(ModelBoard(model), register_map(model.c).addr("PATTERN_DATA"))
    br = HostBridge(line)
    c = read_contract(br)
    assert c.scan
    res = load_manifest(br, tmp_path, c)
    assert line.left == 0 and any("pattern table" in r for r in res["retries"])
    assert model.table.tolist() == manifest["scan"]["pattern"]["words"]
    assert model.beam.mode == 1 and model.azimuth == [5000, 60000]


def test_a_table_damaged_every_time_leaves_the_scan_off(tmp_path):
    scan_manifest(tmp_path)
    model = ReplayModel(ReplayContract(**KW, scan=True))
    line = Damaging(ModelBoard(model), register_map(model.c).addr("PATTERN_DATA"), times=RETRIES + 1)
    br = HostBridge(line)
    with pytest.raises(LoadError, match="did not arrive intact .* the scan is off"):
        load_manifest(br, tmp_path, read_contract(br))
    assert model.beam.mode == 0


def test_a_bitstream_without_the_scan_refuses_a_turning_manifest_before_writing(tmp_path):
    scan_manifest(tmp_path)
    board = ModelBoard(ReplayModel(ReplayContract(**KW)))
    br = HostBridge(board)
    c = read_contract(br)
    with pytest.raises(UserError, match="build it with --scan"):
        load_manifest(br, tmp_path, c)
    assert board.applied == []
