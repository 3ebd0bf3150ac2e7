"""End to end (seed section 4.3.3): two windmills, one second of radar time through the RTL.

20,000 pulses (Table 4.1: PRF 20 kHz, 10 us chirp, 20 MHz) at 20 MHz, i.e. 20 M
RTS samples through the generated Verilog; a radar receiver takes one sample
per pulse at the windmills' range from the RTL output. The test fails on any
sample differing from the bit-exact model (captured samples compared, all
outputs checksummed), on RTL and model spectrograms that are not identical,
on a windmill's maximum Doppler more than one Doppler bin from the physics,
or on a spur-free dynamic range below 70 dB over ±PRF/2 (FIR interpolation).
"""

import json
from pathlib import Path

import numpy as np
import pytest

from rast.cli import main
from rast.model.physics.farm import load_config
from rast.model.radar.sfdr import sfdr
from rast.model.physics.turbine import max_doppler_hz
from rast.sim.e2e import prepare
from rast.sim.pytest_support import SIMULATOR_PARAMS, cocotb_run
from rast.sim.top import top_sources

CONFIG = Path(__file__).resolve().parent.parent / "examples" / "two_windmills.toml"
#: Icarus's scene: two three-blade windmills at 2 km as CONFIG, blades of 4
#: and 5 m (a stream's words grow with the blade, not the rpm) so that the
#: streams are 2,693 words, not CONFIG's 41,264: Icarus spends its run on
#: the load's bus writes (86 of 90 s with CONFIG).
SMALL = """sample_rate = 20
radar_frequency = 5350
prf = 20000
pulse_width = 10
cpi = 100

[[windmill]]
name = "wm20"
range = 2.0
num_blades = 3
rpm = 20
radius = [4.0]
rsc = [1.0]

[[windmill]]
name = "wm30"
range = 2.0
num_blades = 3
rpm = 30
start_angle = 30
radius = [5.0]
rsc = [1.0]
"""


def run_e2e(simulator, seconds, name, require_peaks=True, noise_rms=0.0, config=CONFIG):
    e = prepare(config, seconds, noise_rms=noise_rms)
    c = e.scenario.contract
    sources, top = top_sources(c.channels, pool_words=c.pool_words, max_delay=c.max_delay,
                               interpolation=c.interpolation,
                               max_tap=c.max_tap)
    run_dir = cocotb_run(sources, top, "rast.sim.tb_e2e", "e2e", simulator=simulator, bulk=True,
                         label=f"e2e{c.channels}", name=name,
                         tb_params=dict(config=str(config), seconds=seconds, require_peaks=require_peaks,
                                        noise_rms=noise_rms))
    return json.loads((run_dir / "e2e.json").read_text())


@pytest.mark.slow
def test_two_windmills_one_second_verilator():
    rep = run_e2e("verilator", 1.0, "two_windmills-1s")
    assert rep["info"]["pulses"] == 20_000
    assert rep["samples"] >= 20_000_000 and rep["mismatches"] == 0
    doppler = {d["windmill"]: d for d in rep["doppler"]}
    # seed 4.3.3: 1460 Hz and 1870 Hz maximum Doppler
    assert abs(abs(doppler["wm15"]["measured_hz"]) - 1460) <= 2 * doppler["wm15"]["bin_hz"]
    assert abs(abs(doppler["wm25"]["measured_hz"]) - 1870) <= 2 * doppler["wm25"]["bin_hz"]
    assert all(d["ok"] for d in rep["doppler"])
    # the whole band, ±PRF/2, from the RTL's samples: no ghost turbines
    # (held words gave 9.5 dB here; tests/test_model_replay_sfdr.py)
    assert rep["sfdr_db"] >= 70, rep["sfdr"]


@pytest.mark.slow
@pytest.mark.parametrize("simulator", [p for p in SIMULATOR_PARAMS if p.id == "icarus"])
def test_two_windmills_icarus(simulator, tmp_path):
    # Icarus runs the engine's Verilog at ~120-500 samples/s (one CPI, 0.1 s
    # = 2 M samples, would take hours): 5 pulses (0.25 ms, 5 k samples, the
    # two 10 us chirps of every pulse through both windmills' channels, their
    # echoes 13 us later) with every output sample compared with the model;
    # the spectrograms and their Doppler checks are the Verilator test's. The
    # scene is SMALL.
    config = tmp_path / "small.toml"
    config.write_text(SMALL)
    rep = run_e2e(simulator, 0.00025, "small-0.25ms", require_peaks=False, noise_rms=0.002, config=config)
    assert rep["info"]["pulses"] == 5
    assert rep["samples"] >= 5_000 and rep["mismatches"] == 0


def test_cosim_rejects_a_bad_config_before_creating_anything(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('sample_rate = 20\nradar_frequency = 5350\n'
                   '[[windmill]]\nname = "a"\nnum_blades = 1\nrpm = 15\nradius = [26.0]\nrsc = [1.0]\n')
    out = tmp_path / "out" / "cosim"
    assert main(["cosim", str(bad), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("rast cosim: ") and "bad.toml" in err and "range" in err
    assert not (tmp_path / "out").exists()


def test_cosim_waves_help_names_what_is_written(capsys):
    with pytest.raises(SystemExit):
        main(["cosim", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "VCD with Verilator" in text and "FST with Icarus" in text


@pytest.mark.slow
def test_rast_cosim_keeps_the_evidence(tmp_path, capsys):
    # two CPIs of two_windmills through `rast cosim`: gates.npy is the RTL's per-pulse
    # output at the gate, report.json states the PRF, the gates and the SFDR
    out = tmp_path / "cosim"
    assert main(["cosim", str(CONFIG), "--seconds", "0.2", "--out", str(out), "--zoom", "2500"]) == 0
    capsys.readouterr()
    rep = json.loads((out / "report.json").read_text())
    farm = load_config(CONFIG)
    pulses = int(round(0.2 * farm.radar.prf_hz))
    assert rep["mismatches"] == 0 and rep["failure"] is None
    assert rep["prf_hz"] == farm.radar.prf_hz == 20_000
    assert rep["gates_km"] == [2.0]                    # both windmills at 2 km: one gate

    gates = np.load(out / "gates.npy")
    assert gates.dtype == np.complex128 and gates.shape == (pulses, 1)
    with np.load(out / "e2e.npz") as npz:
        rtl, model = npz["rtl"], npz["model"]
    assert rtl.shape == (1, pulses)
    np.testing.assert_array_equal(gates, rtl.T)
    np.testing.assert_array_equal(gates, model.T)
    # complex numbers of integers: the RTL's I and Q words, not all zero
    np.testing.assert_array_equal(gates.real, np.round(gates.real))
    np.testing.assert_array_equal(gates.imag, np.round(gates.imag))
    assert np.count_nonzero(gates) > pulses // 2

    # the SFDR of those samples, measured here outside both windmills' band
    fmax = [max_doppler_hz(w, farm.radar.wavelength_m) for w in farm.windmills]
    expected = sfdr(gates[:, 0], farm.radar.prf_hz, farm.radar.cpi_ms * 1e-3, fmax)
    assert rep["sfdr_db"] == pytest.approx(expected.sfdr_db)
    (gate,) = rep["sfdr"]
    assert gate["range_km"] == 2.0 and gate["sfdr_db"] == pytest.approx(expected.sfdr_db)
    assert gate["spur_hz"] == pytest.approx(expected.spur_hz)
    assert abs(gate["spur_hz"]) > max(fmax) and abs(gate["spur_hz"]) <= farm.radar.prf_hz / 2
    text = (out / "report.txt").read_text()
    assert f"worst SFDR          {expected.sfdr_db:.1f} dB (gate 2 km)" in text
    assert (out / "spectrogram.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow
def test_the_64_turbine_farm_plays_through_the_default_engine_shape(tmp_path, capsys):
    # examples/farm_atc_sband.toml (`rast farm`'s 64 turbines on 46 taps, 1 us
    # pulses every 1 ms) through 8 pipelines of 8 slots, the default build's
    # shape (its Verilator build is test_cosim_top's farm-scale one): every output of 15
    # pulses equal to the model, the gates' samples as integers, and the output
    # never saturated (rast farm's output_gain_db). docs/farm_layouts.md has the
    # one-second run with the max-Doppler check.
    config = CONFIG.parent / "farm_atc_sband.toml"
    out = tmp_path / "atc"
    assert main(["cosim", str(config), "--slots", "8", "--seconds", "0.015", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "64 channel(s) in 8 pipeline(s) of 8 slot(s)" in text
    rep = json.loads((out / "report.json").read_text())
    assert rep["failure"] is None and rep["mismatches"] == 0
    assert rep["checksummed"] == rep["samples"] >= 15 * 20_000
    assert rep["overflow"] == 0 and "output saturated    no" in (out / "report.txt").read_text()
    assert len(rep["gates_km"]) == 46 and rep["compared"] == 46 * 15
    with np.load(out / "e2e.npz") as npz:
        rtl, model = npz["rtl"], npz["model"]
    np.testing.assert_array_equal(rtl, model)
    assert np.count_nonzero(rtl.all(axis=1)) == 46             # every gate holds an echo in every pulse
