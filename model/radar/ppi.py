"""The plan position indicator of one revolution (``rast preview --ppi``):
the radar's own display, range against azimuth, each range gate's echo power
integrated over each dwell (the pulses while the beam turns one beamwidth),
after an optional 2- or 3-pulse MTI canceller.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from rast.model.radar.mtd import canceller_weights  # noqa: E402

__all__ = ["DwellImage", "dwell_image", "save_ppi", "MTI_CHOICES"]

MTI_CHOICES = (0, 2, 3)


@dataclass(frozen=True)
class DwellImage:
    """Mean power per (azimuth cell, gate), full-scale units; NaN where no
    pulse of the run looked. Cell ``k`` spans ``[k, k + 1)·cell_deg`` from north
    (the last one ends at 360°)."""
    power: np.ndarray            # (cells, gates)
    pulses: np.ndarray           # (cells,) pulses integrated per cell
    cell_deg: float

    @property
    def cells(self) -> int:
        return self.power.shape[0]

    def power_db(self) -> np.ndarray:
        with np.errstate(divide="ignore", invalid="ignore"):
            return 10 * np.log10(self.power)


def dwell_image(samples: np.ndarray, azimuth_deg: np.ndarray, beamwidth_deg: float, mti: int = 0) -> DwellImage:
    """Integrate |sample|² of ``samples`` (gates, pulses) over the dwells: the
    pulses whose beam azimuth lies in each cell of ``beamwidth_deg``
    (360/beamwidth rounded up to whole cells, counted from north). ``mti``: 2
    or 3 runs the binomial canceller along the pulses first (its output is
    taken at the canceller's last pulse; a cell gets the outputs whose last
    pulse it holds), 0 none."""
    if mti not in MTI_CHOICES:
        raise ValueError(f"mti must be one of {MTI_CHOICES} (pulses of the canceller; 0 for none), not {mti!r}")
    samples = np.asarray(samples, dtype=complex)
    az = np.mod(np.asarray(azimuth_deg, dtype=float), 360.0)
    if samples.ndim != 2 or samples.shape[1] != az.size:
        raise ValueError(f"samples must have shape (gates, pulses) with one azimuth per pulse, not "
                         f"{samples.shape} for {az.size} azimuths")
    if not (math.isfinite(beamwidth_deg) and 0 < beamwidth_deg <= 360):
        raise ValueError(f"beamwidth_deg must be in (0, 360] degrees, not {beamwidth_deg!r}")
    weights = canceller_weights(mti)
    if az.size < weights.size:
        raise ValueError(f"a {mti}-pulse canceller needs at least {weights.size} pulses, not {az.size}")
    # y[n] = sum_k c_k x[n - k], n from the canceller's last pulse on
    kept = az.size - weights.size + 1
    y = sum(c * samples[:, weights.size - 1 - k: weights.size - 1 - k + kept] for k, c in enumerate(weights))
    cells = math.ceil(360 / beamwidth_deg - 1e-9)
    cell = np.minimum((az[weights.size - 1:] / beamwidth_deg).astype(np.int64), cells - 1)
    count = np.bincount(cell, minlength=cells)
    total = np.zeros((cells, samples.shape[0]))
    np.add.at(total, cell, (np.abs(y) ** 2).T)
    with np.errstate(invalid="ignore", divide="ignore"):
        power = np.where(count[:, None] > 0, total / np.maximum(count, 1)[:, None], np.nan)
    return DwellImage(power, count, beamwidth_deg)


def _draw(ax, image: DwellImage, db, gate_edges_km, low, top, turbines):
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)
    theta = np.deg2rad(np.minimum(np.arange(image.cells + 1) * image.cell_deg, 360.0))
    mesh = ax.pcolormesh(theta, gate_edges_km, np.ma.masked_invalid(db).T, vmin=low, vmax=max(top, low + 1),
                         cmap="magma", shading="flat")
    for az, r in turbines:
        ax.plot([np.deg2rad(az)], [r], marker="+", color="#6cf", markersize=3, alpha=0.5)
    ax.grid(alpha=0.3)
    return mesh


def _draw_held(ax, held, caption):
    """Channels held against the beam's azimuth, on polar axes (each 16
    codes' most, so no peak is lost at the line's resolution)."""
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)
    most = held.reshape(-1, 16).max(axis=1)
    theta = np.deg2rad(np.arange(most.size + 1) * 360.0 / most.size)
    ax.plot(theta, np.append(most, most[0]), color="#c33", linewidth=1)
    peak = int(np.argmax(most))
    ax.plot([theta[peak]], [most[peak]], marker="o", color="#c33", markersize=4)
    ax.set_rlim(0, most.max() * 1.1 + 1)
    ax.set_rlabel_position(112.5)
    ax.grid(alpha=0.3)
    ax.set_title(caption, fontsize=9)


def save_ppi(path, image: DwellImage, gate_edges_km: np.ndarray, *, turbines=(), dynamic_range_db: float = 60.0,
             floor_db: float | None = None, title: str = "", held=None, held_caption: str = "") -> None:
    """Draw ``image`` on polar axes (north up, clockwise): colour the dwell's
    mean power in dB FS over ``dynamic_range_db`` below the strongest cell,
    not below ``floor_db`` when given (the noise); ``turbines``: (azimuth_deg, range_km) pairs marked
    with a small cross. When the turbines lie within 90° of azimuth, a second
    panel zooms on their sector (three beamwidths either side) and ranges;
    otherwise ``held`` (the channels a board following the beam holds at
    each of the 2**16 beam codes), when given, is the second panel."""
    db = image.power_db()
    top = np.nanmax(db) if np.isfinite(db).any() else 0.0
    low = top - dynamic_range_db if floor_db is None else max(floor_db, top - dynamic_range_db)
    turbines = list(turbines)
    sector = None
    if turbines:
        az = np.mod(np.array([a for a, _ in turbines]), 360.0)
        centre = np.rad2deg(np.angle(np.exp(1j * np.deg2rad(az)).mean()))
        off = np.mod(az - centre + 180.0, 360.0) - 180.0
        if np.ptp(off) < 90:
            pad = 3 * image.cell_deg
            sector = (centre + off.min() - pad, centre + off.max() + pad)
    second = sector is not None or held is not None
    fig = plt.figure(figsize=(15 if second else 8.5, 7.5), layout="constrained")
    ax = fig.add_subplot(1, 2 if second else 1, 1, projection="polar")
    mesh = _draw(ax, image, db, gate_edges_km, low, top, turbines)
    ax.set_rlim(0, gate_edges_km[-1])
    ax.set_rlabel_position(112.5)
    ax.set_title("one revolution (range in km)", fontsize=9)
    if sector:
        zoom = fig.add_subplot(1, 2, 2, projection="polar")
        _draw(zoom, image, db, gate_edges_km, low, top, turbines)
        zoom.set_thetamin(sector[0])
        zoom.set_thetamax(sector[1])
        zoom.set_rlim(gate_edges_km[0], gate_edges_km[-1])
        # the range axis starts near the pole: the sector fills the panel
        zoom.set_rorigin(gate_edges_km[0] - 0.5 * (gate_edges_km[-1] - gate_edges_km[0]))
        zoom.set_title(f"the turbines' sector (range axis from {gate_edges_km[0]:.1f} km), {sector[0] % 360:.1f}°-{sector[1] % 360:.1f}°", fontsize=9)
    elif held is not None:
        _draw_held(fig.add_subplot(1, 2, 2, projection="polar"), np.asarray(held), held_caption)
    fig.suptitle(title, fontsize=10)
    fig.colorbar(mesh, ax=fig.axes, shrink=0.75, label="mean power over the dwell (dB FS)")
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)
