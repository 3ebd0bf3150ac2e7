"""Draw docs/range_extended.png: a range-extended turbine in the model radar.

(a) Fine range resolution (100 MS/s, one range cell per RTS sample of 1.5 m):
one blade with a scatterer at 26 m in the line of sight, one revolution per
range cell, power over Doppler; the closed form ±f_max·sqrt(1 − (ΔR/r)²)
(the blade tip's Doppler at range offset ΔR) drawn over it.
(b) Coarse range resolution (20 MS/s, a 2 µs pulse: every tap in one cell):
the replayed stream words of the taps summed by the radar against the
single-tap replay, one revolution's spectrum, and their difference.

    .venv/bin/python examples/plot_range_extended.py
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from rast.model.physics.config import SPEED_OF_LIGHT_M_S as C
from rast.model.physics.farm import parse_config  # noqa: E402
from rast.model.radar.receiver import receive  # noqa: E402
from rast.model.physics.stream import build_farm_streams  # noqa: E402


def db(p):
    return 10 * np.log10(np.maximum(p, 1e-30))


def main(out=Path(__file__).resolve().parent.parent / "docs" / "range_extended.png"):
    fig, (ax_a, ax_b) = plt.subplots(1, 2, figsize=(13, 5.2))

    # (a) fine: one cell per tap
    prf = 20000.0
    farm = parse_config({"sample_rate": 100, "radar_frequency": 5350, "pulse_width": 0.005, "prf": prf,
                         "windmill": [dict(name="a", range=2.0, num_blades=1, rpm=15, radius=[26.0],
                                           rsc=[1.0], range_extended=True)]})
    t, bins, x = receive(farm, 4.0)
    hub = 2 * 2000 / C * 100e6
    offsets_m = np.array([(farm.windmills[b.members[0]].range_cell.delay_samples - hub) * C / 2 / 100e6
                          for b in bins])
    power = np.abs(np.fft.fftshift(np.fft.fft(x, axis=1), axes=1)) ** 2
    power = power.reshape(len(bins), 400, -1).sum(axis=2)          # 50 Hz columns for the picture
    p = db(power) - db(power).max()
    cell = C / 2 / 100e6
    mesh = ax_a.imshow(p, origin="lower", aspect="auto", vmin=-80, vmax=0, cmap="viridis",
                       extent=(-prf / 2, prf / 2, offsets_m[0] - cell / 2, offsets_m[-1] + cell / 2))
    f_max = 2 * (2 * np.pi * 15 / 60) * 26 / farm.radar.wavelength_m
    dr = np.linspace(-26, 26, 400)
    for sign in (1, -1):
        ax_a.plot(sign * f_max * np.sqrt(1 - (dr / 26) ** 2), dr, color="#ff5a5f", ls="--", lw=0.9)
    ax_a.set_xlim(-prf / 2, prf / 2)
    ax_a.set_xlabel("Doppler (Hz)")
    ax_a.set_ylabel("range from the hub (m)")
    ax_a.set_title(f"(a) 100 MS/s, {len(bins)} taps of 1.5 m: power per range cell\n"
                   f"dashed: ±f_max·sqrt(1 − (ΔR/r)²), f_max = {f_max:.0f} Hz", fontsize=10)
    fig.colorbar(mesh, ax=ax_a, label="dB rel. peak")

    # (b) coarse: all taps in one cell, replayed words
    turbine = dict(name="a", range=2.0, num_blades=3, rpm=15, radius=[26.0, 13.0], rsc=[1.0, 0.5],
                   tower_rcs=1.0)
    spectra = {}
    for extended in (True, False):
        farm = parse_config({"sample_rate": 20, "radar_frequency": 5350, "pulse_width": 2.0, "prf": prf,
                             "windmill": [dict(turbine, range_extended=extended)]})
        streams = build_farm_streams(farm)
        t, bins, x = receive(farm, 4.0, streams)
        k = max(range(len(bins)), key=lambda i: len(bins[i].members))
        unit = max(s.relative_amplitude / s.scale for s in streams.streams) * 2 ** 15
        spectra[extended] = (np.fft.fftshift(np.fft.fft(x[k] * unit)) / t.size, len(farm.windmills))
    f = np.fft.fftshift(np.fft.fftfreq(t.size, 1 / prf))
    (ext, taps), (single, _) = spectra[True], spectra[False]
    ref = db(np.abs(single) ** 2).max()
    ax_b.plot(f, db(np.abs(single) ** 2) - ref, lw=0.8, label="single tap (replayed)")
    ax_b.plot(f, db(np.abs(ext) ** 2) - ref, lw=0.8, ls="--", label=f"{taps} taps summed (replayed)")
    ax_b.plot(f, db(np.abs(ext - single) ** 2) - ref, lw=0.6, color="0.4", label="difference")
    err = 10 * np.log10(np.sum(np.abs(ext - single) ** 2) / np.sum(np.abs(single) ** 2))
    ax_b.set_xlim(-prf / 2, prf / 2)
    ax_b.set_ylim(-180, 5)
    ax_b.set_xlabel("Doppler (Hz)")
    ax_b.set_ylabel("dB rel. peak")
    ax_b.set_title(f"(b) 20 MS/s, 2 µs pulse: one cell holds every tap\n"
                   f"difference {err:.1f} dB of the echo's power (the 16-bit words' floor)", fontsize=10)
    ax_b.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"wrote {out}; coarse difference {err:.1f} dB")


if __name__ == "__main__":
    main()
