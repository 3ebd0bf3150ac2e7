"""Spectrogram pictures like seed Fig. 3.1–3.9: time across, Doppler up, dB in colour."""

from __future__ import annotations

import math
import textwrap

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402
import numpy as np  # noqa: E402

from rast.model.radar.receiver import RangeBin, Spectrogram  # noqa: E402
from rast.model.radar.sfdr import SfdrResult  # noqa: E402
from rast.model.physics.turbine import max_doppler_hz  # noqa: E402

__all__ = ["draw_spectrogram", "save_preview", "save_range_doppler", "range_bands", "save_gate_grid", "grid_columns",
           "gate_title", "MAX_PANELS", "STACKED_PANELS"]

#: ``rast preview`` draws one spectrogram panel per range bin up to this many
#: bins (a 64-channel farm: one bin per channel), and the range-Doppler map beyond.
MAX_PANELS = 64
#: Up to this many range bins (or gates) the panels are stacked one per row, full width;
#: beyond, they are laid out in a grid of small panels (:func:`save_gate_grid`).
STACKED_PANELS = 8

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
    ``sfdr`` (one result per bin) its title states the bin's SFDR. Up to
    ``STACKED_PANELS`` bins the panels are stacked full width, beyond that they
    form a grid of small panels (:func:`save_gate_grid`).
    """
    radar = farm.radar
    title = title or (f"{radar.frequency_mhz / 1e3:g} GHz radar, PRF {radar.prf_hz / 1e3:g} kHz, "
                      f"CPI {radar.cpi_ms:g} ms")
    wavelength = farm.radar.wavelength_m
    if len(bins) > STACKED_PANELS:
        gates = [dict(title=gate_title(b.range_km, [farm.windmills[i].name for i in b.members],
                                       None if sfdr is None else sfdr[k].sfdr_db),
                      max_doppler_hz=[max_doppler_hz(farm.windmills[i], wavelength) for i in b.members],
                      power_db=[spec.power_db]) for k, (b, spec) in enumerate(zip(bins, spectra))]
        save_gate_grid(path, spectra[0].times_s, spectra[0].doppler_hz, gates,
                       dynamic_range_db=dynamic_range_db, zoom_hz=zoom_hz,
                       title=f"{len(farm.windmills)} windmills in {len(bins)} range bins — {title}; "
                             "dashed: ±max Doppler of each windmill in the bin")
        return
    reference = max(float(s.power_db.max()) for s in spectra)
    fig, axes = plt.subplots(len(bins), 1, figsize=(9, 3.2 * len(bins) + 0.8), squeeze=False,
                             layout="constrained")
    image = None
    for k, (ax, b, spec) in enumerate(zip(axes[:, 0], bins, spectra)):
        lines = [(f"{farm.windmills[i].name} ({farm.windmills[i].rpm:g} rpm)",
                  max_doppler_hz(farm.windmills[i], wavelength)) for i in b.members]
        image = draw_spectrogram(ax, spec, dynamic_range_db=dynamic_range_db,
                                 reference_db=reference, lines=lines, zoom_hz=zoom_hz)
        head = f"range bin {b.range_km:g} km"
        ax.set_title(head if sfdr is None else f"{head} — SFDR {sfdr[k].sfdr_db:.1f} dB", fontsize=10)
    fig.suptitle(title, fontsize=11)
    fig.colorbar(image, ax=axes[:, 0].tolist(), label="power (dB rel. peak)", shrink=min(1.0, 0.4 + 0.3 * len(bins)))
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def grid_columns(n: int) -> int:
    """Gates per row of the grid: as many rows as columns (8 × 8 for 64 gates)."""
    return max(1, math.ceil(math.sqrt(n)))


def gate_title(range_km: float, names: list[str], sfdr_db: float | None = None, *, width: int = 30,
               lines: int = 3) -> str:
    """A small panel's title: the gate's range (and SFDR), then its windmills'
    names wrapped to ``width`` characters on at most ``lines`` lines (``+N``:
    the names left out)."""
    head = f"{range_km:.3f} km" + ("" if sfdr_db is None else f" · SFDR {sfdr_db:.0f} dB")
    for shown in range(len(names), -1, -1):
        text = ", ".join(names[:shown]) + (f" +{len(names) - shown}" if shown < len(names) else "")
        wrapped = textwrap.wrap(text, width)
        if len(wrapped) <= lines:
            return "\n".join([head, *wrapped])
    return head


def save_gate_grid(path, times_s: np.ndarray, doppler_hz: np.ndarray, gates: list[dict], *,
                   columns: tuple[str, ...] = ("",), dynamic_range_db: float = 90.0,
                   zoom_hz: float | None = None, title: str = "", dpi: int = 100) -> None:
    """Many range gates' spectrograms as a grid of small panels, one colour scale.

    ``gates``: per gate a dict with ``title`` (:func:`gate_title`), ``max_doppler_hz``
    (its windmills', drawn as dashed lines at ±each) and ``power_db``: one
    (frames, bins) array per entry of ``columns``, drawn side by side in the
    gate's cell (``rast cosim``: the RTL's and the model's; ``columns`` label
    the panels in their corner). Every panel spans the whole Doppler band
    ±PRF/2 (``zoom_hz``: only ±zoom_hz) and the same dB scale, 0 dB the
    strongest value of any panel, so gates compare at a glance.
    """
    n, k = len(gates), len(columns)
    per_row = grid_columns(n)
    rows = math.ceil(n / per_row)
    # a cell of k panels, then (for k > 1) a narrow empty column that sets the cells apart
    step = k + (k > 1)
    ratios = ([1.0] * k + [0.02] * (k > 1)) * per_row
    # laid out by hand in inches (matplotlib's constrained layout takes a minute on 200 axes)
    panel_w, panel_h, title_h, gap = (2.3 if k == 1 else 1.35), 1.45, 0.5, 0.1
    left, right, bottom, top_h = 0.6, 1.1, 0.45, 0.45
    width = sum(ratios) * panel_w + gap * (len(ratios) - 1) + left + right
    height = rows * (panel_h + title_h) + bottom + top_h
    fig = plt.figure(figsize=(width, height))
    grid = fig.add_gridspec(rows, step * per_row, width_ratios=ratios, left=left / width,
                            right=1 - right / width, bottom=bottom / height, top=1 - (top_h + title_h) / height,
                            wspace=gap * len(ratios) / (sum(ratios) * panel_w), hspace=title_h / panel_h)
    axes = np.asarray(grid.subplots(squeeze=False))      # not shared: sharing 200 axes is quadratic
    panels = axes[:, [cell * step + c for cell in range(per_row) for c in range(k)]]
    for ax in axes[:, [cell * step + k for cell in range(per_row)]].ravel() if k > 1 else []:
        ax.set_visible(False)
    top = max(float(p.max()) for g in gates for p in g["power_db"])
    half_bin = (doppler_hz[1] - doppler_hz[0]) / 2 if doppler_hz.size > 1 else 0.5
    band = (doppler_hz[0] - half_bin, doppler_hz[-1] + half_bin)
    frame = times_s[1] - times_s[0] if times_s.size > 1 else 1.0
    extent = (times_s[0] - frame / 2, times_s[-1] + frame / 2, *band)
    image = None
    for index, gate in enumerate(gates):
        row, cell = divmod(index, per_row)
        for c, power in enumerate(gate["power_db"]):
            ax = panels[row, cell * k + c]
            image = ax.imshow(power.T - top, origin="lower", aspect="auto", extent=extent,
                              vmin=-dynamic_range_db, vmax=0, cmap="viridis", interpolation="nearest")
            for f in gate["max_doppler_hz"]:
                ax.axhline(f, color="#ff5a5f", linestyle="--", linewidth=0.5)
                ax.axhline(-f, color="#ff5a5f", linestyle="--", linewidth=0.5)
            if c == 0:
                ax.set_title(gate["title"], fontsize=6.5, loc="left", pad=2)
            if columns[c]:
                ax.text(0.03, 0.97, columns[c], transform=ax.transAxes, fontsize=6, color="white",
                        va="top", ha="left")
            ax.tick_params(labelsize=6, length=2, pad=1)
            ax.xaxis.set_major_locator(MaxNLocator(4))
    low, high = band if zoom_hz is None else (max(-zoom_hz, band[0]), min(zoom_hz, band[1]))
    for index, ax in enumerate(panels.ravel()):
        column = index % (per_row * k)
        if index >= n * k:
            ax.set_visible(False)
            continue
        ax.set_xlim(extent[0], extent[1])
        ax.set_ylim(low, high)
        if column == 0:
            ax.set_ylabel("Doppler (Hz)", fontsize=7)
        else:
            ax.tick_params(labelleft=False)
        if index + per_row * k >= n * k:           # no panel under it
            ax.set_xlabel("time (s)", fontsize=7)
        else:
            ax.tick_params(labelbottom=False)
    bar = fig.add_axes([1 - (right - 0.25) / width, 0.3, 0.15 / width, 0.4])
    fig.colorbar(image, cax=bar, label="power (dB rel. peak)")
    if title:
        fig.suptitle(title, fontsize=10, y=1 - 0.15 / height, va="top")
    fig.savefig(path, dpi=dpi, format="png")
    plt.close(fig)


def range_bands(ranges_km):
    """The rows of a range-Doppler map for bins at ``ranges_km`` (ascending):
    ``(edges, row, low, high)``: each bin a band from ``low`` to ``high``, half
    way to its neighbours but at most 1 % of the ranges shown (0.05 km at
    least) either side, so that farms kilometres apart leave the range between
    them empty; ``edges`` every band's limits, ``row[k]`` the row of ``edges``
    bin k fills (the others are the gaps)."""
    ranges = np.asarray(ranges_km, dtype=float)
    cap = max(0.01 * float(np.ptp(ranges)), 0.05)
    low = ranges - np.minimum(np.diff(ranges, prepend=-np.inf) / 2, cap)
    high = ranges + np.minimum(np.diff(ranges, append=np.inf) / 2, cap)
    edges = np.unique(np.concatenate([low, high]))
    return edges, np.searchsorted(edges, ranges) - 1, low, high


def save_range_doppler(farm, bins: list[RangeBin], spectra: list[Spectrogram], path, *,
                       dynamic_range_db: float = 90.0, zoom_hz: float | None = None,
                       title: str | None = None, beside: tuple | None = None) -> None:
    """A farm's range-Doppler map: one row per range bin (at its range), the
    whole Doppler band ±PRF/2 across, colour the bin's peak power over all CPIs
    (max hold, dB relative to the farm's peak). White ticks mark ±max Doppler of
    the windmills at each bin's own range. ``beside`` = ``(label, other_label,
    other_spectra)``: a second map of the same bins to the right, on the same
    colour scale (a cosimulation's RTL beside its model)."""
    maps = [(None, spectra)] if beside is None else [(beside[0], spectra), (beside[1], beside[2])]
    held = [np.array([s.power_db.max(axis=0) for s in sp]) for _, sp in maps]     # (bins, doppler) each
    reference = max(float(h.max()) for h in held)
    edges, row, low_edges, high_edges = range_bands([b.range_km for b in bins])
    doppler = spectra[0].doppler_hz
    half = spectra[0].resolution_hz / 2
    d_edges = np.concatenate([doppler - half, [doppler[-1] + half]])
    fig, axes = plt.subplots(1, len(maps), figsize=(9 * len(maps), 7), layout="constrained", squeeze=False,
                             sharey=True)
    wavelength = farm.radar.wavelength_m
    radar = farm.radar
    for ax, (label, _), h in zip(axes[0], maps, held):
        rows = np.full((edges.size - 1, h.shape[1]), np.nan)       # the rows between bins stay empty
        rows[row] = h - reference
        mesh = ax.pcolormesh(d_edges, edges, np.ma.masked_invalid(rows), vmin=-dynamic_range_db, vmax=0,
                             cmap="viridis", shading="flat")
        for b, low, high in zip(bins, low_edges, high_edges):
            for i in b.members:
                w = farm.windmills[i]
                if w.range_km == b.range_km:
                    f = max_doppler_hz(w, wavelength)
                    ax.vlines([-f, f], low, high, colors="white", linewidth=0.8)
        ax.set_xlim(d_edges[0], d_edges[-1])
        if zoom_hz is not None:
            ax.set_xlim(max(-zoom_hz, d_edges[0]), min(zoom_hz, d_edges[-1]))
        ax.set_ylim(edges[0], edges[-1])
        ax.set_xlabel("Doppler (Hz)")
        if label:
            ax.set_title(label, fontsize=10)
    axes[0, 0].set_ylabel("range bin (km)")
    fig.suptitle(title or (f"{len(farm.windmills)} windmills in {len(bins)} range bins: peak over "
                           f"{spectra[0].times_s.size} CPIs — {radar.frequency_mhz / 1e3:g} GHz, "
                           f"PRF {radar.prf_hz / 1e3:g} kHz, CPI {radar.cpi_ms:g} ms"), fontsize=10)
    fig.colorbar(mesh, ax=axes[0, -1], label="power (dB rel. peak)")
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)
