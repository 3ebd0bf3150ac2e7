"""Streams: seamless periods, quantisation, RAM files read back as integers, the CLI end to end."""

import json
import math
import zlib
from fractions import Fraction

import numpy as np
import pytest

from rast.cli import main
from rast.model.contract import fixedpoint as fx
from rast.model.physics.farm import parse_config
from rast.model.files.ramfiles import read_bin, read_hex, write_farm_files
from rast.model.physics.stream import build_farm_streams, plan_stream, quantise, stream_times
from rast.model.physics.turbine import modulation


def farm(rate=None, **top):
    windmill = {"name": "w", "range": 2.0, "num_blades": 3, "rpm": 15, "num_rcs": 2,
                "radius": [26.0, 10.0], "rsc": [1.0, 0.5], "phase_start": [0, 45]}
    if rate is not None:
        windmill["stream_rate"] = rate
    return parse_config({"sample_rate": 20, "radar_frequency": 5350, **top, "windmill": [windmill]})


@pytest.mark.parametrize("rate", [None, 10_000.0, "rts"])
def test_stream_holds_exactly_one_period(rate):
    f = farm(rate, interpolation="hold")
    w = f.windmills[0]
    plan = plan_stream(w, f)
    t = stream_times(plan, w)
    t_sim = 60 / (15 * 3)                                  # eq. 2.13, 3 blades at 15 rpm
    assert t.size == plan.length and t[0] == 0
    # Evenly spaced over [0, T_sim): the word after the last would be t = T_sim, where
    # m repeats; a stream of N + 1 words or a spacing of T_sim/(N - 1) has a seam.
    step = t_sim / plan.length
    assert np.max(np.abs(np.diff(t) - step)) < 1e-12
    assert t[-1] + step == pytest.approx(t_sim, abs=1e-12)
    m = modulation(w, np.array([0.0, t_sim, t_sim / 3]), f.radar.wavelength_m)
    assert m[1] == pytest.approx(m[0], abs=1e-9)
    assert abs(m[2] - m[0]) > 1e-3                          # (not trivially constant)


@pytest.mark.parametrize("rate", [None, 10_000.0, "rts"])
def test_replayed_period_is_t_sim_within_half_a_word(rate):
    f = farm(rate, interpolation="hold")
    plan = plan_stream(f.windmills[0], f)
    fs = 20_000_000
    t_sim = Fraction(60, 15 * 3)
    # The replay block steps phase_increment / 2**32 words per RTS sample, so its N
    # words last N·2**32 / (phase_increment·f_s) seconds: that must be T_sim, to
    # within half a word (the rounding of the increment, or in the seed's mode of N).
    replayed = Fraction(plan.length << fx.PHASE_FRAC_BITS, plan.phase_increment * fs)
    assert abs(replayed - t_sim) <= t_sim / plan.length / 2
    assert plan.length == {None: 7775, 10_000.0: 13_333, "rts": 26_666_667}[rate]


@pytest.mark.parametrize("rate, mhz", [(None, 20), (10_000.0, 20), ("rts", 1)])
def test_replayed_index_sequence(rate, mhz):
    """With held words, the word the RTS model plays at sample n is the phase
    accumulator's floor(n·inc / 2**32) mod N (exact integers), and that is the
    word whose interval [k, k+1)·T_sim/N holds the sample's time, give or take
    the exact drift of the rounded increment. (The seed's mode at a 1 MHz RTS
    keeps the stream at 1.3 M words.)"""
    from rast.model.radar.receiver import _replayed
    from rast.model.physics.stream import FarmStreams, WindmillStream
    f = farm(rate, sample_rate=mhz, interpolation="hold")
    w = f.windmills[0]
    plan = plan_stream(w, f)
    n_words, inc, fs = plan.length, plan.phase_increment, mhz * 1_000_000
    # Stream words that spell their own index (I: low 15 bits, Q: the rest), at unit gain.
    index = np.arange(n_words)
    stream = WindmillStream(w, plan, None, index & 0x7FFF, index >> 15, 1.0, 0.0, 0, 1.0,
                            gain=float(1 << (fx.STREAM_WIDTH - 1)))
    fs_model = FarmStreams(f, [stream], [])
    wrap = -(-(n_words << fx.PHASE_FRAC_BITS) // inc)       # first sample back at word 0
    rng = np.random.default_rng(3)
    n = np.concatenate([np.arange(0, 3000), np.arange(wrap - 3000, wrap + 3000),
                        np.arange(2 * wrap - 500, 2 * wrap + 500), rng.integers(0, 2 * wrap, 2000)])
    played = _replayed(fs_model, 0, n / fs)
    got = (played.real.astype(np.int64) + (played.imag.astype(np.int64) << 15)).tolist()
    assert np.array_equal(played, np.round(played))
    t_sim = Fraction(60, 15 * 3)
    for sample, word in zip(n.tolist(), got):
        assert word == (sample * inc >> fx.PHASE_FRAC_BITS) % n_words, sample
        ideal = Fraction(sample, fs) / t_sim * n_words          # position in words, physics time
        drift = abs(Fraction(sample * inc, 1 << fx.PHASE_FRAC_BITS) - ideal)
        assert drift < Fraction(sample // wrap + 1, 2)       # under half a word per period
        assert word in {k % n_words for k in range(math.floor(ideal - drift), math.floor(ideal + drift) + 1)}
    at = n.tolist().index
    assert got[at(wrap - 1)] == n_words - 1 and got[at(wrap)] == 0


def test_automatic_rate_is_at_least_the_oversampling_factor():
    f = farm(stream_oversampling=4)
    plan = plan_stream(f.windmills[0], f)
    assert plan.stream_rate_hz >= 4 * plan.max_doppler_hz
    assert plan.stream_rate_hz < 4 * plan.max_doppler_hz + 1 / f.windmills[0].period_s + 1e-9
    # 2·ω·r/λ for the 26 m scatterer at 15 rpm and 5.35 GHz, and the fewest words
    # holding 4× that over one period T_sim = 4/3 s.
    f_max = 2 * (2 * math.pi * 15 / 60) * 26.0 / (299_792_458 / 5.35e9)
    assert plan.max_doppler_hz == pytest.approx(f_max, rel=1e-12)
    assert plan.length == math.ceil(4 * f_max * 4 / 3) == 7775


def test_forced_rate_is_moved_to_a_seamless_one():
    f = farm(10_000.0)
    plan = plan_stream(f.windmills[0], f)
    assert plan.length == round(10_000 * 60 / (15 * 3))
    assert plan.length / plan.stream_rate_hz == pytest.approx(60 / 45)
    assert plan.phase_increment == round(plan.stream_rate_hz / 20e6 * 2**32)


def test_rts_mode_is_one_word_per_sample():
    f = farm("rts", ram_depth=1 << 26, interpolation="hold")
    plan = plan_stream(f.windmills[0], f)
    assert plan.length == round(60 / 45 * 20e6)
    # One word per sample, as near as the replay block's increment register goes.
    assert plan.phase_increment == (1 << fx.PHASE_FRAC_BITS) - 1


def test_quantisation_uses_full_scale_and_reports_snr():
    rng = np.random.default_rng(1)
    period = rng.normal(size=5000) + 1j * rng.normal(size=5000)
    i, q, scale, snr = quantise(period)
    assert max(np.abs(i).max(), np.abs(q).max()) == fx.STREAM.max
    np.testing.assert_array_equal(i, np.round(period.real * scale).astype(np.int64))
    error = (i - period.real * scale) ** 2 + (q - period.imag * scale) ** 2
    assert snr == pytest.approx(10 * np.log10(np.sum(np.abs(period * scale) ** 2) / error.sum()))
    # Uniform rounding error of 1/12 LSB² per component: about 6 dB per bit.
    assert 75 < snr < 95


def test_gain_carries_relative_amplitude_and_scale():
    f = parse_config({"sample_rate": 20, "radar_frequency": 5350, "windmill": [
        {"name": "near", "range": 2.0, "num_blades": 3, "rpm": 15, "radius": [26.0], "rsc": [1.0]},
        {"name": "far", "range": 4.0, "num_blades": 3, "rpm": 15, "radius": [26.0], "rsc": [4.0]}]})
    fs = build_farm_streams(f)
    near, far = fs.streams
    # far: 4× the RCS (2× amplitude), twice the range (1/4 amplitude): half the near one's return.
    assert far.scale == pytest.approx(near.scale / 2)
    # A word of windmill l stands for 1/scale_l of its modulation, so gain·scale ∝ K_l ∝ 1/R².
    k = [s.gain * s.scale for s in fs.streams]
    assert k[1] / k[0] == pytest.approx(0.25)
    assert far.gain == pytest.approx(0.5)
    assert near.gain == 1.0 and near.gain_word == 1 << fx.GAIN_FRAC


def test_files_read_back_as_the_same_integers(tmp_path):
    fs = build_farm_streams(farm())
    written = write_farm_files(fs, tmp_path)
    s = fs.streams[0]
    words = read_hex(written["w.hex"])
    assert words.size == s.plan.length
    np.testing.assert_array_equal(words, read_bin(written["w.bin"]))
    i, q = fx.unpack_iq(words)
    np.testing.assert_array_equal(i, s.i)
    np.testing.assert_array_equal(q, s.q)
    assert all(len(line) == 8 for line in written["w.hex"].read_text().splitlines())
    np.testing.assert_array_equal(np.load(written["w.npy"]), s.period)
    manifest = json.loads(written["manifest.json"].read_text())
    entry = manifest["windmills"][0]
    assert entry["length"] == s.plan.length and entry["hex_file"] == "w.hex"
    assert entry["gain_word"] == manifest["registers"]["channels"][0]["gain"]
    # the stream's CRC-32 (what the block checks a switch against) is zlib's of the .bin file
    assert entry["crc32"] == zlib.crc32(written["w.bin"].read_bytes())
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".rast-staging")]


def test_pack_puts_i_in_the_low_half():
    word = fx.pack_iq(np.array([-2]), np.array([3]))
    assert int(word[0]) == (3 << 16) | 0xFFFE


def test_cli_stream_and_preview_end_to_end(tmp_path, capsys):
    config = tmp_path / "farm.toml"
    config.write_text('sample_rate = 20\nradar_frequency = 5350\n'
                      '[[windmill]]\nname = "a"\nrange = 2.0\nnum_blades = 3\nrpm = 15\nradius = [26.0]\nrsc = [1.0]\n'
                      '[[windmill]]\nname = "b"\nrange = 2.6\nnum_blades = 3\nrpm = 20\nradius = [20.0]\nrsc = [1.0]\n')
    out = tmp_path / "out"
    assert main(["stream", str(config), "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == [
        "a.bin", "a.hex", "a.npy", "b.bin", "b.hex", "b.npy", "manifest.json"]
    assert "wrote 7 files" in capsys.readouterr().out
    png = tmp_path / "pic.png"
    assert main(["preview", str(config), "--out", str(png), "--seconds", "1"]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "2 range bin(s)" in capsys.readouterr().out


def test_replayed_stream_words_show_the_physics_doppler():
    # The RTS's view (held, quantised words stepped by phase_increment) must put
    # each windmill's peak Doppler where the physics puts it.
    from rast.model.radar.receiver import receive, spectrogram
    f = parse_config({"sample_rate": 20, "radar_frequency": 5350, "windmill": [
        {"name": "a", "range": 2.0, "num_blades": 1, "rpm": 15, "radius": [26.0], "rsc": [1.0],
         "start_angle": -4.5}]})
    fs = build_farm_streams(f)
    _, _, physics = receive(f, 4.0)
    _, _, replayed = receive(f, 4.0, fs)
    peaks = []
    for samples in (physics, replayed):
        spec = spectrogram(samples[0], 20_000, 0.1)
        peaks.append(spec.doppler_hz[np.argmax(spec.power_db, axis=1)])
    np.testing.assert_array_equal(peaks[0], peaks[1])
    assert abs(peaks[1].max() - fs.streams[0].plan.max_doppler_hz) <= 10
