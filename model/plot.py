"""Spectrogram pictures like seed Fig. 3.1–3.9: time across, Doppler up, dB in colour."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .radar import RangeBin, Spectrogram  # noqa: E402
from .sfdr import SfdrResult  # noqa: E402
from .turbine import max_doppler_hz  # noqa: E402

__all__ = ["draw_spectrogram", "save_preview"]

_COLOURS = ["#ff5a5f", "#4dd0e1", "#ffd54f", "#aed581", "#ce93d8", "#ffab91", "#90caf9", "#f48fb1"]


def draw_spectrogram(ax, spec: Spectrogram, *, dynamic_range_db: float = 90.0,
                     reference_db: float | None = None, lines=(), zoom_hz: float | None = None):
    """Draw one spectrogram on ``ax``; ``lines`` are (label, max_doppler_hz) pairs.

    The whole Doppler band (±PRF/2) is drawn; ``zoom_hz`` narrows it to ±zoom_hz.
    """
    top = reference_db if reference_db is not None else float(spec.power_db.max())
    half_bin = spec.resolution_hz / 2
    frame = spec.times_s[1] - spec.times_s[0] if spec.times_s.size > 1 else 1.0
    extent = (spec.times_s[0] - frame / 2, spec.times_s[-1] + frame / 2,
              spec.doppler_hz[0] - half_bin, spec.doppler_hz[-1] + half_bin)
    image = ax.imshow(spec.power_db.T - top, origin="lower", aspect="auto", extent=extent,
                      vmin=-dynamic_range_db, vmax=0, cmap="viridis", interpolation="nearest")
    for index, (label, f_max) in enumerate(lines):
        colour = _COLOURS[index % len(_COLOURS)]
        for sign in (1, -1):
            ax.axhline(sign * f_max, color=colour, linestyle="--", linewidth=0.9,
                       label=f"{label}: ±{f_max:.0f} Hz" if sign == 1 else None)
    if lines:
        ax.legend(loc="upper right", fontsize=7, framealpha=0.7)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("Doppler (Hz)")
    ax.set_ylim(extent[2], extent[3])
    if zoom_hz is not None:
        ax.set_ylim(max(-zoom_hz, extent[2]), min(zoom_hz, extent[3]))
    return image


def save_preview(farm, bins: list[RangeBin], spectra: list[Spectrogram], path, *,
                 dynamic_range_db: float = 90.0, title: str | None = None,
                 zoom_hz: float | None = None, sfdr: list[SfdrResult] | None = None) -> None:
    """One panel per range bin, a common dB scale, ±max Doppler lines per windmill.

    Each panel shows the whole band ±PRF/2 (``zoom_hz``: only ±zoom_hz); with
    ``sfdr`` (one result per bin) its title states the bin's SFDR.
    """
    reference = max(float(s.power_db.max()) for s in spectra)
    fig, axes = plt.subplots(len(bins), 1, figsize=(9, 3.2 * len(bins) + 0.8), squeeze=False,
                             layout="constrained")
    wavelength = farm.radar.wavelength_m
    image = None
    for k, (ax, b, spec) in enumerate(zip(axes[:, 0], bins, spectra)):
        lines = [(f"{farm.windmills[i].name} ({farm.windmills[i].rpm:g} rpm)",
                  max_doppler_hz(farm.windmills[i], wavelength)) for i in b.members]
        image = draw_spectrogram(ax, spec, dynamic_range_db=dynamic_range_db,
                                 reference_db=reference, lines=lines, zoom_hz=zoom_hz)
        head = f"range bin {b.range_km:g} km"
        ax.set_title(head if sfdr is None else f"{head} — SFDR {sfdr[k].sfdr_db:.1f} dB", fontsize=10)
    radar = farm.radar
    fig.suptitle(title or (f"{radar.frequency_mhz / 1e3:g} GHz radar, PRF {radar.prf_hz / 1e3:g} kHz, "
                           f"CPI {radar.cpi_ms:g} ms"), fontsize=11)
    fig.colorbar(image, ax=axes[:, 0].tolist(), label="power (dB rel. peak)", shrink=min(1.0, 0.4 + 0.3 * len(bins)))
    fig.savefig(path, dpi=110)
    plt.close(fig)
