"""Per-gate spectrogram pictures of many range gates (``rast preview``, ``rast cosim``):
a grid of small panels instead of one column 64 panels tall, titles that name
every turbine or count those left out."""

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from rast.cosim import _png
from rast.model.physics.farm import load_config
from rast.model.radar.plot import STACKED_PANELS, gate_title, grid_columns

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def png_size(path) -> tuple[int, int]:
    """Width and height of a PNG, from its IHDR chunk."""
    data = Path(path).read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


@pytest.mark.parametrize("n, columns", [(1, 1), (9, 3), (10, 4), (64, 8), (65, 9)])
def test_grid_is_about_square(n, columns):
    assert grid_columns(n) == columns
    assert (columns - 1) ** 2 < n <= columns ** 2


def test_title_names_every_turbine_or_counts_the_rest():
    names = [f"t31000{k:02d}" for k in range(1, 9)]
    title = gate_title(27.2633, names, 118.6, lines=2)
    head, *rest = title.split("\n")
    assert head == "27.263 km · SFDR 119 dB" and len(rest) <= 2
    text = " ".join(rest)
    shown = [n for n in names if n in text]
    assert shown == names[:len(shown)] and 0 < len(shown) < len(names)
    assert text.endswith(f"+{len(names) - len(shown)}")
    assert all(n in gate_title(27.2633, names) for n in names)     # three lines hold eight


def fake_cosim(n_gates, frames=5, bins=100, prf=1000.0):
    """What rast cosim hands its picture: gates of the 64-turbine example and RTL and model powers."""
    farm = load_config(EXAMPLES / "farm_layout.toml")
    per = len(farm.windmills) // n_gates
    gates = [(k, farm.windmills[k * per].range_km, list(range(k * per, (k + 1) * per))) for k in range(n_gates)]
    rng = np.random.default_rng(1)
    data = dict(times_s=0.05 + 0.01 * np.arange(frames),
                doppler_hz=np.fft.fftshift(np.fft.fftfreq(bins, 1 / prf)))
    for g in range(n_gates):
        data[f"power_rtl_{g}"] = data[f"power_model_{g}"] = rng.uniform(-90, 0, (frames, bins))
    e = SimpleNamespace(gates=gates, farm=farm, config="farm_layout.toml",
                        pulse=SimpleNamespace(n_pulses=200))
    return e, data


def test_cosim_draws_64_gates_as_a_grid(tmp_path):
    e, data = fake_cosim(64)
    out = tmp_path / "spectrogram.png"
    _png(out, e, data, 0.9)
    width, height = png_size(out)
    # stacked, 64 rows of 3.4 in would be 21 800 px tall; the grid is 8 x 8 cells
    assert height < 2000 and width < 3000 and height < width
    assert not list(tmp_path.glob("*.tmp.png"))


def test_cosim_stacks_a_few_gates(tmp_path):
    e, data = fake_cosim(STACKED_PANELS // 2)
    out = tmp_path / "spectrogram.png"
    _png(out, e, data, 0.9)
    width, height = png_size(out)
    assert height > width                      # one full-width row per gate, as before
