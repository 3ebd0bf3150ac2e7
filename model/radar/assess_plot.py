"""Pictures of ``rast assess``: the range-Doppler map of a stare radar with
its plots drawn on it, and the plan position indicator (PPI) of a scanning one."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

__all__ = ["draw_range_doppler", "draw_ppi", "draw_sweep"]


def draw_range_doppler(path, scene, result, summary: dict, *, title: str = "") -> None:
    """The MTD's output over the run: per gate and Doppler filter the strongest
    power of any CPI (dB FS, after the canceller), the plots of the MTD
    filters (circles) and of the zero-velocity channel (squares), the
    turbines' ranges (ticks on the right)."""
    grid = scene.grid
    edges = (grid.first + np.arange(grid.count + 1)) * grid.spacing_km
    f = result.filter_hz
    step = f[1] - f[0] if f.size > 1 else scene.farm.radar.prf_hz
    f_edges = np.concatenate([f - step / 2, [f[-1] + step / 2]])
    noise_db = scene.noise_dbfs
    fig, ax = plt.subplots(figsize=(9, 7), layout="constrained")
    mesh = ax.pcolormesh(f_edges, edges, result.peak_db, vmin=noise_db - 5, vmax=max(noise_db + 60, 0),
                         cmap="viridis", shading="flat")
    ranges = grid.centres_km
    mtd = result.plot_channel == "mtd"
    if result.plots:
        ax.scatter(result.plot_doppler_hz[mtd], ranges[result.plot_gate[mtd]], s=18, facecolors="none",
                   edgecolors="#ff5a5f", linewidths=0.8, label=f"MTD plots ({int(mtd.sum())})")
        ax.scatter(result.plot_doppler_hz[~mtd], ranges[result.plot_gate[~mtd]], s=22, marker="s",
                   facecolors="none", edgecolors="white", linewidths=0.8,
                   label=f"zero-velocity plots ({int((~mtd).sum())})")
        ax.legend(loc="upper right", fontsize=8, framealpha=0.6)
    for w in scene.farm.windmills:
        ax.plot([f_edges[-1]], [w.range_km], marker="<", color="white", markersize=5, clip_on=False)
    ax.set_xlim(f_edges[0], f_edges[-1])
    ax.set_ylim(edges[0], edges[-1])
    ax.set_xlabel("Doppler (Hz)")
    ax.set_ylabel("range (km)")
    radar = scene.farm.radar
    head = title or "rast assess"
    ax.set_title(f"{head}: {summary['plots']} plots in {summary['scans']} scan(s) of {summary['cpis']} CPIs; "
                 f"{radar.frequency_mhz / 1e3:g} GHz, PRF {radar.prf_hz:g} Hz, noise {noise_db:g} dBFS",
                 fontsize=9)
    fig.colorbar(mesh, ax=ax, label="strongest filter output over the CPIs (dB FS)")
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def draw_ppi(path, scene, result, summary: dict, *, title: str = "") -> None:
    """Plan position indicator: the plots at their CPI's azimuth and range
    (colour: SNR), the turbines at their azimuths."""
    fig = plt.figure(figsize=(8, 8), layout="constrained")
    ax = fig.add_subplot(projection="polar")
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)
    az = np.deg2rad(result.plan.azimuth_deg[result.plot_cpi])
    r = scene.grid.centres_km[result.plot_gate]
    if result.plots:
        points = ax.scatter(az, r, c=result.plot_snr_db, s=10, cmap="plasma")
        fig.colorbar(points, ax=ax, label="SNR (dB)", shrink=0.7)
    for w in scene.farm.windmills:
        ax.plot([np.deg2rad(w.azimuth_deg)], [w.range_km], marker="x", color="black", markersize=5)
    top = scene.grid.centres_km[-1] + scene.grid.spacing_km
    ax.set_rlim(0, top)
    ax.set_title(f"{title or 'rast assess'}: {summary['plots']} plots in {summary['scans']} scan(s)", fontsize=9)
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def draw_sweep(path, rows: list[dict], axes: list[str], *, title: str = "") -> None:
    """False plots per scan against the first swept value, one line per
    combination of the other axes."""
    fig, ax = plt.subplots(figsize=(8, 5), layout="constrained")
    first, rest = axes[0], axes[1:]
    groups = {}
    for row in rows:
        key = tuple(row[a] for a in rest)
        groups.setdefault(key, []).append(row)
    for key, group in groups.items():
        group = sorted(group, key=lambda r: r[first])
        x = [r[first] for r in group]
        y = [r["false_plots_per_scan_mean"] if r.get("false_plots_per_scan_mean") is not None else np.nan
             for r in group]
        label = ", ".join(f"{a} = {v}" for a, v in zip(rest, key)) or "false plots per scan"
        ax.plot(x, y, marker="o", label=label)
        noise = [r.get("noise_plots_per_scan_expected") or np.nan for r in group]
        ax.plot(x, noise, linestyle=":", color="grey")
    ax.set_xlabel(first)
    ax.set_ylabel("false plots per scan")
    ax.grid(alpha=0.3)
    ax.set_title((title or "rast assess --sweep") + " (dotted: noise alone, expected)", fontsize=9)
    if len(groups) > 1 or rest:
        ax.legend(fontsize=8)
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)
