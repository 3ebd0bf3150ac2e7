"""Weather moments per range gate from the I/Q: reflectivity (relative dB),
radial velocity and spectrum width, by the pulse-pair estimators.

For each radial (a block of consecutive pulses at one PRT ``T``) and gate,
``R0 = ⟨|x|²⟩`` and ``R1 = ⟨x*[k]·x[k+1]⟩``; with the noise power ``N`` known,
``S = R0 − N`` and

* velocity ``v = −λ/(4πT)·arg R1`` (positive away from the radar: a blade
  moving towards it has positive Doppler and negative velocity),
* width ``σ_v = λ/(2√2·πT)·√ln(S/|R1|)`` (a Gaussian spectrum),
* reflectivity ``10·log10 S + 20·log10(R / 1 km)`` dB: relative, no radar
  constant (dB above the power of a full-scale sample at 1 km).

These are the formulas of MeteoSwiss' Py-ART (``pyart_mch``,
``pyart.retrieve.iq.compute_Doppler_velocity_iq`` with
``direction="negative_away"`` and ``compute_Doppler_width_iq`` with ``lag=0``).
With ``engine="pyart"`` (or ``"auto"`` when it is installed: ``pip install
'rast[weather]'``) the radials' moments come from that library; the numpy
estimators here are the same equations and are always used for the run's
accumulated moments (``R0``, ``R1`` summed over all radials). docs/assess.md
says why the library is optional.

The clutter filter ``"mean"`` subtracts each radial's mean before the
estimators: a notch at zero Doppler that removes a steady return (a tower)
entirely, as a ground-clutter filter would; ``"none"`` keeps it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["MomentsConfig", "ENGINES", "CLUTTER_FILTERS", "autocorrelations", "pulse_pair", "radial_moments",
           "pyart_available", "blade_doppler_moments"]

ENGINES = ("auto", "numpy", "pyart")
CLUTTER_FILTERS = ("none", "mean")


@dataclass(frozen=True)
class MomentsConfig:
    """``pulses``: pulses per radial of a stare radar (a scanning one's radial
    is its dwell); ``clutter_filter``: one of :data:`CLUTTER_FILTERS`;
    ``engine``: one of :data:`ENGINES`; ``snr_threshold_db``: radials whose
    signal is below this over the noise report no velocity and width (as a
    weather radar censors them), None for none."""
    pulses: int = 64
    clutter_filter: str = "mean"
    engine: str = "auto"
    snr_threshold_db: float | None = 3.0

    def __post_init__(self):
        if not (isinstance(self.pulses, (int, np.integer)) and self.pulses >= 2):
            raise ValueError(f"pulses must be a whole number of at least 2, not {self.pulses!r}")
        if self.clutter_filter not in CLUTTER_FILTERS:
            raise ValueError(f"clutter_filter must be one of {', '.join(CLUTTER_FILTERS)}, not "
                             f"{self.clutter_filter!r}")
        if self.engine not in ENGINES:
            raise ValueError(f"engine must be one of {', '.join(ENGINES)}, not {self.engine!r}")
        if self.snr_threshold_db is not None and not math.isfinite(self.snr_threshold_db):
            raise ValueError(f"snr_threshold_db must be a number of dB, not {self.snr_threshold_db!r}")


def pyart_available() -> bool:
    """Whether MeteoSwiss' Py-ART (``pyart_mch``) imports (quietly: without
    ``PYART_QUIET`` its import prints a banner on stdout)."""
    import os
    os.environ.setdefault("PYART_QUIET", "1")
    try:
        import pyart.retrieve.iq  # noqa: F401
    except Exception:              # not installed, or a broken install: use numpy
        return False
    return True


def _filtered(blocks: np.ndarray, valid: np.ndarray, kind: str) -> np.ndarray:
    if kind == "none":
        return blocks
    count = valid.sum(axis=-1)
    mean = (blocks * valid[:, None, :]).sum(axis=-1) / np.maximum(count, 1)[:, None]
    return (blocks - mean[..., None]) * valid[:, None, :]


def autocorrelations(blocks: np.ndarray, valid: np.ndarray | None = None):
    """``R0`` and ``R1`` of every radial and gate: ``blocks`` of shape (radials,
    gates, pulses), ``valid`` (radials, pulses) marks the pulses a shorter
    radial has. Returns ``(r0, r1, n0, n1)``: the means and how many products
    each averages."""
    if valid is None:
        valid = np.ones((blocks.shape[0], blocks.shape[2]), dtype=bool)
    v = valid[:, None, :]
    pair = (valid[:, :-1] & valid[:, 1:])[:, None, :]
    n0 = valid.sum(axis=-1)
    n1 = pair[:, 0, :].sum(axis=-1)
    r0 = (np.abs(blocks) ** 2 * v).sum(axis=-1) / np.maximum(n0, 1)[:, None]
    r1 = (np.conj(blocks[..., :-1]) * blocks[..., 1:] * pair).sum(axis=-1) / np.maximum(n1, 1)[:, None]
    return r0, r1, n0, n1


def pulse_pair(r0, r1, prt_s, wavelength_m: float, noise_power=0.0):
    """``(power, velocity_m_s, width_m_s)`` from ``R0``, ``R1`` and the PRT
    (scalar or per radial, broadcast against the gates). Power is ``R0 − N``;
    where it is not positive it, the velocity and the width are NaN; where ``|R1|``
    exceeds it the width is 0."""
    r0, r1 = np.asarray(r0, dtype=float), np.asarray(r1, dtype=complex)
    prt = np.asarray(prt_s, dtype=float)
    if prt.ndim == 1 and r0.ndim == 2:
        prt = prt[:, None]
    power = r0 - noise_power
    velocity = -wavelength_m / (4 * np.pi * prt) * np.angle(r1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.log(power / np.abs(r1))
    width = wavelength_m / (2 * math.sqrt(2) * np.pi * prt) * np.sqrt(np.maximum(ratio, 0.0))
    bad = ~(power > 0) | ~(np.abs(r1) > 0)
    velocity = np.where(bad, np.nan, velocity)
    width = np.where(bad, np.nan, width)
    power = np.where(power > 0, power, np.nan)           # as Py-ART masks it
    return power, velocity, width


def _pyart_moments(blocks, valid, prt_s, wavelength_m, noise_power, ranges_km):
    """The same moments from Py-ART's I/Q retrievals (``pyart.retrieve.iq``),
    the radials as rays of an I/Q radar object (``RadarSpectra``)."""
    import warnings
    from pyart.retrieve import iq
    from pyart.testing import make_empty_spectra_radar
    rays, gates, pulses = blocks.shape
    radar = make_empty_spectra_radar(rays, gates, pulses)
    radar.range["data"] = np.asarray(ranges_km, dtype=float) * 1e3
    radar.npulses["data"] = valid.sum(axis=-1)
    # A radial's pulses first: Py-ART reads pulses [0, npulses) of each ray.
    order = np.argsort(~valid, axis=-1, kind="stable")
    packed = np.take_along_axis(blocks, order[:, None, :], axis=-1)
    mask = np.broadcast_to(~np.take_along_axis(valid, order, axis=-1)[:, None, :], packed.shape)
    radar.fields = {
        "IQ_hh_ADU": {"data": np.ma.array(packed, mask=mask)},
        "IQ_noiseADU_hh": {"data": np.ma.array(np.full((rays, gates, 1), float(noise_power)))},
    }
    radar.instrument_parameters = {
        "prt": {"data": np.broadcast_to(np.asarray(prt_s, dtype=float), (rays,)).copy()},
        "frequency": {"data": np.array([299_792_458.0 / wavelength_m])},
    }
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        velocity = iq.compute_Doppler_velocity_iq(radar, signal_field="IQ_hh_ADU",
                                                  direction="negative_away")["data"]
        width = iq.compute_Doppler_width_iq(radar, subtract_noise=True, signal_field="IQ_hh_ADU",
                                            noise_field="IQ_noiseADU_hh", lag=0)["data"]
        power = iq._compute_power(radar.fields["IQ_hh_ADU"]["data"],
                                  noise=radar.fields["IQ_noiseADU_hh"]["data"], subtract_noise=True)
    fill = lambda a: np.ma.filled(np.ma.asarray(a, dtype=float), np.nan)  # noqa: E731
    return fill(power), fill(velocity), fill(width)


def radial_moments(blocks: np.ndarray, prt_s, wavelength_m: float, *, valid=None, noise_power: float = 0.0,
                   cfg: MomentsConfig = MomentsConfig(), ranges_km=None):
    """Moments of every radial: ``blocks`` (radials, gates, pulses), after the
    clutter filter. Returns a dict of ``power``, ``velocity_m_s``,
    ``width_m_s`` (radials, gates), ``r0`` and ``r1`` (numpy's, for
    accumulating over radials) and ``engine`` (the one used)."""
    blocks = np.asarray(blocks, dtype=complex)
    if valid is None:
        valid = np.ones((blocks.shape[0], blocks.shape[2]), dtype=bool)
    x = _filtered(blocks, valid, cfg.clutter_filter)
    count = np.maximum(valid.sum(axis=-1), 1)
    # the mean's removal takes 1/M of the noise with it
    noise = noise_power * ((count - 1) / count if cfg.clutter_filter == "mean" else np.ones_like(count, float))
    r0, r1, _, _ = autocorrelations(x, valid)
    engine = cfg.engine
    if engine == "auto":
        engine = "pyart" if pyart_available() else "numpy"
    if engine == "pyart":
        if not pyart_available():
            raise ValueError("the moments engine 'pyart' needs MeteoSwiss' Py-ART: pip install 'rast[weather]'")
        if ranges_km is None:
            ranges_km = np.arange(blocks.shape[1], dtype=float)
        # Py-ART subtracts one noise power per radial; it is the same for all here but the mean's share
        power, velocity, width = _pyart_moments(x, valid, prt_s, wavelength_m, float(np.mean(noise)), ranges_km)
    else:
        power, velocity, width = pulse_pair(r0, r1, prt_s, wavelength_m, noise[:, None])
    if cfg.snr_threshold_db is not None and noise_power > 0:
        weak = ~(power >= 10 ** (cfg.snr_threshold_db / 10) * noise[:, None])
        velocity, width = np.where(weak, np.nan, velocity), np.where(weak, np.nan, width)
    return dict(power=power, velocity_m_s=velocity, width_m_s=width, r0=r0, r1=r1, engine=engine,
                noise=noise)


def blade_doppler_moments(windmill, wavelength_m: float, amplitude: float = 1.0) -> tuple[float, float]:
    """A windmill's echo power and its power-weighted mean square Doppler (Hz²),
    from its blades' velocity distribution.

    Scatterer k at radius r_k has the Doppler ``f_k·cos β`` (``f_k = 2ω·r_k·
    cos(rotor_angle)/λ``, its maximum, :func:`~rast.model.physics.turbine.max_doppler_hz`
    at r_k); over a revolution β is uniform and the mean of cos² β is ½, so the
    scatterer's spectrum has mean 0 and mean square ``f_k²/2``. The spectrum of
    the turbine, averaged over a revolution, weights each by its RCS (the
    cross terms between scatterers average out over the revolution); the tower
    adds its RCS at 0 Hz. Blade-flash weights and the wire are left out.
    Returns ``(power, power·mean square)`` scaled by ``amplitude²`` so that
    turbines sharing a gate add up.
    """
    from rast.model.physics.turbine import max_doppler_hz
    import dataclasses
    power = 0.0
    moment = 0.0
    if windmill.num_rcs:
        lone = dataclasses.replace(windmill, wire=None)
        f_tip = max_doppler_hz(lone, wavelength_m)
        r = np.asarray(windmill.radius_m, dtype=float)
        f = f_tip * r / r.max() if r.max() > 0 else np.zeros_like(r)
        rcs = np.asarray(windmill.rcs_m2, dtype=float) * windmill.num_blades
        power += float(rcs.sum())
        moment += float((rcs * f ** 2 / 2).sum())
    if windmill.tower is not None:
        power += windmill.tower.rcs_m2
    return amplitude ** 2 * power, amplitude ** 2 * moment
