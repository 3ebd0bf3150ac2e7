"""What the radar will report: a reference processor on the model radar's
range-gate samples (``rast assess``).

The samples are :func:`rast.model.radar.receiver.receive`'s (what the RTS
plays, quantised, or with ``physics`` the physics itself), or a
cosimulation's ``gates.npy`` (the RTL's own output), laid on a regular grid
of range gates with the receiver's noise (``noise_dbfs``) in every gate.
Then, as an airport surveillance radar's MTD would:

* an MTI canceller and a Doppler filter bank per CPI (:mod:`~rast.model.radar.mtd`);
* CA-CFAR over range in every Doppler filter but the zero-velocity one, and a
  clutter map on the zero-velocity filter (:mod:`~rast.model.radar.cfar`);
* one plot per range gate and CPI: the strongest detection among its filters;

and as a weather radar would, the pulse-pair moments per gate
(:mod:`~rast.model.radar.moments`). :func:`assess` runs it all and returns
the plots and a summary; :func:`write_outputs` writes ``plots.csv``,
``summary.json`` and the picture.

The dwell is a parameter (:func:`process`): without antenna azimuths a
stare radar is processed CPI by CPI, a scan being a fixed number of CPIs;
with one azimuth per pulse, CPIs are aligned to the dwells in the beam and a
scan is a revolution.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rast.model.physics.config import SPEED_OF_LIGHT_M_S, Farm
from rast.model.radar import cfar as cf
from rast.model.radar import moments as mo
from rast.model.radar import mtd as mt
from rast.model.radar.receiver import (NOISE_SEED, echo_samples, physics_full_scale, range_bins, receive,
                                      receiver_noise)

__all__ = ["AssessConfig", "GateGrid", "Scene", "Result", "DEFAULT_NOISE_DBFS", "make_grid", "embed",
           "simulate", "scene_from_gates", "process", "summarize", "assess", "write_outputs",
           "MAX_ASSESS_SAMPLES", "read_gates"]

#: The receiver noise when neither the config (``noise_dbfs``) nor the caller gives one.
DEFAULT_NOISE_DBFS = -70.0
#: Most gate samples (gates × pulses) one assessment holds (2**26 complex: 1 GB).
MAX_ASSESS_SAMPLES = 1 << 26


@dataclass(frozen=True)
class AssessConfig:
    """Everything the processor is told. ``noise_dbfs`` None: the config's,
    else :data:`DEFAULT_NOISE_DBFS`; ``gate_km`` None: the pulse's range
    resolution c·τ/2; ``scan_cpis`` None: the stare radar's whole run is one
    scan; ``beamwidth_deg``: the dwell of a scanning radar."""
    seconds: float = 10.0
    mtd: mt.MtdConfig = mt.MtdConfig()
    cfar: cf.CfarConfig = cf.CfarConfig()
    clutter_map: cf.ClutterMapConfig = cf.ClutterMapConfig()
    moments: mo.MomentsConfig = mo.MomentsConfig()
    noise_dbfs: float | None = None
    noise_seed: int = NOISE_SEED
    physics: bool = False
    gate_km: float | None = None
    scan_cpis: int | None = None
    beamwidth_deg: float = 1.4

    def __post_init__(self):
        if not (math.isfinite(self.seconds) and self.seconds > 0):
            raise ValueError(f"seconds must be a positive number of seconds, not {self.seconds!r}")
        if self.noise_dbfs is not None and not (math.isfinite(self.noise_dbfs) and self.noise_dbfs <= 0):
            raise ValueError(f"noise_dbfs must be at most 0 dBFS, not {self.noise_dbfs!r}")
        if self.gate_km is not None and not (math.isfinite(self.gate_km) and self.gate_km > 0):
            raise ValueError(f"gate_km must be a positive range in km, not {self.gate_km!r}")
        if self.scan_cpis is not None and not (isinstance(self.scan_cpis, int) and self.scan_cpis >= 1):
            raise ValueError(f"scan_cpis must be a positive whole number of CPIs, not {self.scan_cpis!r}")
        if not (math.isfinite(self.beamwidth_deg) and 0 < self.beamwidth_deg <= 360):
            raise ValueError(f"beamwidth_deg must be in (0, 360] degrees, not {self.beamwidth_deg!r}")


# ---------------------------------------------------------------------------
# Range gates

@dataclass(frozen=True)
class GateGrid:
    """Gate g holds ranges [(first + g)·spacing, (first + g + 1)·spacing) km."""
    first: int
    spacing_km: float
    count: int

    @property
    def centres_km(self) -> np.ndarray:
        return (self.first + np.arange(self.count) + 0.5) * self.spacing_km

    def index(self, range_km) -> np.ndarray:
        return np.floor(np.asarray(range_km, dtype=float) / self.spacing_km + 1e-9).astype(np.int64) - self.first


def make_grid(ranges_km, spacing_km: float, margin_gates: int) -> GateGrid:
    """Gates from ``margin_gates`` before the nearest range to as many after the
    farthest (not before the radar), counted from the radar."""
    ranges = np.asarray(ranges_km, dtype=float)
    lo = max(0, int(math.floor(ranges.min() / spacing_km + 1e-9)) - margin_gates)
    hi = int(math.floor(ranges.max() / spacing_km + 1e-9)) + margin_gates
    return GateGrid(lo, spacing_km, hi - lo + 1)


def embed(samples: np.ndarray, ranges_km, grid: GateGrid) -> np.ndarray:
    """The per-range samples (rows at ``ranges_km``) on the gate grid: a row goes
    to the gate holding its range; of several in one gate the farthest wins
    (its sample sees every echo in the gate, eq. 2.3); other gates are 0."""
    ranges = np.asarray(ranges_km, dtype=float)
    out = np.zeros((grid.count, samples.shape[1]), dtype=complex)
    order = np.argsort(ranges, kind="stable")
    gates = grid.index(ranges[order])
    last = np.flatnonzero(np.concatenate([np.diff(gates) != 0, [True]]))
    out[gates[last]] = samples[order[last]]
    return out


# ---------------------------------------------------------------------------
# Scenes: the samples the processor gets

@dataclass
class Scene:
    samples: np.ndarray            # (gates, pulses), full-scale units, noise included
    times_s: np.ndarray            # (pulses,)
    grid: GateGrid
    farm: Farm
    noise_dbfs: float
    source: str                    # "replay", "physics" or "rtl"
    azimuth_deg: np.ndarray | None = None

    @property
    def noise_power(self) -> float:
        return 10 ** (self.noise_dbfs / 10)


def _noise_dbfs(farm: Farm, cfg: AssessConfig) -> float:
    if cfg.noise_dbfs is not None:
        return cfg.noise_dbfs
    return farm.noise_dbfs if farm.noise_dbfs is not None else DEFAULT_NOISE_DBFS


def _spacing_km(farm: Farm, cfg: AssessConfig) -> float:
    return cfg.gate_km or SPEED_OF_LIGHT_M_S * farm.radar.pulse_width_us * 1e-6 / 2 / 1e3


def _stagger_times(cfg: AssessConfig, prf_hz: float) -> np.ndarray:
    """Pulse times of CPIs alternating between ``prf_hz`` and the stagger PRF."""
    n = cfg.mtd.cpi_pulses
    prfs = (prf_hz, cfg.mtd.stagger_prf_hz)
    starts, t, k = [], 0.0, 0
    while t + n / prfs[k % 2] <= cfg.seconds + 1e-12:
        starts.append(t + np.arange(n) / prfs[k % 2])
        t += n / prfs[k % 2]
        k += 1
    return np.concatenate(starts) if starts else np.zeros(0)


def _check_size(gates: int, pulses: int) -> None:
    if gates * pulses > MAX_ASSESS_SAMPLES:
        raise ValueError(f"{pulses:,} pulses in {gates} range gates are {gates * pulses:.3g} samples, more "
                         f"than the {MAX_ASSESS_SAMPLES:,} an assessment holds: give a shorter run")


def simulate(farm: Farm, cfg: AssessConfig, *, farm_streams=None) -> Scene:
    """The model radar's samples on the gate grid, with the receiver's noise.

    What the RTS plays (``farm_streams``, built here unless given) or, with
    ``cfg.physics``, the physics; the noise is :func:`receiver_noise` of
    ``noise_dbfs`` in every gate (the physics' at the replay's level,
    :func:`physics_full_scale`)."""
    from rast.model.physics.stream import build_farm_streams
    quiet = dataclasses.replace(farm, noise_dbfs=None)
    # the assessment does not need the streams to fit a build's pool (ram_depth)
    streams = None if cfg.physics else (farm_streams or build_farm_streams(quiet, check_ram_depth=False))
    prf = farm.radar.prf_hz
    spacing = _spacing_km(farm, cfg)
    bins = range_bins(farm)
    grid = make_grid([b.range_km for b in bins], spacing, cfg.cfar.reach + 2)
    if cfg.mtd.stagger_prf_hz is None:
        pulses = int(round(cfg.seconds * prf))
        _check_size(grid.count, pulses)
        times, bins, samples = receive(quiet, cfg.seconds, streams)
    else:
        times = _stagger_times(cfg, prf)
        _check_size(grid.count, times.size)
        bins, samples = echo_samples(quiet, times, streams)
    gated = embed(samples, [b.range_km for b in bins], grid)
    level = _noise_dbfs(farm, cfg)
    unit = 1.0 / physics_full_scale(quiet) if cfg.physics else 1.0
    gated += receiver_noise(gated.shape, level, cfg.noise_seed, unit)
    if cfg.physics:                 # in the replay's full scale, as every other source
        gated *= physics_full_scale(quiet)
    return Scene(gated, times, grid, farm, level, "physics" if cfg.physics else "replay",
                 _scan_azimuth(farm, times))


def _scan_azimuth(farm: Farm, times_s: np.ndarray):
    """The beam's azimuth per pulse when the antenna turns, else None (a stare radar)."""
    return farm.scan.beam_azimuth_deg(times_s) if farm.scan.turning else None


def read_gates(path) -> tuple[np.ndarray, dict, Path]:
    """A cosimulation's ``gates.npy`` (complex, (pulses, gates)) and the
    ``report.json`` beside it; ``path`` is the file or its folder. Raises
    ValueError naming the file."""
    path = Path(path)
    if path.is_dir():
        path = path / "gates.npy"
    try:
        gates = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as error:
        raise ValueError(f"cannot read the gates {path}: {getattr(error, 'strerror', None) or error}") from None
    if gates.ndim != 2 or not np.iscomplexobj(gates) or 0 in gates.shape:
        raise ValueError(f"{path} is not a cosimulation's gates: it must be a complex array of shape "
                         f"(pulses, gates), not {gates.dtype} of shape {gates.shape}")
    report_path = path.parent / "report.json"
    try:
        report = json.loads(report_path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as error:
        raise ValueError(f"cannot read the cosimulation's report {report_path} beside the gates: "
                         f"{getattr(error, 'strerror', None) or error}") from None
    if not isinstance(report, dict) or not isinstance(report.get("gates_km"), list) \
            or not isinstance(report.get("prf_hz"), (int, float)):
        raise ValueError(f"{report_path} lacks 'prf_hz' and 'gates_km': give the folder `rast cosim` wrote")
    if len(report["gates_km"]) != gates.shape[1]:
        raise ValueError(f"{path} has {gates.shape[1]} gates but {report_path} lists {len(report['gates_km'])}")
    return gates, report, path


def scene_from_gates(farm: Farm, gates: np.ndarray, report: dict, cfg: AssessConfig) -> Scene:
    """The RTL's samples (``gates.npy``: output words at each gate's sample,
    one row per pulse) as a scene: in full-scale units (÷ 2**15), on the
    gate grid, with the receiver's noise added as for the model."""
    from rast.model.contract import fixedpoint as fx
    prf = float(report["prf_hz"])
    if abs(prf - farm.radar.prf_hz) > 1e-9 * prf:
        raise ValueError(f"the gates were recorded at a PRF of {prf:g} Hz but the config's is "
                         f"{farm.radar.prf_hz:g} Hz: give the config the cosimulation ran")
    if cfg.mtd.stagger_prf_hz is not None:
        raise ValueError("a cosimulation's gates have one PRF: the stagger cannot be applied to them")
    ranges = np.asarray(report["gates_km"], dtype=float)
    grid = make_grid(ranges, _spacing_km(farm, cfg), cfg.cfar.reach + 2)
    pulses = gates.shape[0]
    _check_size(grid.count, pulses)
    gated = embed(gates.T / (1 << fx.OUTPUT.frac), ranges, grid)
    level = _noise_dbfs(farm, cfg)
    gated += receiver_noise(gated.shape, level, cfg.noise_seed)
    times = np.arange(pulses) / prf
    return Scene(gated, times, grid, farm, level, "rtl", None)


# ---------------------------------------------------------------------------
# The processor

@dataclass
class Result:
    """The processor's output. Plots are arrays of one entry per plot."""
    plan: mt.CpiPlan
    prf_hz: np.ndarray             # per CPI
    plot_cpi: np.ndarray
    plot_gate: np.ndarray
    plot_doppler_hz: np.ndarray
    plot_snr_db: np.ndarray
    plot_channel: np.ndarray       # "mtd" or "zero"
    peak_db: np.ndarray            # (gates, filters) strongest filter power over the CPIs, dB FS, shifted
    filter_hz: np.ndarray          # the shifted filters' Doppler at the first CPI's PRF
    cells_tested: int              # CFAR and map cells tested over the run
    cpi_pulses: int
    moments: dict
    run_moments: dict
    alphas: dict = field(default_factory=dict)

    @property
    def plots(self) -> int:
        return int(self.plot_cpi.size)


def _map_alpha_cached(weights, counts, pfa, solved: dict) -> np.ndarray:
    """:func:`~rast.model.radar.cfar.map_alpha` per cell, each distinct history solved once."""
    key = np.ascontiguousarray(np.vstack([weights, counts]).T)
    keys = [row.tobytes() for row in key]
    todo = sorted({k: i for i, k in enumerate(keys) if k not in solved}.items(), key=lambda kv: kv[1])
    if todo:
        cols = [i for _, i in todo]
        new = cf.map_alpha(weights[:, cols], counts[:, cols], pfa)
        for (k, _), a in zip(todo, new):
            solved[k] = a
    return np.array([solved[k] for k in keys])


def _clutter_map(zero_power: np.ndarray, plan: mt.CpiPlan, cfg: cf.ClutterMapConfig):
    """Zero-velocity detections against the clutter map (docstring of
    :mod:`~rast.model.radar.cfar`).

    The map of a (azimuth cell, gate) is the first scan's mean power of the
    cell's CPIs, then after each scan ``(1 − w)·map + w·mean``. A CPI is
    compared with the map of the scans before, with ``α`` solved for the
    weights and CPI counts that map holds (:func:`~rast.model.radar.cfar.map_alpha`:
    the false-alarm probability is ``pfa`` while the map fills too); in the
    first scan, with the mean of the cell's other CPIs of that scan (none:
    no detection)."""
    w = cfg.weight
    cpis, gates = zero_power.shape
    detected = np.zeros((cpis, gates), dtype=bool)
    reference = np.full((cpis, gates), np.nan)
    clutter = np.full((plan.cells, gates), np.nan)
    weights = np.zeros((0, plan.cells))               # the map's terms: weight and CPI count per cell
    counts = np.zeros((0, plan.cells))
    solved = {}                                       # α of each map history met (they repeat)
    for s in range(plan.scans):
        sel = np.flatnonzero(plan.scan == s)
        if sel.size == 0:
            continue
        cells = plan.cell[sel]
        sums = np.zeros((plan.cells, gates))
        n = np.zeros(plan.cells)
        np.add.at(sums, cells, zero_power[sel])
        np.add.at(n, cells, 1)
        if weights.shape[0] == 0:                     # first scan: the cell's other CPIs
            others = n[cells] - 1
            with np.errstate(invalid="ignore", divide="ignore"):
                ref = (sums[cells] - zero_power[sel]) / others[:, None]
            alpha = cf.ca_alpha(others, cfg.pfa)[:, None]
        else:
            alpha = _map_alpha_cached(weights, counts, cfg.pfa, solved)[cells][:, None]
            ref = clutter[cells]
        reference[sel] = ref
        with np.errstate(invalid="ignore"):
            detected[sel] = zero_power[sel] > alpha * ref
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = sums / n[:, None]
        seen = n > 0
        first = seen & np.isnan(clutter[:, 0])
        again = seen & ~first
        clutter[first] = mean[first]
        clutter[again] = (1 - w) * clutter[again] + w * mean[again]
        weights[:, again] *= 1 - w
        new_w = np.where(first, 1.0, np.where(again, w, 0.0))
        weights = np.vstack([weights, new_w])
        counts = np.vstack([counts, np.where(seen, n, 0.0)])
        live = weights.max(axis=1) > 1e-12           # older scans no longer count: drop them
        weights, counts = weights[live], counts[live]
    return detected, reference, cf.clutter_map_alpha(w, cfg.pfa)


def _radials(samples: np.ndarray, times: np.ndarray, plan: mt.CpiPlan, cfg: AssessConfig, azimuth: bool):
    """The weather radials: (blocks, valid, prt per radial)."""
    n = cfg.mtd.cpi_pulses
    if azimuth:                       # a scanning radar: one radial per dwell (its whole CPIs)
        dwells = np.unique(plan.dwell)
        first = np.array([plan.start[plan.dwell == d].min() for d in dwells], dtype=np.int64)
        length = np.array([(plan.dwell == d).sum() * n for d in dwells], dtype=np.int64)
    elif cfg.mtd.stagger_prf_hz is not None:      # one PRF per CPI: one radial per CPI
        first, length = plan.start, np.full(plan.count, n)
    else:
        m = cfg.moments.pulses
        count = times.size // m
        first, length = np.arange(count) * m, np.full(count, m)
    if first.size == 0:
        return np.zeros((0, samples.shape[0], 2), complex), np.zeros((0, 2), bool), np.zeros(0)
    width = int(length.max())
    idx = first[:, None] + np.arange(width)[None, :]
    valid = np.arange(width)[None, :] < length[:, None]
    idx = np.where(valid, idx, first[:, None])
    blocks = np.moveaxis(samples[:, idx], 0, 1) * valid[:, None, :]
    prt = times[first + 1] - times[first]
    return blocks, valid, prt


def process(samples: np.ndarray, times_s: np.ndarray, cfg: AssessConfig, *, wavelength_m: float,
            azimuth_deg=None, noise_power: float = 0.0, ranges_km=None, progress=None) -> Result:
    """Run the processor on ``samples`` (gates, pulses) taken at ``times_s``.

    ``azimuth_deg`` (one per pulse) switches from CPIs and scans of a stare
    radar to dwells and revolutions (:func:`rast.model.radar.mtd.plan_cpis`).
    ``noise_power`` (full-scale units) is subtracted from the moments' power.
    ``progress(done, total)`` is called as CPIs are processed.
    """
    samples = np.asarray(samples, dtype=complex)
    times_s = np.asarray(times_s, dtype=float)
    if samples.ndim != 2 or samples.shape[1] != times_s.size:
        raise ValueError(f"samples must have shape (gates, pulses) with one time per pulse, not "
                         f"{samples.shape} for {times_s.size} times")
    m = cfg.mtd
    plan = mt.plan_cpis(times_s.size, m.cpi_pulses, azimuth_deg=azimuth_deg,
                        beamwidth_deg=cfg.beamwidth_deg, scan_cpis=cfg.scan_cpis)
    if plan.count == 0:
        raise ValueError(f"the run's {times_s.size} pulses hold no whole CPI of {m.cpi_pulses} pulses"
                         + (" within one dwell" if azimuth_deg is not None else ""))
    prf = 1.0 / (times_s[plan.start + 1] - times_s[plan.start])
    gates, filters = samples.shape[0], m.filters
    detected = np.zeros((plan.count, gates, filters), dtype=bool)
    snr = np.zeros((plan.count, gates, filters))
    zero_power = np.zeros((plan.count, gates))
    peak = np.full((gates, filters), -np.inf)
    # CPIs at a time: bounded memory, and about 50 steps for the progress lines
    chunk = max(16, min((1 << 22) // max(1, gates * m.cpi_pulses), -(-plan.count // 50)))
    tested = 0
    for lo in range(0, plan.count, chunk):
        sub = dataclasses.replace(plan, start=plan.start[lo:lo + chunk])
        spectrum = mt.doppler_filter_bank(samples, sub, m)
        power = np.abs(spectrum) ** 2                          # (cpis, gates, filters)
        hit, noise, alpha = cf.ca_cfar(np.moveaxis(power, 1, 2), cfg.cfar)   # CFAR along gates
        hit, noise = np.moveaxis(hit, 2, 1), np.moveaxis(noise, 2, 1)
        hit[..., 0] = False                                    # zero Doppler: the clutter map's
        detected[lo:lo + chunk] = hit
        with np.errstate(divide="ignore", invalid="ignore"):
            snr[lo:lo + chunk] = power / noise
        zero_power[lo:lo + chunk] = np.abs(mt.zero_velocity_filter(samples, sub, m)) ** 2
        peak = np.maximum(peak, power.max(axis=0))
        tested += int(np.isfinite(alpha).sum()) * (filters - 1) * sub.start.size
        if progress:
            progress(min(plan.count, lo + chunk), plan.count)
    zero_hit, zero_ref, map_alpha = _clutter_map(zero_power, plan, cfg.clutter_map)
    tested += plan.count * gates
    with np.errstate(divide="ignore", invalid="ignore"):
        zero_snr = zero_power / zero_ref
    # one plot per (CPI, gate): the strongest detection of its filters and the zero channel
    mtd_snr = np.where(detected, snr, -np.inf)
    best = np.argmax(mtd_snr, axis=-1)
    best_snr = np.take_along_axis(mtd_snr, best[..., None], axis=-1)[..., 0]
    zero_best = np.where(zero_hit, zero_snr, -np.inf)
    use_zero = zero_best > best_snr
    plot_snr = np.where(use_zero, zero_best, best_snr)
    cpi, gate = np.nonzero(np.isfinite(plot_snr) & (plot_snr > 0))
    k = best[cpi, gate]
    f = k * prf[cpi] / filters
    f = np.where(f >= prf[cpi] / 2, f - prf[cpi], f)
    zero = use_zero[cpi, gate]
    with np.errstate(divide="ignore"):
        peak_db = 10 * np.log10(np.fft.fftshift(peak, axes=-1))
    filter_hz = np.fft.fftshift(np.fft.fftfreq(filters, 1.0 / prf[0]))
    # weather moments
    blocks, valid, prt = _radials(samples, times_s, plan, cfg, azimuth_deg is not None)
    mom = mo.radial_moments(blocks, prt, wavelength_m, valid=valid, noise_power=noise_power, cfg=cfg.moments,
                            ranges_km=ranges_km)
    run = _run_moments(mom, valid, prt, wavelength_m)
    return Result(plan=plan, prf_hz=prf, plot_cpi=cpi, plot_gate=gate,
                  plot_doppler_hz=np.where(zero, 0.0, f), plot_snr_db=10 * np.log10(plot_snr[cpi, gate]),
                  plot_channel=np.where(zero, "zero", "mtd"), peak_db=peak_db, filter_hz=filter_hz,
                  cells_tested=tested, cpi_pulses=m.cpi_pulses, moments=mom, run_moments=run,
                  alphas=dict(cfar_alpha=float(cf.ca_alpha(cfg.cfar.reference_cells, cfg.cfar.pfa)),
                              clutter_map_alpha=map_alpha))


def _run_moments(mom: dict, valid: np.ndarray, prt: np.ndarray, wavelength_m: float) -> dict:
    """Pulse-pair moments of the whole run: ``R0`` and ``R1`` accumulated over
    the radials of the most common PRT (the spectrum averaged over the run)."""
    if prt.size == 0:
        return {}
    values, counts = np.unique(np.round(prt, 12), return_counts=True)
    base = values[np.argmax(counts)]
    sel = np.isclose(prt, base, rtol=1e-9, atol=0)
    n0 = valid[sel].sum(axis=-1).astype(float)
    n1 = (valid[sel][:, :-1] & valid[sel][:, 1:]).sum(axis=-1).astype(float)
    r0 = (mom["r0"][sel] * n0[:, None]).sum(axis=0) / n0.sum()
    r1 = (mom["r1"][sel] * n1[:, None]).sum(axis=0) / max(n1.sum(), 1)
    noise = float((mom["noise"][sel] * n0).sum() / n0.sum())
    power, velocity, width = mo.pulse_pair(r0, r1, base, wavelength_m, noise)
    return dict(power=power, velocity_m_s=velocity, width_m_s=width, prt_s=float(base))


# ---------------------------------------------------------------------------
# Summary and outputs

def _finite(x, digits=6):
    x = float(x)
    return round(x, digits) if math.isfinite(x) else None


def _windmill_azimuth(w):
    for key in ("azimuth_deg", "azimuth"):
        value = getattr(w, key, None)
        if value is not None:
            return float(value)
    return None


def summarize(scene: Scene, result: Result, cfg: AssessConfig) -> dict:
    """The figures a radar engineer asks for (``summary.json``)."""
    farm, grid, plan = scene.farm, scene.grid, result.plan
    lam = farm.radar.wavelength_m
    windmill_gate = grid.index([w.range_km for w in farm.windmills])
    turbine_gates = set(int(g) for g in windmill_gate) | set(int(g) + 1 for g in windmill_gate)
    at_turbine = np.isin(result.plot_gate, sorted(turbine_gates))
    scans = plan.scans
    per_scan = np.bincount(plan.scan[result.plot_cpi], minlength=scans)
    per_scan_turbine = np.bincount(plan.scan[result.plot_cpi[at_turbine]], minlength=scans)
    cells_per_scan = result.cells_tested / scans
    pfa_mix = (cfg.cfar.pfa * (result.cells_tested - plan.count * grid.count)
               + cfg.clutter_map.pfa * plan.count * grid.count) / max(result.cells_tested, 1)
    lo, hi = cf.binomial_interval(int(round(cells_per_scan)), min(max(pfa_mix, 1e-300), 0.5))
    # turbines: the looks whose CPI contains a plot at the turbine's gate or the next
    hit = np.zeros((plan.count, grid.count + 1), dtype=bool)
    hit[result.plot_cpi, result.plot_gate] = True
    turbines = []
    for w, g in zip(farm.windmills, windmill_gate):
        looks = np.ones(plan.count, dtype=bool)
        az = _windmill_azimuth(w)
        if az is not None and np.isfinite(plan.azimuth_deg).all():
            looks = np.abs((plan.azimuth_deg - az + 180) % 360 - 180) <= cfg.beamwidth_deg / 2
        seen = (hit[:, g] | hit[:, g + 1])[looks]
        turbines.append(dict(name=w.name, range_km=w.range_km, gate=int(g), looks=int(looks.sum()),
                             detection_fraction=_finite(seen.mean()) if seen.size else None,
                             plots=int(np.isin(result.plot_gate, [g, g + 1]).sum())))
    # moments per turbine gate: the run's and the radials' spread
    nearest = min(w.echo_range_km for w in farm.windmills)
    mom, run = result.moments, result.run_moments
    gate_rows = []
    centres = grid.centres_km
    for g in sorted(set(int(x) for x in windmill_gate)):
        members = [w for w, wg in zip(farm.windmills, windmill_gate) if wg == g]
        power = moment = 0.0
        for w in members:
            p, m2 = mo.blade_doppler_moments(w, lam, (nearest / w.echo_range_km) ** 2)
            if cfg.moments.clutter_filter == "mean" and w.tower is not None:
                p -= (nearest / w.echo_range_km) ** 4 * w.tower.rcs_m2   # the filter removes the tower
            power, moment = power + p, moment + m2
        expected_hz = math.sqrt(moment / power) if power > 0 else None
        v = mom["velocity_m_s"][:, g] if mom["velocity_m_s"].size else np.zeros(0)
        wd = mom["width_m_s"][:, g] if mom["width_m_s"].size else np.zeros(0)
        gate_rows.append(dict(
            gate=g, range_km=_finite(centres[g]), windmills=[w.name for w in members],
            reflectivity_db=_finite(10 * np.log10(run["power"][g]) + 20 * np.log10(centres[g]), 2)
            if run and run["power"][g] > 0 else None,
            velocity_bias_m_s=_finite(run["velocity_m_s"][g], 4) if run else None,
            width_m_s=_finite(run["width_m_s"][g], 4) if run else None,
            expected_width_m_s=_finite(expected_hz * lam / 2, 4) if expected_hz is not None else None,
            radial_velocity_rms_m_s=_finite(np.sqrt(np.nanmean(v ** 2)), 4) if np.isfinite(v).any() else None,
            radial_width_mean_m_s=_finite(np.nanmean(wd), 4) if np.isfinite(wd).any() else None))
    return dict(
        format="rast-assess/1",
        source=scene.source,
        radar=dict(frequency_mhz=farm.radar.frequency_mhz, prf_hz=farm.radar.prf_hz,
                   stagger_prf_hz=cfg.mtd.stagger_prf_hz, pulse_width_us=farm.radar.pulse_width_us,
                   wavelength_m=lam, scanning=scene.azimuth_deg is not None),
        parameters=dict(seconds=cfg.seconds, pulses=int(scene.times_s.size), noise_dbfs=scene.noise_dbfs,
                        noise_seed=cfg.noise_seed, gate_km=grid.spacing_km, gates=grid.count,
                        first_gate_km=grid.first * grid.spacing_km, scan_cpis=cfg.scan_cpis,
                        beamwidth_deg=cfg.beamwidth_deg, mtd=dataclasses.asdict(cfg.mtd),
                        cfar=dataclasses.asdict(cfg.cfar), clutter_map=dataclasses.asdict(cfg.clutter_map),
                        moments=dict(dataclasses.asdict(cfg.moments), engine_used=mom["engine"]),
                        cfar_alpha=result.alphas["cfar_alpha"],
                        clutter_map_alpha=result.alphas["clutter_map_alpha"],
                        albersheim_snr_db_pd_0_9=_finite(cf.albersheim_snr_db(0.9, cfg.cfar.pfa), 3)),
        cpis=plan.count, scans=scans, cells_tested=result.cells_tested,
        plots=result.plots,
        false_plots_per_scan=[int(x) for x in per_scan],
        false_plots_per_scan_mean=_finite(per_scan.mean(), 3),
        turbine_plots_per_scan_mean=_finite(per_scan_turbine.mean(), 3),
        other_plots_per_scan_mean=_finite((per_scan - per_scan_turbine).mean(), 3),
        noise_plots_per_scan_expected=_finite(pfa_mix * cells_per_scan, 4),
        noise_plots_per_scan_interval_99_9=[lo, hi],
        turbines=turbines,
        detection_fraction_mean=_finite(np.mean([t["detection_fraction"] or 0 for t in turbines]), 4),
        gates=gate_rows,
        velocity_bias_max_m_s=_finite(max((abs(r["velocity_bias_m_s"]) for r in gate_rows
                                            if r["velocity_bias_m_s"] is not None), default=float("nan")), 4),
        width_mean_m_s=_finite(np.mean([r["width_m_s"] for r in gate_rows if r["width_m_s"] is not None])
                               if any(r["width_m_s"] is not None for r in gate_rows) else float("nan"), 4),
    )


def assess(farm: Farm, cfg: AssessConfig, *, gates=None, report=None, azimuth_deg=None, progress=None):
    """The whole assessment: ``(scene, result, summary)``. ``gates``/``report``:
    a cosimulation's (:func:`read_gates`) instead of the model's samples;
    ``azimuth_deg``: one antenna azimuth per pulse (else the config's scan, if any)."""
    scene = scene_from_gates(farm, gates, report, cfg) if gates is not None else simulate(farm, cfg)
    if azimuth_deg is not None:
        azimuth_deg = np.asarray(azimuth_deg, dtype=float)
        if azimuth_deg.shape != scene.times_s.shape:
            raise ValueError(f"the azimuths hold {azimuth_deg.size} values but the run has "
                             f"{scene.times_s.size} pulses")
        scene.azimuth_deg = azimuth_deg
    result = process(scene.samples, scene.times_s, cfg, wavelength_m=farm.radar.wavelength_m,
                     azimuth_deg=scene.azimuth_deg, noise_power=scene.noise_power,
                     ranges_km=scene.grid.centres_km, progress=progress)
    return scene, result, summarize(scene, result, cfg)


def plots_csv(scene: Scene, result: Result) -> str:
    """``plots.csv``: one row per plot."""
    buf = io.StringIO()
    out = csv.writer(buf, lineterminator="\n")
    out.writerow(["time_s", "range_km", "azimuth_deg", "doppler_hz", "snr_db", "scan", "channel"])
    plan = result.plan
    ranges = scene.grid.centres_km
    last = np.minimum(plan.start + result.cpi_pulses - 1, scene.times_s.size - 1)
    centre = (scene.times_s[plan.start] + scene.times_s[last]) / 2       # the CPI's middle
    for c, g, f, s, ch in zip(result.plot_cpi, result.plot_gate, result.plot_doppler_hz, result.plot_snr_db,
                              result.plot_channel):
        t = centre[c]
        az = plan.azimuth_deg[c]
        out.writerow([f"{t:.6f}", f"{ranges[g]:.4f}", "" if not np.isfinite(az) else f"{az:.2f}",
                      f"{f:.2f}", f"{s:.2f}", int(plan.scan[c]), ch])
    return buf.getvalue()


def write_outputs(out, scene: Scene, result: Result, summary: dict, *, title: str = "") -> list[Path]:
    """``plots.csv``, ``summary.json`` and the picture (``range_doppler.png`` for
    a stare radar, ``ppi.png`` for a scanning one) into ``out``, each written
    whole (:mod:`rast.model.files.outputs`). Returns the files written."""
    from rast.model.files.outputs import atomic_file, write_text
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    write_text(out / "plots.csv", plots_csv(scene, result))
    written.append(out / "plots.csv")
    write_text(out / "summary.json", json.dumps(summary, indent=2) + "\n")
    written.append(out / "summary.json")
    from rast.model.radar.assess_plot import draw_ppi, draw_range_doppler
    name = "ppi.png" if scene.azimuth_deg is not None else "range_doppler.png"
    with atomic_file(out / name) as png:
        if scene.azimuth_deg is not None:
            draw_ppi(png, scene, result, summary, title=title)
        else:
            draw_range_doppler(png, scene, result, summary, title=title)
    written.append(out / name)
    return written
