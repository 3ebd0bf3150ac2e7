"""One chain from config to bitstream: `rast stream --build report.json`, the
build description both sides read, and the README's configuration example."""

import json
import re
from pathlib import Path

import pytest

from rast.cli import main
from rast.gateware.build import BuildConfig
from rast.model.physics.farm import load_config
from rast.model.contract.fixedpoint import ReplayContract

ROOT = Path(__file__).resolve().parents[1]


def _report(tmp_path, **kw):
    c = ReplayContract(**{"channels": 8, "pool_words": 4096, "sample_rate_hz": 20_000_000, **kw})
    path = tmp_path / "report.json"
    path.write_text(json.dumps({"build": c.to_dict()}))
    return path


def _readme_config(tmp_path):
    text = (ROOT / "README.md").read_text()
    block = re.search(r"## Configuration.*?```toml\n(.*?)```", text, re.S).group(1)
    path = tmp_path / "readme.toml"
    path.write_text(block)
    return path


def test_readme_configuration_example_runs_and_fits_the_default_build(tmp_path, capsys):
    config = _readme_config(tmp_path)
    default = BuildConfig()
    report = _report(tmp_path, channels=default.channels, slots=default.slots,
                     pool_words=default.pool_words, interpolation=default.interpolation,
                     sample_rate_hz=round(default.sample_rate_mhz * 1e6))
    out = tmp_path / "out"
    assert main(["stream", str(config), "--out", str(out), "--build", str(report)]) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    (w,) = manifest["windmills"]
    assert w["length"] == 3589 <= default.pool_words
    assert manifest["build"]["pool_words"] == default.pool_words
    assert manifest["sample_rate_hz"] == default.sample_rate_mhz * 1e6
    assert "needs a build with at least 1 channel(s), a stream pool of 4096 words" in capsys.readouterr().out


#: Examples made for a build other than the default, and that build's sample rate (MHz).
OTHER_BUILDS = {"farm_atc_512.toml": BuildConfig(channels=512, sample_rate_mhz=2.5, pool="sdram").sample_rate_mhz,
                # the beam-following scene, at the air-traffic builds' rate (docs/beam_following.md)
                "farm_follow.toml": 2.5}


def test_default_bitstream_runs_at_the_examples_sample_rate():
    """Every example at the default build's rate, but those made for another
    build (the 512-channel, 2.5 MS/s SDRAM build's example, the beam-following
    scene at the same rate), at that build's."""
    rates = {p.name: load_config(p).sample_rate_mhz for p in (ROOT / "examples").glob("*.toml")}
    assert {r for name, r in rates.items() if name not in OTHER_BUILDS} == {BuildConfig().sample_rate_mhz}
    assert {name: rates[name] for name in OTHER_BUILDS} == OTHER_BUILDS


def test_stream_for_a_build_of_another_sample_rate_is_refused(tmp_path, capsys):
    report = _report(tmp_path, sample_rate_hz=100_000_000)
    out = tmp_path / "out"
    assert main(["stream", str(_readme_config(tmp_path)), "--out", str(out), "--build", str(report)]) == 2
    err = capsys.readouterr().err
    assert "'sample_rate' is 20 MHz but the build replays at 100 MHz (sample_rate_hz 100000000)" in err
    assert "5x too high" in err and not out.exists()


def test_stream_that_does_not_fit_the_build_is_refused(tmp_path, capsys):
    out = tmp_path / "out"
    config = ROOT / "examples" / "two_windmills.toml"
    assert main(["stream", str(config), "--out", str(out), "--build", str(_report(tmp_path))]) == 2
    err = capsys.readouterr().err
    assert "windmill 'wm15': its stream needs 23323 words" in err and "'ram_depth' is 4096" in err
    assert not out.exists()


def test_stream_with_more_windmills_than_channels_is_refused(tmp_path, capsys):
    config = ROOT / "examples" / "sec4_3_4_four_windmills.toml"
    report = _report(tmp_path, channels=2, pool_words=32768)
    assert main(["stream", str(config), "--out", str(tmp_path / "o"), "--build", str(report)]) == 2
    assert "the farm has 4 windmills but the build has 2 channels" in capsys.readouterr().err


def test_stream_takes_the_builds_interpolation(tmp_path):
    out = tmp_path / "out"
    report = _report(tmp_path, interpolation="hold")
    assert main(["stream", str(_readme_config(tmp_path)), "--out", str(out), "--build", str(report)]) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["interpolation"] == "hold" == manifest["build"]["interpolation"]


@pytest.mark.parametrize("content, message", [
    ("{}", "has no 'build' section"),
    ('{"build": {"channels": 0}}', "its 'build' section lacks slots, pool_words"),
    ('{"build": {"channels": 0, "slots": 8, "pool_words": 65536, "max_delay": 8190, "max_tap": 2046, '
     '"interpolation": "fir", "cmult_form": "4mult", "sample_rate_hz": 20000000, "pool": "bram"}}',
     "Channel count must be a positive integer, not 0"),
    ("not json", "is not valid JSON"),
])
def test_bad_build_reports_are_refused(tmp_path, capsys, content, message):
    report = tmp_path / "report.json"
    report.write_text(content)
    out = tmp_path / "out"
    assert main(["stream", str(_readme_config(tmp_path)), "--out", str(out), "--build", str(report)]) == 2
    assert message in capsys.readouterr().err and not out.exists()


def test_contract_description_round_trips():
    c = ReplayContract(channels=7, slots=2, pool_words=64, max_delay=10, max_tap=4,
                       interpolation="linear", cmult_form="3mult", sample_rate_hz=12_345_678)
    d = c.to_dict()
    assert ReplayContract.from_dict(json.loads(json.dumps(d))) == c
    # linear: at most one word per P = 4 samples (each pipeline's slots are offered a
    # fetch every 4th period); the fabric runs at 2 x the sample rate
    assert d["pipelines"] == 4 and d["max_phase_increment"] == (2**32 - 1) // 4
    assert d["latency_samples"] == 2 and d["clock_hz"] == 24_691_356


def test_stream_says_whether_it_fits_the_default_bitstream(tmp_path, capsys):
    """Without --build, `rast stream` says whether the streams load into the
    default bitstream, and names what does not fit."""
    assert main(["stream", str(ROOT / "examples" / "farm_atc_sband.toml"), "--out", str(tmp_path / "a")]) == 0
    out = capsys.readouterr().out
    assert "fits the default bitstream (64 channels, 20 MS/s, a stream pool of 65536 words" in out
    assert main(["stream", str(ROOT / "examples" / "farm_layout.toml"), "--out", str(tmp_path / "b")]) == 0
    out = capsys.readouterr().out
    assert "does not fit the default bitstream" in out and "but the stream pool holds 65536" in out


def test_stream_says_where_echoes_add_up_beyond_full_scale(tmp_path, capsys):
    """Two windmills at one range, each at full scale (output_gain_db 0, equal
    gains): their echoes add to twice full scale, +6.0 dBFS, and `rast stream`
    says so with what to do; the same two a pulse apart stay at full scale."""
    config = ROOT / "examples" / "two_windmills.toml"
    assert main(["stream", str(config), "--out", str(tmp_path / "a")]) == 0
    out = capsys.readouterr().out
    assert ("loudest echo sum for a full-scale pulse: +6.0 dBFS (2 echoes within one 200-sample pulse "
            "from delay 267): they saturate the output") in out
    assert "keep the radar's pulse under -6.0 dBFS, or lower output_gain_db by 6.0 dB" in out
    apart = tmp_path / "apart.toml"          # the first windmill 1.5 km (a 10 us pulse) farther
    apart.write_text(config.read_text().replace("range = 2.0", "range = 3.5", 1))
    assert main(["stream", str(apart), "--out", str(tmp_path / "b")]) == 0
    out = capsys.readouterr().out
    assert "loudest echo sum for a full-scale pulse: +0.0 dBFS (one echo at delay" in out
    assert "saturate" not in out


def test_a_turning_config_needs_a_build_with_the_scan(tmp_path, capsys):
    """The streams of a turning config for a staring build are refused (the
    board would light every turbine on every pulse); for a build with the
    scan they are made, and the manifest carries the scan."""
    config = ROOT / "examples" / "scan_two_turbines.toml"
    staring = _report(tmp_path, pool_words=65536)
    assert main(["stream", str(config), "--out", str(tmp_path / "o"), "--build", str(staring)]) == 2
    assert "the build has no antenna scan: build it with --scan" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()
    (tmp_path / "s").mkdir()
    scanning = _report(tmp_path / "s", pool_words=65536, scan=True)
    assert main(["stream", str(config), "--out", str(tmp_path / "o"), "--build", str(scanning)]) == 0
    manifest = json.loads((tmp_path / "o" / "manifest.json").read_text())
    assert manifest["scan"]["mode"] == 1 and [ch["azimuth"] for ch in manifest["registers"]["channels"]] == [
        8192, 21845]
