"""The end-to-end max-Doppler check (``rast.sim.e2e.doppler_check``) on what
the RTS plays (``model.radar.receive`` with the streams: the quantised,
interpolated words the RTL outputs, per range bin), without a simulator:
it passes on the examples, shared range gates included, and fails on a
signature played at the wrong rate or mirrored."""

from pathlib import Path

import numpy as np
import pytest

from rast.model.config import load_config
from rast.model.radar import receive, spectrogram
from rast.model.stream import build_farm_streams
from rast.sim.e2e import E2E, doppler_check

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
OVERLAP = 0.9          # the end-to-end testbench's default


def played(name, seconds=1.0):
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
