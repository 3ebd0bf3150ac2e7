"""Impact sweeps: the assessment (:mod:`rast.model.radar.assess`) of one farm
under many conditions, every case a task on Dask (``rast assess --sweep``).

Axes:

* ``wind_from`` (degrees): the farm is made again from its turbine layout for
  each wind direction (:func:`rast.model.physics.layout.make_farm`): rotor
  angles, and so the Doppler spread, follow the wind. The layout and the
  ``rast farm`` options are read from the config's header comments (a config
  ``rast farm`` wrote) or given (``--layout``, ``--radar``);
* ``rpm``: every windmill's rotor speed, a value in rpm, or a factor on each
  windmill's own with a trailing ``x`` (``rpm=0.8x,1x,1.2x``);
* ``scan_start_deg``: the antenna's azimuth at t = 0 (docs/antenna_scan.md);
  without effect, and noted so, on a config whose antenna stares.

Values: ``start:stop:step`` (stop excluded, as Python's ``range``:
``0:360:15`` is 24 directions) or a comma-separated list. Several axes make a
grid. Every case uses the same noise seed, so that the differences between
cases are the turbines', not the noise's.
"""

from __future__ import annotations

import itertools
import math
import re
import tomllib
import uuid
from dataclasses import dataclass
from pathlib import Path

__all__ = ["AXES", "Axis", "parse_axis", "grid", "LayoutRecipe", "recipe_from_header", "case_data",
           "run_case", "run_sweep", "SweepError", "MAX_CASES", "ROW_FIGURES"]

AXES = ("wind_from", "rpm", "scan_start_deg")
#: Most cases one sweep runs.
MAX_CASES = 10_000
#: The summary figures of each case in ``sweep.csv``.
ROW_FIGURES = ("false_plots_per_scan_mean", "turbine_plots_per_scan_mean", "other_plots_per_scan_mean",
               "noise_plots_per_scan_expected", "detection_fraction_mean", "velocity_bias_max_m_s",
               "width_mean_m_s", "plots", "scans", "cpis")


class SweepError(ValueError):
    """A sweep that cannot be run as asked (the message names the option)."""


@dataclass(frozen=True)
class Axis:
    name: str
    values: tuple[float, ...]
    factor: bool = False            # rpm only: values multiply each windmill's rpm

    def label(self, value: float) -> str:
        return f"{value:g}x" if self.factor else f"{value:g}"


_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"


def parse_axis(text: str) -> Axis:
    """``NAME=START:STOP:STEP`` or ``NAME=V1,V2,...`` (:data:`AXES`)."""
    name, sep, spec = text.partition("=")
    name, spec = name.strip(), spec.strip().replace(" ", "")
    if not sep or name not in AXES:
        raise SweepError(f"--sweep {text!r}: give NAME=START:STOP:STEP or NAME=V1,V2,... with NAME one of "
                         f"{', '.join(AXES)}")
    factor = name == "rpm" and spec.endswith("x")
    if factor:
        spec = spec.replace("x", "")
    elif "x" in spec:
        raise SweepError(f"--sweep {text!r}: only rpm takes factors (a trailing x)")
    if re.fullmatch(rf"{_NUMBER}:{_NUMBER}:{_NUMBER}", spec):
        start, stop, step = (float(v) for v in spec.split(":"))
        if not step > 0 or not stop > start:
            raise SweepError(f"--sweep {text!r}: START:STOP:STEP needs STOP > START and STEP > 0")
        count = math.ceil((stop - start) / step - 1e-9)
        if count > MAX_CASES:
            raise SweepError(f"--sweep {text!r} has {count:,} values, more than {MAX_CASES:,}")
        values = tuple(start + k * step for k in range(count))
    elif re.fullmatch(rf"{_NUMBER}(,{_NUMBER})*", spec):
        values = tuple(float(v) for v in spec.split(","))
    else:
        raise SweepError(f"--sweep {text!r}: the values must be START:STOP:STEP or a comma-separated list of "
                         f"numbers{' (each with a trailing x for factors)' if name == 'rpm' else ''}")
    values = tuple(round(v, 9) + 0.0 for v in values)
    if name == "rpm" and any(v <= 0 for v in values):
        raise SweepError(f"--sweep {text!r}: rotor speeds and factors must be positive")
    if name == "wind_from" and any(not 0 <= v < 360 for v in values):
        raise SweepError(f"--sweep {text!r}: wind directions must be bearings in [0, 360) degrees")
    return Axis(name, values, factor)


def grid(axes: list[Axis]) -> list[dict[str, float]]:
    """Every combination of the axes' values (the first axis varies slowest)."""
    names = [a.name for a in axes]
    if len(set(names)) != len(names):
        raise SweepError(f"--sweep names an axis twice: {', '.join(names)}")
    count = math.prod(len(a.values) for a in axes)
    if count > MAX_CASES:
        raise SweepError(f"the sweep has {count:,} cases, more than {MAX_CASES:,}")
    return [dict(zip(names, combo)) for combo in itertools.product(*(a.values for a in axes))]


# ---------------------------------------------------------------------------
# Farms for each wind direction

@dataclass(frozen=True)
class LayoutRecipe:
    """What ``rast farm`` was given: enough to make the farm again for another wind."""
    layout_path: Path
    radar: tuple[float, float, float]      # --radar: LAT,LON,HEIGHT_M (X,Y,HEIGHT_M for x/y layouts)
    wind_from_deg: float
    wind_speed_m_s: float | None = None
    turbine_model: str = "nrel-5mw"
    tower_rcs_m2: float | None = None
    max_range_km: float | None = None


def recipe_from_header(text: str, config_path, *, layout=None, radar=None) -> LayoutRecipe | None:
    """The ``rast farm`` options from a config's header comments; ``layout``
    and ``radar`` (the command's ``--layout``, ``--radar``) replace or supply
    them. None when neither the header nor the options name a layout."""
    from rast.model.physics.layout import unambiguous_range_km
    head = "\n".join(line for line in text.splitlines() if line.startswith("#"))
    f = _NUMBER
    m_layout = re.search(rf"^# \d+ turbines from (.+?) \(([^)]*)\), radar at "
                         rf"(?:lat, lon = ({f}), ({f})|x, y = ({f}), ({f}) m), antenna ({f}) m", head, re.M)
    m_wind = re.search(rf"^# wind from ({f}) deg(?: at ({f}) m/s)?", head, re.M)
    m_class = re.search(r"^# turbine class ([\w.-]+):", head, re.M)
    m_max = re.search(rf"\(maximum ({f}) km\)", head)
    m_tower = re.search(rf"a static return of ({f}) m2 per turbine", head)
    if layout is None and m_layout is None:
        return None
    if layout is None:
        layout = Path(config_path).parent / m_layout.group(1)
    if radar is None:
        if m_layout is None:
            raise SweepError("--layout needs --radar LAT,LON,HEIGHT_M: the config's header does not say "
                             "where the radar is")
        g = m_layout.groups()
        radar = ((float(g[2]), float(g[3])) if g[2] is not None else (float(g[4]), float(g[5]))) + (float(g[6]),)
    data = tomllib.loads(text)
    prf = float(data.get("prf", 20_000.0))
    max_range = float(m_max.group(1)) if m_max else None
    if max_range is not None and abs(max_range - unambiguous_range_km(prf)) < 1e-3:
        max_range = None
    return LayoutRecipe(Path(layout), tuple(radar), float(m_wind.group(1)) if m_wind else 0.0,
                        float(m_wind.group(2)) if m_wind and m_wind.group(2) else None,
                        m_class.group(1) if m_class else "nrel-5mw",
                        float(m_tower.group(1)) if m_tower else None, max_range)


def _farm_text(recipe: LayoutRecipe, base: dict, wind_from_deg: float) -> str:
    from rast.model.physics.layout import (FarmSettings, RadarSite, TURBINE_CLASSES, make_farm,
                                           read_layout)
    layout = read_layout(recipe.layout_path)
    settings = FarmSettings(float(base.get("sample_rate", 20.0)), float(base.get("radar_frequency", 5350.0)),
                            float(base.get("prf", 20_000.0)), float(base.get("pulse_width", 2.0)),
                            float(base.get("cpi", 100.0)), base.get("ram_depth"))
    text, _ = make_farm(layout, RadarSite.from_option(recipe.radar, layout.geodetic), wind_from_deg,
                        turbine_class=TURBINE_CLASSES[recipe.turbine_model], settings=settings,
                        wind_speed_m_s=recipe.wind_speed_m_s, max_range_km=recipe.max_range_km,
                        layout_name=recipe.layout_path.name, tower_rcs_m2=recipe.tower_rcs_m2)
    return text


def case_data(base: dict, values: dict, axes: dict[str, Axis], recipe: LayoutRecipe | None) -> tuple[dict, list[str]]:
    """The config document of one case, and notes on what it could not set."""
    notes = []
    data = dict(base)
    if "wind_from" in values:
        if recipe is None:
            raise SweepError("--sweep wind_from needs the farm's turbine layout: a config written by `rast farm` "
                             "(its header names the layout), or --layout LAYOUT.csv --radar LAT,LON,HEIGHT_M")
        data = tomllib.loads(_farm_text(recipe, base, values["wind_from"]))
        for key in ("noise_dbfs", "interpolation", "stream_oversampling", "adc_latency", "dac_latency",
                    "range_extend_above", "stream_rate"):
            if key in base:          # farm-level keys rast farm does not write
                data[key] = base[key]
    if "rpm" in values:
        axis = axes["rpm"]
        tables = data.get("windmill")
        if isinstance(tables, list):
            data["windmill"] = [dict(t, rpm=(t.get("rpm", 0) * values["rpm"] if axis.factor else values["rpm"]))
                                for t in tables]
        else:
            data["rpm"] = data.get("rpm", 0) * values["rpm"] if axis.factor else values["rpm"]
    if "scan_start_deg" in values:
        data["scan_start_deg"] = values["scan_start_deg"]
        if data.get("scan_mode", "stare") == "stare":
            notes.append("scan_start_deg has no effect: the config's antenna stares (scan_mode)")
    return data, notes


def run_case(data: dict, cfg, values: dict, notes: list[str]) -> dict:
    """One case (a Dask task): the config document ``data`` assessed with
    ``cfg``. Returns the summary with the case's ``values`` and ``notes``, or
    ``error`` when the case's config is refused."""
    from rast.model.physics.config import ConfigError
    from rast.model.physics.farm import parse_config
    from rast.model.radar.assess import assess
    try:
        farm = parse_config(data, "the case's config")
        _, _, summary = assess(farm, cfg)
    except (ConfigError, ValueError) as error:
        return dict(values=values, notes=notes, error=str(error))
    return dict(summary, values=values, notes=notes)


def run_sweep(tasks: list[tuple], *, scheduler: str | None = None, workers: int = 2, processes: bool = True,
              progress=None) -> list[dict]:
    """Run ``run_case(*task)`` for every task on Dask and return the results
    in the tasks' order. ``scheduler``: the address of a running Dask
    scheduler; else a ``distributed.LocalCluster`` of ``workers`` worker
    processes (or threads with ``processes=False``), one thread each, shut
    down at the end. ``progress(done, total)`` as cases finish."""
    from distributed import Client, LocalCluster, as_completed
    cluster = None
    if scheduler is None:
        # no dashboard; the scheduler's own HTTP endpoints on a free port, not 8787
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=processes,
                               dashboard_address=":0", scheduler_kwargs={"dashboard": False},
                               silence_logs=40)
        client = Client(cluster)
    else:
        try:
            client = Client(scheduler, timeout=10)
        except (OSError, TimeoutError) as error:
            raise SweepError(f"--scheduler {scheduler}: cannot reach the Dask scheduler: {error}") from None
    run = uuid.uuid4().hex[:12]           # keys unique on a shared scheduler
    try:
        futures = [client.submit(run_case, *task, pure=False, key=f"rast-assess-{run}-case-{k}")
                   for k, task in enumerate(tasks)]
        order = {f.key: k for k, f in enumerate(futures)}
        results = [None] * len(futures)
        for done, future in enumerate(as_completed(futures), 1):
            results[order[future.key]] = future.result()
            if progress:
                progress(done, len(futures))
        return results
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
