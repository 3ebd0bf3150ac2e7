"""Make examples/recording_15rpm.npy: a synthetic slow-time recording for `rast import`.

One range cell of a 5.35 GHz radar at a PRF of 5 kHz, 8 s long, holding a
three-bladed turbine at 15 rpm (26 m and 12 m scatterers per blade, blade
flashes at 0° and 180°, a mast), made by RAST's own physics model, plus
complex white noise 20 dB below the echo's mean power (seeded: the file is
the same on every run). complex64, 320 kB.

    .venv/bin/python examples/make_recording.py
    .venv/bin/rast import examples/recording_15rpm.npy --prf 5000 --rate 4000 --out out/recording
"""

from pathlib import Path

import numpy as np

from rast.model.physics.recording import synthetic_recording

if __name__ == "__main__":
    path = Path(__file__).with_name("recording_15rpm.npy")
    np.save(path, synthetic_recording().astype(np.complex64))
    print(f"wrote {path} ({path.stat().st_size} bytes)")
