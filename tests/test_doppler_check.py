"""The end-to-end max-Doppler check (``rast.sim.e2e.doppler_check``) on what
the RTS plays (``model.radar.receive`` with the streams: the quantised,
interpolated words the RTL outputs, per range bin), without a simulator:
it passes on the examples, shared range gates and the 64-turbine S-band farm
included, and fails on a signature played at the wrong rate, mirrored or
missing. Its line reader (``signature_edge_hz``) is checked on synthetic
tones of known Doppler."""

from pathlib import Path

import numpy as np
import pytest

from rast.model.physics.farm import load_config
from rast.model.radar.receiver import _replayed, receive, spectrogram
from rast.model.physics.stream import build_farm_streams
from rast.sim.e2e import E2E, doppler_check, physics_doppler_track, signature_edge_hz

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
OVERLAP = 0.9          # the end-to-end testbench's default


def played(name, seconds=1.0):
    """The example's played samples per range bin, and an E2E of its bins."""
    farm = load_config(EXAMPLES / name)
    fs = build_farm_streams(farm)
    _, bins, samples = receive(farm, seconds, fs)
    e = E2E(name, farm, fs, None, None, [(k, b.range_km, list(b.members)) for k, b in enumerate(bins)])
    return e, samples


def checks(e, samples):
    r = e.farm.radar
    spectra = [spectrogram(row, r.prf_hz, r.cpi_ms * 1e-3, overlap=OVERLAP) for row in samples]
    return doppler_check(e, spectra)


@pytest.mark.parametrize("name", ["two_windmills.toml", "sec4_3_4_four_windmills.toml"])
def test_the_played_streams_pass(name):
    e, samples = played(name)
    result = checks(e, samples)
    assert len(result) == len(e.farm.windmills)
    assert all(c["reached"] for c in result)
    assert [c["windmill"] for c in result if not c["ok"]] == []
    for c in result:
        assert abs(c["measured_hz"] - c["physics_hz"]) <= c["bin_hz"]
        if c["explained_by"] == c["windmill"]:
            assert abs(c["physics_hz"] - c["windmill_hz"]) <= c["bin_hz"]


def test_a_shared_gate_is_explained_by_its_windmills():
    # seed 4.3.4: four windmills at one range; the edge in a frame belongs to
    # whichever windmill's line is strong there, not always to the one peaking
    e, samples = played("sec4_3_4_four_windmills.toml")
    assert len(e.gates) == 1 and len(e.gates[0][2]) == 4
    result = checks(e, samples)
    by_another = [c for c in result if c["explained_by"] != c["windmill"]]
    assert by_another, "no edge explained by another windmill of the shared gate"
    for c in by_another:
        # the windmill's own Doppler alone would have failed it
        assert abs(c["measured_hz"] - c["windmill_hz"]) > c["bin_hz"]
        assert abs(c["measured_hz"] - c["physics_hz"]) <= c["bin_hz"]


@pytest.mark.parametrize("name", ["two_windmills.toml", "sec4_3_4_four_windmills.toml"])
@pytest.mark.parametrize("wrong", ["twice the rate", "half the rate", "mirrored"])
def test_a_wrong_signature_fails(name, wrong):
    e, samples = played(name)
    n = samples.shape[1]
    if wrong == "mirrored":
        bad = np.conj(samples)
    else:
        scale = 2.0 if wrong == "twice the rate" else 0.5
        bad = samples[:, (np.arange(n) * scale).astype(int) % n]
    result = checks(e, bad)
    assert sum(not c["ok"] for c in result) >= len(result) // 2


# ------------------------------------------------------------------ the outermost line of a frame

PRF, CPI = 1000.0, 0.1          # 10 Hz bins


def frame(*tones, seconds=CPI):
    """One spectrogram frame (dB, Hz) of complex tones given as (Hz, amplitude, phase rad)."""
    t = np.arange(int(round(seconds * PRF))) / PRF
    x = sum(a * np.exp(1j * (2 * np.pi * f * t + ph)) for f, a, ph in tones)
    spec = spectrogram(x, PRF, CPI)
    return spec.power_db[0], spec.doppler_hz


@pytest.mark.parametrize("f", [123.0, 125.0, 127.7, -131.3])
def test_a_line_alone_is_read_to_an_eighth_of_a_bin(f):
    power, doppler = frame((f, 1.0, 0.0))
    assert abs(signature_edge_hz(power, doppler, np.sign(f)) - f) <= 1.2   # Hz: 0.12 of a 10 Hz bin


def test_the_outermost_line_however_weak():
    # the case the old rule missed: the tip 12 dB under two coinciding blades on
    # the other side and 26 dB under a static tower at 0 Hz
    tip = 127.0
    power, doppler = frame((tip, 0.25, 0.3), (-63.5, 1.0, 1.0), (0.0, 5.0, 0.0), (90.0, 0.2, 2.0))
    assert power[np.argmin(abs(doppler - tip))] < power.max() - 6          # not within 6 dB of the strongest
    assert abs(signature_edge_hz(power, doppler, 1.0) - tip) <= 2.0


@pytest.mark.parametrize("phase", np.linspace(0, 2 * np.pi, 8, endpoint=False))
def test_a_neighbour_inside_a_main_lobe_does_not_move_the_edge_a_bin(phase):
    # a blade's scatterers 1.5 bins apart: not resolved by the Hann window
    tip = 128.0
    power, doppler = frame((tip, 1.0, 0.0), (tip - 15.0, 1.0, phase), (tip - 30.0, 1.0, 2 * phase))
    assert abs(signature_edge_hz(power, doppler, 1.0) - tip) <= 5.0        # half a bin


def test_no_line_on_the_side_reads_zero():
    power, doppler = frame((-120.0, 1.0, 0.0), (0.0, 10.0, 0.0))
    assert signature_edge_hz(power, doppler, 1.0) == 0.0                   # the tower's main lobe is no line
    silent = np.full_like(power, -300.0)
    assert signature_edge_hz(silent, doppler, -1.0) == 0.0


# ------------------------------------------------------------------ the 64-turbine S-band farm

ATC = "farm_atc_sband.toml"
ATC_SECONDS = 4.0               # every turbine's blades pass their peak (every 0.9 s)


@pytest.fixture(scope="module")
def atc():
    return played(ATC, ATC_SECONDS)


def gate_sizes(e):
    return {rk: len(members) for _, rk, members in e.gates}


def test_the_atc_farm_passes(atc):
    e, samples = atc
    result = checks(e, samples)
    assert len(result) == sum(len(m) for _, _, m in e.gates) and len(e.farm.windmills) == 64
    assert all(c["reached"] for c in result)
    assert [c["windmill"] for c in result if not c["ok"]] == []
    alone = [c for c in result if gate_sizes(e)[c["range_km"]] == 1]
    assert alone                                   # a gate of its own: the edge is its own peak
    for c in alone:
        assert c["explained_by"] == c["windmill"]
        assert abs(c["measured_hz"] - c["physics_max_hz"] * np.sign(c["physics_hz"])) <= c["bin_hz"]


def test_at_the_peak_the_tip_is_not_the_strongest_line(atc):
    # why the criterion changed: a windmill alone in its gate, in the frame of its peak
    e, samples = atc
    r = e.farm.radar
    g = next(g for g, (_, _, m) in enumerate(e.gates) if len(m) == 1)
    w = e.farm.windmills[e.gates[g][2][0]]
    spec = spectrogram(samples[g], r.prf_hz, r.cpi_ms * 1e-3, overlap=OVERLAP)
    track = physics_doppler_track(w, r.wavelength_m, spec.times_s)
    j = int(np.argmax(np.abs(track)))
    power = spec.power_db[j]
    blades = (np.abs(spec.doppler_hz) >= 2 * spec.resolution_hz)
    tip = power[np.argmin(abs(spec.doppler_hz - track[j]))]
    assert tip < power[blades].max() - 6           # the two other blades on the other side are stronger
    assert tip < power.max() - 20                  # and the tower at 0 Hz far stronger


@pytest.mark.parametrize("wrong", ["twice the rate", "half the rate", "mirrored"])
def test_a_wrong_atc_signature_fails(atc, wrong):
    e, samples = atc
    n = samples.shape[1]
    if wrong == "mirrored":
        bad = np.conj(samples)
    else:
        scale = 2.0 if wrong == "twice the rate" else 0.5
        bad = samples[:, (np.arange(n) * scale).astype(int) % n]
    result = checks(e, bad)
    sizes = gate_sizes(e)
    if wrong == "mirrored":
        # a gate of one or two turbines shows the mirror; eight similar rotors at
        # random blade angles are nearly symmetric in Doppler (the docstring)
        few = [c for c in result if sizes[c["range_km"]] <= 2]
        assert few and not any(c["ok"] for c in few)
        assert sum(not c["ok"] for c in result) >= len(result) // 3
    else:
        assert not any(c["ok"] for c in result)


def test_a_missing_atc_signature_fails(atc):
    # the stream of a turbine alone in its gate is not played: its check there fails
    # (in the gates it shares with turbines alike it may pass: their edges are its
    # edges to within a bin)
    e, samples = atc
    g = next(g for g, (_, _, m) in enumerate(e.gates) if len(m) == 1)
    gone = e.gates[g][2][0]
    t = np.arange(samples.shape[1]) / e.farm.radar.prf_hz
    bad = samples.copy()
    for k, (_, _, members) in enumerate(e.gates):
        if gone in members:
            bad[k] -= _replayed(e.streams, gone, t)
    result = checks(e, bad)
    own = [c for c in result if c["range_km"] == e.gates[g][1]]
    assert [c["windmill"] for c in own] == [e.farm.windmills[gone].name] and not own[0]["ok"]
    assert own[0]["measured_hz"] == 0.0                     # no line on its side at all
