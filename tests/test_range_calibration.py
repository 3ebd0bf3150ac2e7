"""Range calibration from config to registers: the converters' latencies
(``adc_latency``, ``dac_latency``), the board's own stages and the replay
block's L, subtracted from the common delay when a manifest goes into a board.
The pin-to-pin measurement is ``tests/test_cosim_board_io.py``."""

import pytest

from rast.model.physics.config import ConfigError
from rast.model.physics.farm import parse_config
from rast.model.contract.fixedpoint import ReplayContract, path_latency
from rast.model.contract.regmap import register_map
from rast.model.contract.loadplan import manifest_channel_inits, manifest_to_register_writes
from rast.model.physics.stream import build_farm_streams


def farm(**top):
    data = {"sample_rate": 20, "radar_frequency": 5350, "interpolation": "hold",
            "windmill": [{"name": "near", "range": 2.0, "num_blades": 3, "rpm": 15, "num_rcs": 1,
                          "radius": [20.0], "rsc": [1.0]},
                         {"name": "far", "range": 2.3, "num_blades": 3, "rpm": 20, "num_rcs": 1,
                          "radius": [20.0], "rsc": [1.0]}]}
    data.update(top)
    return data


def problems_of(data):
    with pytest.raises(ConfigError) as info:
        parse_config(data)
    return info.value.problems


def test_keys_default_to_zero_and_are_read():
    f = parse_config(farm())
    assert (f.adc_latency, f.dac_latency) == (0, 0)
    f = parse_config(farm(adc_latency=9, dac_latency=4))
    assert (f.adc_latency, f.dac_latency) == (9, 4)


@pytest.mark.parametrize("value, message", [
    (-1, "must be at least 0 (RTS samples), not -1"),
    (2.5, "must be an integer (RTS samples), not 2.5"),
    (True, "must be an integer (RTS samples), not True"),
    ("3", "must be an integer (RTS samples), not '3'"),
])
@pytest.mark.parametrize("key", ["adc_latency", "dac_latency"])
def test_bad_values_name_the_key(key, value, message):
    assert problems_of(farm(**{key: value})) == [f"'{key}' {message}"]


def test_flat_file_takes_the_keys():
    f = parse_config({"sample_rate": 20, "radar_frequency": 5350, "range": 2.0, "num_blades": 3,
                      "rpm": 15, "num_rcs": 1, "radius": [20.0], "rsc": [1.0], "adc_latency": 5})
    assert f.adc_latency == 5 and f.dac_latency == 0


def test_manifest_states_the_calibration():
    m = build_farm_streams(parse_config(farm(adc_latency=9, dac_latency=4))).manifest()
    assert m["calibration"] == {"adc_latency_samples": 9, "dac_latency_samples": 4}


def _delay0(writes, contract):
    """Channel 0's programmed delay: COMMON_DELAY + its tap."""
    w, a = dict(writes), register_map(contract).addr
    return w[a("COMMON_DELAY")] + w[a("DELAY", 0)]


@pytest.mark.parametrize("slots", [1, 10])
def test_board_target_subtracts_board_and_converters(slots):
    fs = build_farm_streams(parse_config(farm(adc_latency=9, dac_latency=4)))
    m = fs.manifest()
    c = ReplayContract(channels=2, slots=slots, pool_words=1 << 15, max_delay=1022, max_tap=62,
                       interpolation="hold", sample_rate_hz=20_000_000)
    d = fs.streams[0].delay_samples                       # 267 samples at 2 km, 20 MHz
    assert _delay0(manifest_to_register_writes(m, c, target="board"), c) == d - c.board_latency - 13
    assert _delay0(manifest_to_register_writes(m, c, target="block"), c) == d - c.latency
    assert _delay0(manifest_to_register_writes(m, c), c) == d - c.latency          # default: block
    # the taps of the further channels are not touched: the common delay takes the fixed part
    tap = dict(manifest_to_register_writes(m, c, target="board"))[register_map(c).addr("DELAY", 1)]
    assert tap == fs.streams[1].delay_samples - d
    inits, common = manifest_channel_inits(m, c, streams=[s.words for s in fs.streams], target="board")
    assert common == d - c.board_latency - 13 and inits[0].delay == 0 and inits[1].delay == tap


def test_manifest_without_calibration_loads_as_zero_converters():
    fs = build_farm_streams(parse_config(farm()))
    m = fs.manifest()
    del m["calibration"]
    c = ReplayContract(channels=2, pool_words=1 << 15, max_delay=1022, max_tap=62,
                       interpolation="hold")
    d = fs.streams[0].delay_samples
    assert _delay0(manifest_to_register_writes(m, c, target="board"), c) == d - c.board_latency


@pytest.mark.parametrize("cal, message", [
    ({"adc_latency_samples": -1}, r"^Manifest's calibration 'adc_latency_samples' must be a "
                                  r"non-negative integer \(RTS samples\), not -1$"),
    ({"dac_latency_samples": 1.5}, r"^Manifest's calibration 'dac_latency_samples' must be a "
                                   r"non-negative integer \(RTS samples\), not 1.5$"),
    ([3], r"^Manifest's 'calibration' must be an object, not \[3\]$"),
])
def test_bad_manifest_calibration_is_refused(cal, message):
    m = build_farm_streams(parse_config(farm())).manifest()
    m["calibration"] = cal
    with pytest.raises(ValueError, match=message):
        manifest_to_register_writes(m, ReplayContract(channels=2, pool_words=1 << 15,
                                                      interpolation="hold"), target="board")


def test_unknown_target_is_refused():
    m = build_farm_streams(parse_config(farm())).manifest()
    with pytest.raises(ValueError, match=r"^Target must be one of board, block, not 'dac'$"):
        manifest_to_register_writes(m, ReplayContract(channels=2, pool_words=1 << 15,
                                                      interpolation="hold"), target="dac")


def test_contract_states_the_board_latency():
    # M = 1: ADC pins to the block 7 clocks (the pin clock's edge PIN_LAG 5 after
    # its slot, the IDDRX1F and the sample register 2); the block L 2; its 27
    # clocks to the saturation register (4 pipelines: two tree levels of 2), the FIFO
    # and the DAC register 2
    c = ReplayContract(channels=4)
    assert c.output_cycles == 27 and c.board_latency == 7 + 2 + 29
    # M = 10: the same clocks, in whole periods: ceil(12 / 10) + 2 + ceil(41 / 10)
    c10 = ReplayContract(channels=64, slots=10)
    assert c10.board_latency == 2 + 2 + 5
    assert c.to_dict()["board_latency_samples"] == 38
    assert ReplayContract.from_dict(c.to_dict()) == c
    assert path_latency(c, "block", 5, 5) == c.latency
    assert path_latency(c, "board", 2, 3) == c.board_latency + 5
