"""Config errors name the key and the windmill; nothing is written on bad input."""

import re
from pathlib import Path

import numpy as np
import pytest

from rast.cli import main
from rast.model.physics.config import BladeFlash, ConfigError, WeightTable
from rast.model.physics.farm import load_config, parse_config

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def farm(**windmill):
    base = {"name": "alpha", "range": 2.0, "num_blades": 3, "rpm": 15, "num_rcs": 2,
            "radius": [26.0, 13.0], "rsc": [1.0, 1.0]}
    base.update(windmill)
    return {"sample_rate": 20, "radar_frequency": 5350, "windmill": [base]}


def problems_of(data):
    with pytest.raises(ConfigError) as info:
        parse_config(data)
    return info.value.problems


def test_vector_length_must_agree_with_num_rcs():
    assert problems_of(farm(radius=[26.0, 13.0, 5.0])) == [
        "windmill 'alpha': 'radius' has 3 values but num_rcs = 2"]
    assert problems_of(farm(phase_start=[0])) == [
        "windmill 'alpha': 'phase_start' has 1 values but num_rcs = 2"]


@pytest.mark.parametrize("key, value, message", [
    ("rpm", 0, "'rpm' must be positive, not 0"),
    ("rpm", -3, "'rpm' must be positive, not -3"),
    ("num_blades", 0, "'num_blades' must be at least 1, not 0"),
    ("num_blades", 2.5, "'num_blades' must be an integer, not 2.5"),
    ("range", 0, "'range' must be positive, not 0"),
])
def test_non_positive_values_are_refused(key, value, message):
    assert problems_of(farm(**{key: value})) == [f"windmill 'alpha': {message}"]


def test_radar_frequency_must_be_positive():
    data = farm()
    data["radar_frequency"] = 0
    assert problems_of(data) == ["'radar_frequency' must be positive, not 0"]


def test_unknown_key_gets_a_did_you_mean():
    assert problems_of(farm(rmp=15)) == ["windmill 'alpha': 'rmp' is not a known key (did you mean 'rpm'?)"]
    data = farm()
    data["sample_rte"] = 20
    assert problems_of(data) == ["'sample_rte' is not a known key (did you mean 'sample_rate'?)"]


def test_wire_radii_must_be_in_order():
    assert problems_of(farm(wire_enable=True, wire_radius_min=40.0, wire_radius_max=10.0,
                            wire_reflectivity=0.1)) == [
        "windmill 'alpha': 'wire_radius_min' (40.0 m) must be less than 'wire_radius_max' (10.0 m)"]


def test_all_problems_are_reported_together():
    problems = problems_of(farm(rpm=0, num_blades=0, radius=[1.0]))
    assert len(problems) == 3


def test_second_windmill_is_named_in_its_errors():
    data = farm()
    data["windmill"].append({"name": "beta", "range": 3.0, "num_blades": 3, "rpm": -1,
                             "radius": [20.0], "rsc": [1.0]})
    assert problems_of(data) == ["windmill 'beta': 'rpm' must be positive, not -1"]


def test_duplicate_names_are_refused():
    data = farm()
    data["windmill"].append(dict(data["windmill"][0]))
    assert problems_of(data) == ["windmill 'alpha': 'name' is used by 2 windmills; names must be "
                                 "unique (they name the stream files)"]


def test_rcs_is_accepted_as_spelling_of_rsc():
    config = parse_config(_with_rcs())
    np.testing.assert_array_equal(config.windmills[0].rcs_m2, [2.0, 3.0])


def _with_rcs():
    data = farm()
    table = data["windmill"][0]
    del table["rsc"]
    table["rcs"] = [2.0, 3.0]
    return data


def test_wire_only_windmill_is_allowed():
    config = parse_config(farm(num_rcs=0, radius=[], rsc=[], wire_enable=True,
                               wire_radius_max=40.0, wire_reflectivity=0.05))
    assert config.windmills[0].num_rcs == 0 and config.windmills[0].wire is not None


def test_windmill_with_nothing_that_reflects_is_refused():
    assert problems_of(farm(num_rcs=0, radius=[], rsc=[])) == [
        "windmill 'alpha': has nothing that reflects: give point scatterers (num_rcs > 0), a wire "
        "(wire_enable = true) or a tower (tower_rcs > 0)"]


def test_weighting_forms():
    flash = parse_config(farm(rsc_weighting={"angle": [0, 180], "width": 5, "gain_db": 10})).windmills[0]
    assert flash.weighting == BladeFlash((0.0, 180.0), 5.0, 10.0)
    table = parse_config(farm(rsc_weighting=[[1, 2], [3, 4]])).windmills[0]
    assert isinstance(table.weighting, WeightTable) and table.weighting.weights.shape == (2, 2)
    assert problems_of(farm(rsc_weighting=[[1, 2], [3, 4], [5, 6]])) == [
        "windmill 'alpha': 'rsc_weighting' has 3 rows but num_rcs = 2 (give one row per scatterer, "
        "or one row for all)"]
    assert problems_of(farm(rsc_weighting={"angle": 0, "widht": 5, "gain_db": 3})) == [
        "windmill 'alpha': rsc_weighting: 'widht' is not a known key (did you mean 'width'?)",
        "windmill 'alpha': rsc_weighting: 'width' is required (deg)"]


def test_flat_file_describes_one_windmill(tmp_path):
    path = tmp_path / "seed.toml"
    path.write_text('sample_rate = 20\nradar_frequency = 5350\noutput_file = "calanda.bin"\n'
                    'range = 0.73\nnum_blades = 3\nrpm = 7.7\nnum_rcs = 1\nradius = [50.0]\nrsc = [1.0]\n')
    config = load_config(path)
    assert [w.name for w in config.windmills] == ["calanda"]
    assert config.windmills[0].output_file == "calanda.bin"


def test_invalid_toml_names_the_file(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text("rpm = = 3\n")
    with pytest.raises(ConfigError, match=re.escape(str(path)) + ": is not valid TOML"):
        load_config(path)


@pytest.mark.parametrize("path", sorted(EXAMPLES.glob("*.toml")), ids=lambda p: p.stem)
def test_every_example_is_valid(path):
    assert load_config(path).windmills


def test_bad_config_writes_nothing(tmp_path, capsys):
    config = tmp_path / "bad.toml"
    config.write_text('sample_rate = 20\nradar_frequency = 5350\n[[windmill]]\nname = "a"\n'
                      'range = 2\nnum_blades = 3\nrpm = 15\nnum_rcs = 2\nradius = [1.0]\nrsc = [1.0, 1.0]\n')
    out = tmp_path / "out"
    assert main(["stream", str(config), "--out", str(out)]) == 2
    assert "windmill 'a': 'radius' has 1 values but num_rcs = 2" in capsys.readouterr().err
    assert not out.exists()


def test_stream_that_does_not_fit_ram_depth_writes_nothing(tmp_path, capsys):
    config = tmp_path / "big.toml"
    config.write_text('sample_rate = 20\nradar_frequency = 5350\nram_depth = 1024\n[[windmill]]\n'
                      'name = "big"\nrange = 2\nnum_blades = 1\nrpm = 15\nradius = [26.0]\nrsc = [1.0]\n')
    out = tmp_path / "out"
    assert main(["stream", str(config), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "windmill 'big': its stream needs 23323 words" in err and "'ram_depth' is 1024" in err
    assert not out.exists()
