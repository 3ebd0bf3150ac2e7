"""What the radar sees of the replayed streams over its whole Doppler band:
the held words' images are found, the FIR interpolator's are below -70 dB.

The replayed samples are the bit-exact model's stream words
(``rast.model.radar.receiver.receive`` with streams), one per pulse, for one second
(ten CPIs); the SFDR is ``rast.model.radar.sfdr`` over ±PRF/2.
"""

import dataclasses
from pathlib import Path

import pytest

from rast.model.physics.farm import load_config
from rast.model.radar.receiver import receive
from rast.model.radar.sfdr import farm_sfdr, worst
from rast.model.physics.stream import build_farm_streams

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def replay_sfdr(name, interpolation, **changes):
    farm = dataclasses.replace(load_config(EXAMPLES / name), interpolation=interpolation, **changes)
    streams = build_farm_streams(farm, check_ram_depth=False)
    _, bins, samples = receive(farm, 1.0, streams)
    return worst(farm_sfdr(farm, samples, bins))


@pytest.mark.parametrize("name", ["two_windmills.toml", "sec4_3_3_realistic.toml"])
def test_held_words_show_ghost_turbines(name):
    """The check can fail: held words at 4x oversampling leave images of each
    turbine less than 20 dB under it, outside its Doppler band."""
    r = replay_sfdr(name, "hold")
    assert r.sfdr_db < 20, r
    assert abs(r.spur_hz) > 2000


@pytest.mark.parametrize("name", ["two_windmills.toml", "sec4_3_3_realistic.toml"])
def test_linear_interpolation_is_not_enough(name):
    assert replay_sfdr(name, "linear").sfdr_db < 30


@pytest.mark.parametrize("name", ["two_windmills.toml", "sec4_3_3_realistic.toml",
                                  "farm_ranges_tower.toml", "sec4_3_4_four_windmills.toml"])
def test_fir_replay_is_spur_free_to_70_db(name):
    r = replay_sfdr(name, "fir")
    assert r.sfdr_db >= 70, r


def test_fir_at_higher_oversampling_stays_spur_free():
    assert replay_sfdr("sec4_3_3_realistic.toml", "fir", stream_oversampling=8.0).sfdr_db >= 70
