"""The host side of channels that follow the beam: `rast stream --build` of a
following build (a scene that needs more channels than the build is refused
with the beam's azimuth and the count, before any file is written), and the
load plan (rast.model.contract.loadplan.follow_load): the rolled streams,
the turbine table, the zeroed pattern and the window."""

import json
import math
import re

import numpy as np
import pytest

from rast.cli import main
from rast.model.contract.fixedpoint import PHASE_FRAC_BITS, ReplayContract
from rast.model.contract.follow import follow_guard_codes, follow_phase, unpack_rows
from rast.model.contract.loadplan import follow_load, follow_register_writes
from rast.model.contract.regmap import register_map, stream_crc32
from rast.model.contract.scan import azimuth_code

SCENE = """
sample_rate = 2.5
radar_frequency = 2800
prf = 1000
pulse_width = 1
ram_depth = 65536
scan_mode = "free"
scan_rpm = 12.5
beamwidth_deg = 1.4
sidelobe_db = {sidelobe}
share_streams = true
"""

TURBINE = """
[[windmill]]
name = "t{k}"
range = {range}
azimuth = {azimuth}
num_blades = 3
rpm = {rpm}
num_rcs = 1
radius = [20.0]
rsc = [1.0]
start_angle = {start}
"""


def _config(tmp_path, azimuths, sidelobe=-70):
    text = SCENE.format(sidelobe=sidelobe) + "".join(
        TURBINE.format(k=k, range=5.0 + 0.4 * k, azimuth=a, rpm=15 if k % 3 else 12, start=17.0 * k)
        for k, a in enumerate(azimuths))
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return path


def _follow_build(tmp_path, channels=4, rows=16):
    c = ReplayContract(channels=channels, slots=64, pool_words=65536, sample_rate_hz=2_500_000, scan=True,
                       start_frac=True, follow_rows=rows)
    path = tmp_path / "report.json"
    path.write_text(json.dumps({"build": c.to_dict()}))
    return c, path


#: Five turbines within 3 degrees at 90, the rest spread round.
CROWDED = [89.0, 89.7, 90.4, 91.1, 91.8, 0.0, 45.0, 180.0, 270.0, 300.0]


def test_a_scene_needing_more_channels_than_the_build_is_refused_before_anything_is_written(tmp_path, capsys):
    _, report = _follow_build(tmp_path, channels=4)
    out = tmp_path / "out"
    assert main(["stream", str(_config(tmp_path, CROWDED)), "--out", str(out), "--build", str(report)]) == 2
    err = capsys.readouterr().err
    found = re.search(r"5 turbines are within the beam's window at once with the beam from ([\d.]+) to "
                      r"([\d.]+) deg", err)
    assert found, err
    # all five hold a channel from the last one's entry to the first one's exit:
    # the Gaussian lobe at -60 dB is +-1.4 * sqrt(60/24) deg, the guard a few codes
    half = 1.4 * math.sqrt(60 / 24)
    assert abs(float(found.group(1)) - (91.8 - half)) < 0.05 and abs(float(found.group(2)) - (89.0 + half)) < 0.05
    assert "more than the build's 4 channels" in err and not out.exists()


def test_a_staring_scene_and_a_table_too_small_are_refused(tmp_path, capsys):
    _, report = _follow_build(tmp_path, channels=4, rows=8)
    out = tmp_path / "out"
    assert main(["stream", str(_config(tmp_path, CROWDED[5:] * 2)), "--out", str(out),
                 "--build", str(report)]) == 2
    assert "the build's turbine table holds 8 rows" in capsys.readouterr().err and not out.exists()


@pytest.fixture(scope="module")
def loaded(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("follow")
    contract, report = _follow_build(tmp, channels=8)
    azimuths = [10.0, 12.0, 100.0, 101.5, 200.0, 201.0, 202.0, 330.0]
    out = tmp / "out"
    assert main(["stream", str(_config(tmp, azimuths)), "--out", str(out), "--build", str(report)]) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    return contract, manifest, out, follow_load(manifest, contract, stream_dir=out), azimuths


def test_the_table_holds_every_turbine_sorted_by_azimuth(loaded):
    contract, manifest, out, load, azimuths = loaded
    rows = unpack_rows(load.table)
    assert rows == load.rows and len(rows) == len(azimuths)
    assert [r.azimuth for r in rows] == sorted(int(azimuth_code(a)) for a in azimuths)
    assert load.table_crc == stream_crc32(load.table)
    chans = {int(c["azimuth"]): c for c in manifest["registers"]["channels"]}
    for r in rows:
        ch = chans[r.azimuth]
        assert (r.gain, r.length, r.phase_inc) == (ch["gain"], ch["length"], ch["phase_increment"])


def test_every_stream_is_held_rolled_so_a_channel_starts_at_any_word(loaded):
    """From a row's base, 2N - 1 words: its stream, then its stream again but
    the last word; any phase then plays from BASE + whole words."""
    contract, manifest, out, load, _ = loaded
    pool = np.zeros(contract.pool_words, dtype=np.int64)
    for base, words in load.regions:
        pool[base:base + len(words)] = words
    hexes = {int(c["azimuth"]): w["hex_file"] for c, w in zip(manifest["registers"]["channels"],
                                                                manifest["windmills"])}
    shared = sum(1 for c in manifest["registers"]["channels"] if "pool_region" in c)
    assert shared >= 2, "the scene shares no stream: the shared regions are not exercised"
    for r in load.rows:
        own = [int(x, 16) for x in (out / hexes[r.azimuth]).read_text().split()]
        held = pool[r.base:r.base + 2 * r.length - 1]
        assert np.array_equal(held, np.array(own + own[:-1]))
        for step in (0, 12345, 9_999_999):
            phase = follow_phase(step, r.phase_inc, r.length)
            i = phase >> PHASE_FRAC_BITS
            assert np.array_equal(pool[r.base + i:r.base + i + r.length], np.roll(own, -i))


def test_the_pattern_and_the_window_are_the_rules(loaded):
    contract, manifest, out, load, _ = loaded
    rmap = register_map(contract)
    writes = dict(load.settings)
    follow = manifest["follow"]
    scan = manifest["scan"]
    beam = type("Beam", (), dict(mode=scan["scan_mode"], acp_per_rev=scan["acp_per_rev"], rpm=scan["scan_rpm"]))
    assert load.guard == follow_guard_codes(beam, contract, contract.channels)
    width = follow["hi"] + 1 - follow["lo"] + load.guard
    assert writes[rmap.addr("FOLLOW_SPAN")] == width | load.guard << 16
    assert writes[rmap.addr("FOLLOW_WINDOW")] == ((follow["lo"] - load.guard) % 65536
                                                   | (follow["hi"] + 1) % 65536 << 16)
    sent = [v for a, v in load.settings if a == rmap.addr("PATTERN_DATA")]
    assert sent == follow["words"] and min(sent) == 0 and max(sent) == 1 << 15
    assert writes[rmap.addr("PATTERN")] >> 16 == 0                      # the floor: 0
    whole = follow_register_writes(load, rmap)
    assert whole[-1] == (rmap.addr("FOLLOW_CTRL"), 1 | len(load.rows) << 4 | 1 << 31)


def test_a_pattern_whose_floor_stays_above_the_assignment_floor_cannot_follow(tmp_path, capsys):
    contract, report = _follow_build(tmp_path, channels=8)
    out = tmp_path / "out"
    assert main(["stream", str(_config(tmp_path, [10.0, 50.0], sidelobe=-50)), "--out", str(out),
                 "--build", str(report)]) == 2
    assert "sidelobe_db -50 dB lies above assign_below_db -60 dB" in capsys.readouterr().err


def test_rast_load_writes_the_rolled_streams_the_table_and_the_window_into_the_block(loaded):
    """`rast load` of a following build, against a block answered by the
    bit-exact model: the pool holds the rolled regions, TABLE_CRC and
    PATTERN_CRC read what was sent, the window's registers and FOLLOW_CTRL
    (on, the rows) read back."""
    from rast.load import load_manifest
    from rast.model.contract.datapath import ReplayModel
    from rast.model.contract.hostproto import HostBridge
    from rast.sim.uart_chain import ModelBoard
    contract, manifest, out, load, _ = loaded
    model = ReplayModel(contract)
    res = load_manifest(HostBridge(ModelBoard(model)), out, contract)
    assert res["following"] and res["rows"] == len(load.rows) and not res["retries"]
    for base, words in load.regions:
        assert np.array_equal(model.pool[base:base + len(words)], words)
    rmap = register_map(contract)
    assert model.read(rmap.addr("TABLE_CRC")) == load.table_crc
    assert model.read(rmap.addr("PATTERN_CRC")) == stream_crc32(manifest["follow"]["words"])
    assert np.array_equal(model.table, manifest["follow"]["words"])
    ctrl = model.read(rmap.addr("FOLLOW_CTRL"))
    assert ctrl & 1 and ctrl >> 4 & 0x1FFF == len(load.rows)
    assert model.beam.mode == 1                                         # the scan started


def test_rast_load_refuses_a_staring_manifest_for_a_following_block(tmp_path):
    from rast.errors import UserError
    from rast.load import load_manifest
    from rast.model.contract.datapath import ReplayModel
    from rast.model.contract.hostproto import HostBridge
    from rast.sim.uart_chain import ModelBoard
    contract, _ = _follow_build(tmp_path, channels=8)
    text = _config(tmp_path, [10.0, 50.0]).read_text().replace('scan_mode = "free"', 'scan_mode = "stare"')
    (tmp_path / "stare.toml").write_text(text)
    out = tmp_path / "out"
    assert main(["stream", str(tmp_path / "stare.toml"), "--out", str(out)]) == 0
    model = ReplayModel(contract)
    with pytest.raises(UserError, match="need a manifest whose antenna turns"):
        load_manifest(HostBridge(ModelBoard(model)), out, contract)
    assert model.stream_addr == 0 and not model.pool.any()               # nothing written


class _DamagedTable:
    """The line to a model board, flipping a bit of the first ``times``
    bursts of TABLE_DATA words."""

    def __init__(self, board, addr, times):
        self.board, self.addr, self.left = board, addr, times

    def write(self, frame):
        from rast.model.contract.hostproto import CMD_BURST
        if self.left and frame[:1] == bytes([CMD_BURST]) and int.from_bytes(frame[1:3], "little") == self.addr:
            frame = bytearray(frame)
            frame[5 + 4 * 3] ^= 0x10
            frame, self.left = bytes(frame), self.left - 1
        return self.board.write(frame)

    def read(self, n):
        return self.board.read(n)


@pytest.mark.parametrize("times", [1, 4])
def test_a_damaged_table_is_sent_again_and_one_damaged_every_time_leaves_following_off(loaded, times):
    from rast.load import RETRIES, LoadError, load_manifest
    from rast.model.contract.datapath import ReplayModel
    from rast.model.contract.hostproto import HostBridge
    from rast.sim.uart_chain import ModelBoard
    contract, manifest, out, load, _ = loaded
    model = ReplayModel(contract)
    rmap = register_map(contract)
    line = _DamagedTable(ModelBoard(model), rmap.addr("TABLE_DATA"), times)
    if times <= RETRIES:
        res = load_manifest(HostBridge(line), out, contract)
        assert line.left == 0 and res["retries"] == ["the turbine table"]
        assert model.read(rmap.addr("TABLE_CRC")) == load.table_crc
    else:
        with pytest.raises(LoadError, match="the turbine table did not arrive intact"):
            load_manifest(HostBridge(line), out, contract)
        assert not model.read(rmap.addr("FOLLOW_CTRL")) & 1
