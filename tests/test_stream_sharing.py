"""Streams shared between alike turbines (rast.model.physics.sharing): the
words a sharing turbine plays are its own, the pool holds a group once, the
load and the bit-exact model play them as the unshared farm does, and
aspect sharing stops where the measured SFDR says."""

import json
import math

import numpy as np
import pytest

from rast.cli import main
from rast.model.contract.datapath import ReplayModel
from rast.model.contract.fixedpoint import ReplayContract
from rast.model.contract.loadplan import (NoRoomBeside, _live_layout, manifest_channel_inits,
                                          manifest_to_register_writes, pool_layout)
from rast.model.contract.powerup import pool_contents
from rast.model.physics.config import ConfigError
from rast.model.physics.farm import parse_config
from rast.model.physics.sharing import region_layout, word_offset
from rast.model.physics.stream import build_farm_streams, plan_stream


def _config(share, starts, rotors=None, **farm_keys):
    """Three-bladed turbines at S band, alike but for start and rotor angles."""
    data = {"sample_rate": 20, "radar_frequency": 3000, "prf": 1000, "cpi": 64, "share_streams": share,
            **farm_keys, "windmill": []}
    for k, start in enumerate(starts):
        data["windmill"].append({"name": f"t{k}", "range": 3.0 + 0.15 * k, "num_blades": 3, "rpm": 15,
                                 "start_angle": start, "rotor_angle": rotors[k] if rotors else 20.0,
                                 "num_rcs": 3, "radius": [10.0, 25.0, 40.0], "rsc": [1.0, 2.0, 3.0]})
    return data


def _toml(data):
    """The config as TOML (numbers, booleans, lists and [[windmill]] tables)."""
    def value(v):
        return "true" if v is True else "false" if v is False else json.dumps(v)
    lines = [f"{k} = {value(v)}" for k, v in data.items() if k != "windmill"]
    for w in data["windmill"]:
        lines += ["", "[[windmill]]"] + [f"{k} = {value(v)}" for k, v in w.items()]
    return "\n".join(lines) + "\n"


def _length(data):
    farm = parse_config(data)
    return plan_stream(farm.windmills[0], farm).length


def _on_grid(data, words):
    """Start angles (degrees) that put the turbines ``words`` words into the stream."""
    n = _length(data)
    return [120.0 * o / n for o in words]


def test_a_turbine_differing_only_by_start_angle_plays_its_own_words():
    starts = _on_grid(_config(True, [0]), [0, 1000, 2101, 5000])
    shared = build_farm_streams(parse_config(_config(True, starts)))
    own = build_farm_streams(parse_config(_config(False, starts)))
    for s, o in zip(shared.streams, own.streams):
        assert s.windmill.name == o.windmill.name
        assert s.share is not None and s.share.stream == "t0"
        assert np.array_equal(s.i, o.i) and np.array_equal(s.q, o.q)
        assert s.gain_word == o.gain_word and s.delay_samples == o.delay_samples
    assert shared.pool_words < own.pool_words == 4 * _length(_config(True, [0]))


def test_a_start_angle_off_the_word_grid_plays_the_rounded_one():
    n = _length(_config(True, [0]))
    start = 120.0 * 1234.4 / n                     # 0.4 words past word 1234
    shared = build_farm_streams(parse_config(_config(True, [0.0, start])))
    member = next(s for s in shared.streams if s.windmill.name == "t1")
    assert member.share.offset_words == 1234
    assert member.share.start_error_deg == pytest.approx(-0.4 * 120.0 / n)
    played = build_farm_streams(parse_config(_config(False, [0.0, start + member.share.start_error_deg])))
    own = next(s for s in played.streams if s.windmill.name == "t1")
    assert np.array_equal(member.i, own.i) and np.array_equal(member.q, own.q)


@pytest.mark.parametrize("offsets, length, expected", [
    ([0, 3, 5], 100, (0, [0, 3, 5], 105)),
    ([0, 99], 100, (99, [1, 0], 101)),           # the gap is inside: the region wraps round
    ([10, 70], 100, (70, [40, 0], 140)),         # from 70 round to 10: 40 words of span
])
def test_region_layout(offsets, length, expected):
    assert region_layout(offsets, length) == expected


def test_word_offset_wraps_at_the_blade_sector():
    farm = parse_config(_config(True, [0.0, 130.0]))   # 130 deg = 10 deg into the next blade's sector
    o, error = word_offset(farm.windmills[1], farm.windmills[0], 1200)
    assert o == 100 and error == pytest.approx(0.0, abs=1e-9)


def _model_output(manifest, contract, words, n=40_000):
    inits, common = manifest_channel_inits(manifest, contract, streams=words)
    model = ReplayModel(contract, inits, common_delay=common)
    rng = np.random.default_rng(5)
    xi = rng.integers(-2000, 2000, n)
    xq = rng.integers(-2000, 2000, n)
    return model.run(xi, xq), inits


def test_the_shared_pool_plays_what_the_unshared_one_does_bit_exact():
    keys = {"sample_rate": 2.5, "stream_oversampling": 2.5}      # (the FIR's limit at 2.5 MS/s)
    starts = _on_grid(_config(True, [0], **keys), [0, 700, 2200, 3100])
    shared = build_farm_streams(parse_config(_config(True, starts, **keys)))
    own = build_farm_streams(parse_config(_config(False, starts, **keys)))
    contract = own.smallest_contract()
    outputs = []
    for fs in (shared, own):
        manifest = fs.manifest()
        words = [s.words for s in fs.streams]
        (yi, yq), inits = _model_output(manifest, contract, words)
        outputs.append((yi, yq))
        extent = max(i.base + len(i.words) for i in inits)
        assert extent == fs.pool_words
        pool_contents(inits, contract.pool_words)      # overlapping windows agree word for word
    assert np.array_equal(outputs[0][0], outputs[1][0]) and np.array_equal(outputs[0][1], outputs[1][1])
    assert np.abs(outputs[0][0]).max() > 0
    # the register load puts each channel's words where the layout says, once per region
    manifest = shared.manifest()
    regions = {c["pool_region"]["stream"] for c in manifest["registers"]["channels"]}
    assert regions == {"t0"}
    writes = manifest_to_register_writes(manifest, contract, streams=[s.words for s in shared.streams])
    assert len(writes) > 4 * shared.streams[0].plan.length


def test_pool_layout_places_a_region_once_and_refuses_what_does_not_fit():
    regions = [("a", 2, 12), None, ("a", 0, 12)]
    assert pool_layout([10, 5, 10], 100, regions) == [2, 12, 0]
    with pytest.raises(ValueError, match="need 17 words together"):
        pool_layout([10, 5, 10], 16, regions)
    # a live load puts the region where no playing stream lies
    playing = [(0, 8), None, None]
    assert _live_layout([10, 5, 10], playing, 100, regions) == [10, 20, 8]
    with pytest.raises(NoRoomBeside):
        _live_layout([10, 5, 10], playing, 24, regions)


def test_aspect_sharing_refuses_a_stream_of_another_doppler_extent():
    # the stream is the 60-degree turbine (the largest rotor angle within 45 deg
    # of the first); the 20-degree ones would miss their outer Doppler lines,
    # the 100-degree one would get lines beyond its band (its SFDR measured)
    data = _config(True, [0.0, 10.0, 20.0, 30.0], [20.0, 20.5, 60.0, 100.0], share_aspect_deg=45.0)
    fs = build_farm_streams(parse_config(data))
    assert all(s.share is None for s in fs.streams)
    refused = {r[0]: r for r in fs.refused_shares}
    assert set(refused) == {"t0", "t1", "t3"} and {r[1] for r in refused.values()} == {"t2"}
    guard = 6 / 0.064
    # short of its band, which covers the whole of the stream's: no SFDR to measure (NaN), refused
    assert refused["t0"][3] < -guard and math.isnan(refused["t0"][2])
    assert refused["t3"][3] > guard and refused["t3"][2] < 70         # past its band: spurs
    farm = parse_config(data)
    assert fs.streams[3].plan == plan_stream(farm.windmills[3], farm)   # its own stream
    assert "kept their own stream" in fs.sharing_summary()


def test_the_doppler_extent_alone_refuses_a_stream_whose_sfdr_passes():
    """A 20-degree turbine on a 40-degree turbine's stream: the SFDR measured
    outside its band passes (94 dB), but the stream's maximum Doppler lies
    218 Hz (more than 6 bins) short of the turbine's: refused."""
    fs = build_farm_streams(parse_config(_config(True, [0.0, 10.0], [20.0, 40.0], share_aspect_deg=30.0)))
    ((name, stream, sfdr_db, doppler_error_hz),) = fs.refused_shares
    assert (name, stream) == ("t0", "t1") and 70 <= sfdr_db < math.inf and doppler_error_hz < -6 / 0.064


def test_aspect_sharing_follows_the_measured_sfdr():
    data = _config(True, [0.0, 10.0], [20.0, 20.5], share_aspect_deg=1.0)
    fs = build_farm_streams(parse_config(data))
    member = next(s for s in fs.streams if s.windmill.name == "t0").share
    assert member is not None and member.stream == "t1" and member.aspect_error_deg == pytest.approx(0.5)
    assert 70 <= member.sfdr_db < 200 and -6 / 0.064 < member.doppler_error_hz < 0   # 20.5 deg: less Doppler
    assert "worst replay SFDR" in fs.sharing_summary()
    # the threshold decides, on the measured figure
    stricter = build_farm_streams(parse_config({**data, "share_min_sfdr_db": member.sfdr_db + 0.1}))
    assert all(s.share is None for s in stricter.streams)
    (refused,) = stricter.refused_shares
    assert refused[:2] == ("t0", "t1") and refused[2] == pytest.approx(member.sfdr_db)


def test_without_a_tolerance_other_aspects_do_not_share():
    fs = build_farm_streams(parse_config(_config(True, [0.0, 10.0], [20.0, 20.5])))
    assert all(s.share is None for s in fs.streams)
    assert "none" in fs.sharing_summary()


def test_sharing_off_says_what_it_would_save():
    starts = [0.0, 33.0, 71.0]
    fs = build_farm_streams(parse_config(_config(False, starts)))
    assert all(s.share is None for s in fs.streams)
    n = fs.streams[0].plan.length
    words = region_layout([word_offset(w, fs.farm.windmills[0], n)[0] for w in fs.farm.windmills], n)[2]
    assert f"in {words:,} pool words instead of {3 * n:,}" in fs.sharing_summary()


def test_a_pool_too_small_unshared_points_to_sharing():
    starts = [0.0, 33.0, 71.0]
    n = _length(_config(False, starts))
    with pytest.raises(ConfigError, match="or set share_streams = true"):
        build_farm_streams(parse_config(_config(False, starts, ram_depth=2 * n)))
    fs = build_farm_streams(parse_config(_config(True, starts, ram_depth=2 * n)))
    assert fs.pool_words <= 2 * n


@pytest.mark.parametrize("key, value, message", [
    ("share_streams", "yes", "'share_streams' must be true or false"),
    ("share_aspect_deg", -1.0, "'share_aspect_deg' must not be negative"),
    ("share_min_sfdr_db", "70", "'share_min_sfdr_db' must be a number"),
])
def test_bad_sharing_keys_are_refused_by_name(key, value, message):
    data = _config(False, [0.0])
    data[key] = value
    with pytest.raises(ConfigError, match=message):
        parse_config(data)


def test_rast_stream_prints_the_words_saved_and_writes_the_regions(tmp_path, capsys):
    starts = [0.0, 33.0, 71.0, 100.0]
    config = tmp_path / "farm.toml"
    config.write_text(_toml(_config(True, starts, [20.0, 20.0, 20.0, 20.2], share_aspect_deg=0.5)))
    assert main(["stream", str(config), "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert "shared streams: 4 windmills play 1 stream(s)" in out and "worst replay SFDR" in out
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    shares = [w["shared"] for w in manifest["windmills"]]
    assert {s["stream"] for s in shares} == {"t3"}       # the largest rotor angle within 0.5 deg of the first
    assert all("pool_region" in c for c in manifest["registers"]["channels"])
    # each windmill's .hex holds the words it plays (the loader checks them against the CRC)
    from rast.model.contract.loadplan import read_hex_words
    from rast.model.contract.regmap import stream_crc32
    for w in manifest["windmills"]:
        words = read_hex_words(tmp_path / "out" / w["hex_file"])
        assert stream_crc32(words) == w["crc32"]

