"""How well `rast import` reproduces recordings: rpm found and spectrogram correlation.

Each case is a synthetic recording made by RAST's physics model
(``rast.model.physics.recording.synthetic_recording``: three blades, 15 rpm, 26 m and
12 m scatterers, blade flashes, a mast) and imported as `rast import` does it
(stream rate 4 kHz, FIR interpolation, 20 MS/s). The correlation is that of
``spectrogram_correlation``: the model radar's spectrogram of the replayed
stream words against the recording's, in dB within 40 dB of each one's peak,
100 ms CPIs over the whole periods cut.

    .venv/bin/python bench/bench_recordings.py
"""

import numpy as np

from rast.model.physics.config import Radar
from rast.model.radar.receiver import spectrogram_correlation
from rast.model.physics.recording import (RecordingError, estimate_period, make_loop, recording_streams,
                                          synthetic_recording)

CASES = [
    # name, keyword arguments of synthetic_recording
    ("no noise, period 6666.67 PRIs", dict()),
    ("SNR 20 dB", dict(snr_db=20.0)),
    ("SNR 10 dB", dict(snr_db=10.0)),
    ("SNR 3 dB", dict(snr_db=3.0)),
    ("SNR 0 dB", dict(snr_db=0.0)),
    ("SNR -10 dB", dict(snr_db=-10.0)),
    ("SNR 20 dB, period exactly 6000 PRIs (PRF 4.5 kHz)", dict(snr_db=20.0, prf_hz=4500.0)),
    ("SNR 20 dB, 2.3 periods (3.07 s)", dict(snr_db=20.0, seconds=3.07)),
    ("SNR 20 dB, rpm drifts +0.5 % over 8 s", dict(snr_db=20.0, rpm_drift=0.005)),
    ("SNR 20 dB, rpm drifts +2 % over 8 s", dict(snr_db=20.0, rpm_drift=0.02)),
    ("SNR 20 dB, rpm drifts +5 % over 8 s", dict(snr_db=20.0, rpm_drift=0.05)),
    ("SNR 20 dB, Doppler aliased (PRF 2.5 kHz < 2 x 1458 Hz)", dict(snr_db=20.0, prf_hz=2500.0)),
]


def run(prf_hz=5000.0, **kwargs):
    x = synthetic_recording(prf_hz=prf_hz, **kwargs)
    est = estimate_period(x, prf_hz)
    period = est.period_s
    rate = min(4000.0, prf_hz)
    n = round(rate * period)
    loop = make_loop(x, prf_hz, period, n, n / period)
    streams = recording_streams(loop, name="rec", range_km=2.0, num_blades=3, sample_rate_mhz=20,
                                radar=Radar(5350, prf_hz))
    return 60 / (3 * period), loop.periods, spectrogram_correlation(x, loop, streams), est.method


if __name__ == "__main__":
    print(f"{'case':<56}{'rpm found':>11}{'estimate':>13}{'periods':>9}{'correlation':>13}")
    for name, kwargs in CASES:
        try:
            rpm, periods, corr, method = run(**kwargs)
            print(f"{name:<56}{rpm:>11.5f}{method:>13}{periods:>9}{corr:>13.4f}")
        except RecordingError as error:
            print(f"{name:<56}  refused: {error}")
