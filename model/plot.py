"""Spectrogram pictures like seed Fig. 3.1–3.9: time across, Doppler up, dB in colour."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .radar import RangeBin, Spectrogram  # noqa: E402
from .sfdr import SfdrResult  # noqa: E402
from .turbine import max_doppler_hz  # noqa: E402

__all__ = ["draw_spectrogram", "save_preview", "save_range_doppler", "MAX_PANELS"]

#: ``rast preview`` draws one spectrogram panel per range bin up to this many
#: bins, and the range-Doppler map beyond.
MAX_PANELS = 8

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


def save_range_doppler(farm, bins: list[RangeBin], spectra: list[Spectrogram], path, *,
                       dynamic_range_db: float = 90.0, zoom_hz: float | None = None,
                       title: str | None = None) -> None:
    """A farm's range-Doppler map: one row per range bin (at its range), the
    whole Doppler band ±PRF/2 across, colour the bin's peak power over all CPIs
    (max hold, dB relative to the farm's peak). White ticks mark ±max Doppler of
    the windmills at each bin's own range."""
    held = np.array([s.power_db.max(axis=0) for s in spectra])          # (bins, doppler)
    reference = float(held.max())
    ranges = np.array([b.range_km for b in bins])
    if ranges.size > 1:
        mids = (ranges[1:] + ranges[:-1]) / 2
        edges = np.concatenate([[ranges[0] - (mids[0] - ranges[0])], mids,
                                [ranges[-1] + (ranges[-1] - mids[-1])]])
    else:
        edges = np.array([ranges[0] - 0.05, ranges[0] + 0.05])
    doppler = spectra[0].doppler_hz
    half = spectra[0].resolution_hz / 2
    d_edges = np.concatenate([doppler - half, [doppler[-1] + half]])
    fig, ax = plt.subplots(figsize=(9, 7), layout="constrained")
    mesh = ax.pcolormesh(d_edges, edges, held - reference, vmin=-dynamic_range_db, vmax=0,
                         cmap="viridis", shading="flat")
    wavelength = farm.radar.wavelength_m
    for b, low, high in zip(bins, edges[:-1], edges[1:]):
        for i in b.members:
            w = farm.windmills[i]
            if w.range_km == b.range_km:
                f = max_doppler_hz(w, wavelength)
                ax.vlines([-f, f], low, high, colors="white", linewidth=0.8)
    radar = farm.radar
    ax.set_xlim(d_edges[0], d_edges[-1])
    if zoom_hz is not None:
        ax.set_xlim(max(-zoom_hz, d_edges[0]), min(zoom_hz, d_edges[-1]))
    ax.set_ylim(edges[0], edges[-1])
    ax.set_xlabel("Doppler (Hz)")
    ax.set_ylabel("range bin (km)")
    ax.set_title(title or (f"{len(farm.windmills)} windmills in {len(bins)} range bins: peak over "
                           f"{spectra[0].times_s.size} CPIs — {radar.frequency_mhz / 1e3:g} GHz, "
                           f"PRF {radar.prf_hz / 1e3:g} kHz, CPI {radar.cpi_ms:g} ms"), fontsize=10)
    fig.colorbar(mesh, ax=ax, label="power (dB rel. peak)")
    fig.savefig(path, dpi=110)
    plt.close(fig)
