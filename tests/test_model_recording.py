"""Recorded signatures (rast.model.physics.recording, rast import) against the physics they were made from."""

import json

import numpy as np
import pytest

from rast.cli import main
from rast.errors import read_manifest
from rast.model.physics.config import Radar
from rast.model.physics.farm import parse_config
from rast.model.files.ramfiles import read_hex
from rast.model.radar.receiver import spectrogram_correlation
from rast.model.physics.recording import (SYNTHETIC_TURBINE, estimate_period, make_loop, read_recording,
                                          recording_streams, synthetic_recording)
from rast.model.contract.loadplan import manifest_to_register_writes
from rast.model.physics.turbine import modulation


def physics(t_s, **turbine):
    farm = parse_config({"sample_rate": 20, "radar_frequency": 5350,
                         "windmill": [dict(SYNTHETIC_TURBINE, **turbine)]})
    return modulation(farm.windmills[0], t_s, farm.radar.wavelength_m)


@pytest.mark.parametrize("rpm, prf, blades", [(15, 5000.0, 3), (11.7, 4000.0, 3), (21.3, 4500.0, 2)])
def test_imported_recording_returns_its_rpm(rpm, prf, blades):
    # T = 60/(rpm·blades): 1.3333 s, 1.7094 s, 1.4085 s: 6666.7, 6837.6, 6338.0 PRIs; Doppler within ±PRF/2
    x = synthetic_recording(prf_hz=prf, seconds=7.0, rpm=rpm, num_blades=blades)
    period = estimate_period(x, prf).period_s
    assert 60 / (period * blades) == pytest.approx(rpm, rel=1e-6)


def test_loop_is_the_physics_at_the_stream_instants():
    """Noise-free: the loop equals the model's m(t_n) at t_n = start + n·T/N to the
    interpolator's accuracy; with noise 20 dB down, M whole periods averaged and the band
    narrowed from the PRF to the stream rate, the error is the noise left:
    −(20 + 10·log10(M) + 10·log10(prf/rate)) dB."""
    prf, period = 5000.0, 60 / 45
    for snr_db, rate in ((None, 5000.0), (None, 4000.0), (20.0, 4000.0)):
        x = synthetic_recording(snr_db=snr_db)
        n = round(rate * period)
        loop = make_loop(x, prf, period, n, n / period)
        assert loop.periods == 5          # 8 s less the kernel's 2·16·5/4 samples
        ref = physics(loop.start_sample / prf + np.arange(n) * period / n)
        error_db = 10 * np.log10(np.sum(np.abs(loop.words - ref) ** 2) / np.sum(np.abs(ref) ** 2))
        if snr_db is None:
            assert error_db < -85
        else:
            expected = -(snr_db + 10 * np.log10(loop.periods) + 10 * np.log10(prf / (n / period)))
            assert error_db == pytest.approx(expected, abs=0.5)


def test_replayed_spectrogram_matches_a_noisy_recording():
    prf = 5000.0
    x = synthetic_recording(prf_hz=prf, snr_db=20.0, seed=3)
    period = estimate_period(x, prf).period_s
    n = round(4000.0 * period)
    loop = make_loop(x, prf, period, n, n / period)
    streams = recording_streams(loop, name="rec", range_km=2.0, num_blades=3, sample_rate_mhz=20,
                                radar=Radar(5350, prf))
    assert spectrogram_correlation(x, loop, streams) >= 0.95
    # and the check can fail: a recording of another turbine does not match
    other = synthetic_recording(prf_hz=prf, snr_db=20.0, seed=3, radius=[20.0, 5.0], rpm=12)
    assert spectrogram_correlation(other, loop, streams) < 0.8


def test_formats_read_the_same_samples(tmp_path):
    import sigmf
    from sigmf import SigMFFile
    x = synthetic_recording(seconds=0.2).astype(np.complex64)
    np.save(tmp_path / "r.npy", x)
    np.save(tmp_path / "iq.npy", np.stack([x.real, x.imag], axis=1))
    (tmp_path / "r.csv").write_text("i,q\n" + "".join(f"{v.real!r},{v.imag!r}\n" for v in x.tolist()))
    x.tofile(tmp_path / "r.sigmf-data")
    meta = SigMFFile(data_file=str(tmp_path / "r.sigmf-data"),
                     global_info={sigmf.DATATYPE_KEY: "cf32_le", sigmf.SAMPLE_RATE_KEY: 5000.0})
    meta.add_capture(0, metadata={sigmf.FREQUENCY_KEY: 5.35e9})
    meta.tofile(str(tmp_path / "r.sigmf-meta"))
    for name in ("r.npy", "iq.npy", "r.csv", "r.sigmf-meta", "r.sigmf-data"):
        rec = read_recording(tmp_path / name)
        assert np.array_equal(rec.samples, x.astype(complex)), name
    rec = read_recording(tmp_path / "r.sigmf-meta")
    assert (rec.sample_rate_hz, rec.frequency_hz) == (5000.0, 5.35e9)


def test_rast_import_writes_what_rast_stream_writes(tmp_path, capsys):
    x = synthetic_recording()
    np.save(tmp_path / "rec.npy", x)
    out = tmp_path / "out"
    assert main(["import", str(tmp_path / "rec.npy"), "--prf", "5000", "--rate", "4000",
                 "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    correlation = float(printed.split("(dB, 40 dB range): ")[1].split()[0])
    assert correlation >= 0.95
    manifest, _ = read_manifest(out)
    (w,) = manifest["windmills"]
    assert w["rpm"] == pytest.approx(15, rel=2e-5)
    assert w["length"] == round(4000 * 60 / 45)
    assert len(read_hex(out / w["hex_file"])) == w["length"]
    assert w["delay_samples"] == round(2 * 2000 / 299_792_458 * 20e6)
    assert sorted(p.name for p in out.iterdir()) == ["manifest.json", "rec.bin", "rec.hex", "rec.npy"]
    json.dumps(manifest)
    from rast.model.contract.fixedpoint import ReplayContract
    writes = manifest_to_register_writes(manifest, ReplayContract(channels=1, pool_words=8192),
                                         stream_dir=out)
    assert len(writes) > w["length"]


def run_import(argv, capsys):
    try:
        status = main(["import", *map(str, argv)])
    except SystemExit as exc:
        status = exc.code
    return status, capsys.readouterr().err


@pytest.mark.parametrize("case, needle", [
    ("short", "needs at least two periods"),
    ("period_longer", "too short for one period"),
    ("csv_cell", "row 4: 'x,0.5' is not two numbers"),
    ("csv_columns", "row 3: has 3 columns"),
    ("no_prf", "--prf"),
    ("prf_contradicts", "contradicts the recording's core:sample_rate"),
    ("suffix", "unknown recording type '.wav'"),
    ("constant", "is constant"),
    ("rate", "too high for fir interpolation"),
    ("blades", "--blades must be at least 1"),
    ("missing", "does not exist"),
    ("real", "give one complex sample per pulse"),
    ("name", "--name must be a file-name-safe string"),
])
def test_import_errors(case, needle, tmp_path, capsys):
    """One message, exit status 2, nothing written."""
    import sigmf
    from sigmf import SigMFFile
    x = synthetic_recording(seconds=8.0)
    path, extra = tmp_path / "rec.npy", ["--prf", 5000]
    if case == "short":                       # 1.5 blade periods
        np.save(path, x[:10_000])
    elif case == "period_longer":
        np.save(path, x)
        extra += ["--period", 9]
    elif case in ("csv_cell", "csv_columns"):
        path = tmp_path / "rec.csv"
        rows = ["i,q", "0.1,0.2", "0.3,0.4,0.5" if case == "csv_columns" else "0.3,0.4", "x,0.5"]
        path.write_text("\n".join(rows) + "\n")
    elif case == "no_prf":
        np.save(path, x)
        extra = []
    elif case == "prf_contradicts":
        path = tmp_path / "rec.sigmf-meta"
        x.astype(np.complex64).tofile(tmp_path / "rec.sigmf-data")
        SigMFFile(data_file=str(tmp_path / "rec.sigmf-data"),
                  global_info={sigmf.DATATYPE_KEY: "cf32_le", sigmf.SAMPLE_RATE_KEY: 4000.0}).tofile(str(path))
    elif case == "suffix":
        path = tmp_path / "rec.wav"
        path.write_bytes(b"RIFF")
    elif case == "constant":
        np.save(path, np.full(40_000, 1 + 1j))
    elif case == "rate":
        np.save(path, x)
        extra += ["--rate", 5e6]
    elif case == "blades":
        np.save(path, x)
        extra += ["--blades", 0]
    elif case == "missing":
        path = tmp_path / "nothing.npy"
    elif case == "real":
        np.save(path, x.real)
    elif case == "name":
        np.save(path, x)
        extra += ["--name", "../escape"]
    out = tmp_path / "out"
    status, err = run_import([path, "--out", out, *extra], capsys)
    assert status == 2, err
    lines = [line for line in err.splitlines() if line.startswith("rast import: ")]
    assert len(lines) == 1 and "Traceback" not in err, err
    assert needle in err, err
    assert not out.exists()


def test_drifting_rpm_gives_its_mean_rpm():
    """rpm(t) = 15·(1 + 0.02·t/8 s): the phase no longer repeats, the Doppler pattern does;
    the estimate is the mean rpm over the recording, 15·(1 + 0.02/2)."""
    x = synthetic_recording(rpm_drift=0.02)
    estimate = estimate_period(x, 5000.0)
    assert estimate.method == "spectrogram"
    assert 60 / (3 * estimate.period_s) == pytest.approx(15 * 1.01, rel=1e-3)


def test_sigmf_recording_brings_its_prf_and_frequency(tmp_path, capsys):
    import sigmf
    from sigmf import SigMFFile
    synthetic_recording(prf_hz=4000.0, seconds=6.0).astype(np.complex64).tofile(tmp_path / "r.sigmf-data")
    meta = SigMFFile(data_file=str(tmp_path / "r.sigmf-data"),
                     global_info={sigmf.DATATYPE_KEY: "cf32_le", sigmf.SAMPLE_RATE_KEY: 4000.0})
    meta.add_capture(0, metadata={sigmf.FREQUENCY_KEY: 5.35e9})
    meta.tofile(str(tmp_path / "r.sigmf-meta"))
    assert main(["import", str(tmp_path / "r.sigmf-meta"), "--out", str(tmp_path / "out")]) == 0
    manifest, _ = read_manifest(tmp_path / "out")
    assert manifest["radar"]["prf_hz"] == 4000.0
    assert manifest["radar_frequency_hz"] == pytest.approx(5.35e9)
    assert manifest["windmills"][0]["rpm"] == pytest.approx(15, rel=1e-6)
