"""Streams shared between alike turbines.

A turbine's modulation depends on its blades' start angle only through time:
the blades turn at ω = 2π·rpm/60 and β_b(t) = ω·t + start_angle + b·2π/B
(eq. 2.13 and ``rast.model.physics.turbine``), so two turbines equal in
everything but the start angle have the same period, shifted by
Δt = Δstart / ω. One stream of N words holds that period over 360°/B of
rotation, so turbine k plays the stream from word

    o_k = round(((start_k − start_0) mod 360°/B) / (360°/B) · N)  (mod N),

its start angle rounded to the stream's word grid, (360°/B)/N apart (a few
thousandths of a degree for a stream of thousands of words).

The engine plays a channel's LENGTH words from its BASE and wraps back to
BASE, so a channel cannot start inside a stream. The group's stream is
therefore held as a *region*: the period from an origin word for N + span
words (span: the largest offset from the origin, the origin chosen after the
largest gap between the offsets on the circle), and channel k plays the N
words from ``region base + (o_k − origin) mod N``, which are the period
rolled by o_k. A group of k turbines needs N + span ≤ 2N − 1 words instead of
k·N; the engine is unchanged (the load writes each channel's N words, equal
where the windows overlap, and checks their CRC as for any stream).

With ``share_aspect_deg`` > 0 a turbine whose rotor angle lies that close to
a group's stream may play it as well; its echo then differs from its own
(the Doppler extent scales with cos(rotor_angle)), so it joins only if the
spur-free dynamic range of what it plays, measured on the shared stream's
words outside its own Doppler band ±(max Doppler + 6 Doppler bins) as
``rast.model.radar.sfdr`` measures a radar's pulses, is at least
``share_min_sfdr_db``. Within the band the echo still differs (its lines'
strengths follow the stream's aspect): the SFDR says only that nothing
appears where the turbine itself puts nothing. A stream whose maximum Doppler
falls short of the turbine's would pass that measure while missing the
turbine's outer lines, so its maximum Doppler must also lie within
``GUARD_BINS`` Doppler bins of the turbine's own.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from rast.model.physics.config import Farm, Windmill

__all__ = ["GUARD_BINS", "Share", "sharing_key", "word_offset", "region_layout", "candidate_groups", "pool_words_shared",
           "words_if_shared", "shared_replay_sfdr"]

#: Doppler bins (of the radar's CPI) beside a turbine's band that its SFDR
#: leaves out (as ``rast.model.radar.sfdr``), and that an aspect-shared
#: stream's maximum Doppler may lie from the turbine's own.
GUARD_BINS = 6

#: Windmill fields that do not change the stream (they set the channel's
#: gain, delay or azimuth, or name it) and the two sharing compares.
_NOT_IN_STREAM = {"name", "range_km", "output_file", "range_extended", "azimuth_deg",
                  "start_angle_deg", "rotor_angle_deg"}


@dataclass(frozen=True)
class Share:
    """Where a windmill's words lie in its group's pool region."""
    stream: str              # the windmill whose period the region holds
    offset_words: int        # the windmill's word 0 is the stream's word offset_words
    region_offset: int       # its N words start this many words into the region
    region_words: int        # the region: the stream from its origin, N + span words
    start_error_deg: float   # start angle played minus its own (the word grid's rounding)
    aspect_error_deg: float  # rotor angle played minus its own
    doppler_error_hz: float = 0.0  # maximum Doppler played minus its own
    sfdr_db: float | None = None   # measured replay SFDR (aspect-shared windmills only)


def _frozen(value):
    """A hashable, exact image of a windmill field's value."""
    if isinstance(value, np.ndarray):
        return ("array", value.dtype.str, value.shape, value.tobytes())
    if dataclasses.is_dataclass(value):
        return (type(value).__name__,) + tuple(_frozen(getattr(value, f.name)) for f in dataclasses.fields(value))
    if isinstance(value, (list, tuple)):
        return tuple(_frozen(v) for v in value)
    return value


def sharing_key(windmill: Windmill):
    """What must be equal for two windmills to share a stream (all that
    shapes the stream but the start and rotor angles); None for a delay tap
    of a range-extended turbine (its weights depend on where its hub lies)."""
    if windmill.range_cell is not None:
        return None
    return tuple(_frozen(getattr(windmill, f.name)) for f in dataclasses.fields(windmill)
                 if f.name not in _NOT_IN_STREAM)


def word_offset(windmill: Windmill, stream: Windmill, length: int) -> tuple[int, float]:
    """``(o, error_deg)``: the word of ``stream``'s N-word period where
    ``windmill``'s starts, and the start angle that plays minus its own."""
    sector = 360.0 / windmill.num_blades
    exact = ((windmill.start_angle_deg - stream.start_angle_deg) % sector) / sector * length
    o = round(exact)
    return o % length, (o - exact) * sector / length


def region_layout(offsets, length: int) -> tuple[int, list[int], int]:
    """``(origin, region_offsets, region_words)`` for members starting at
    ``offsets`` of an N-word period: the origin after the largest gap between
    the offsets round the circle, each member's window ``(o − origin) mod N``
    into the region, the region N + the largest of those."""
    points = sorted(set(int(o) % length for o in offsets))
    gaps = [(points[(k + 1) % len(points)] - points[k]) % length or length for k in range(len(points))]
    origin = points[(int(np.argmax(gaps)) + 1) % len(points)]
    rel = [(int(o) - origin) % length for o in offsets]
    return origin, rel, length + max(rel)


def candidate_groups(farm: Farm) -> list[list[int]]:
    """Windmill indices that may share a stream, the stream's windmill first.
    Among windmills equal but for their angles (:func:`sharing_key`), in
    order of rotor angle: the stream is the last within ``share_aspect_deg``
    of the first not yet grouped, its members all within that of it (0:
    equal rotor angles only); windmills that share with none are left out."""
    tolerance = farm.sharing.aspect_tolerance_deg
    by_key: dict = {}
    for k, w in enumerate(farm.windmills):
        key = sharing_key(w)
        if key is not None:
            by_key.setdefault(key, []).append(k)
    groups = []
    for members in by_key.values():
        members = sorted(members, key=lambda k: (farm.windmills[k].rotor_angle_deg, k))
        angle = [farm.windmills[k].rotor_angle_deg for k in members]
        while members:
            top = max(a for a in angle if a - angle[0] <= tolerance)
            stream = angle.index(top)           # (the first of equal angles)
            take = [j for j in range(len(members)) if angle[j] - angle[stream] <= tolerance]
            if len(take) > 1:
                groups.append([members[stream]] + [members[j] for j in take if j != stream])
            members, angle = members[len(take):], angle[len(take):]
    return sorted(groups)


def pool_words_shared(lengths, groups, offsets) -> int:
    """Pool words of streams of ``lengths`` (per windmill) when each group of
    ``groups`` is one region holding its members' ``offsets``."""
    shared = {k for g in groups for k in g}
    total = sum(int(n) for k, n in enumerate(lengths) if k not in shared)
    for g in groups:
        total += region_layout([offsets[k] for k in g], int(lengths[g[0]]))[2]
    return total


def words_if_shared(farm: Farm, lengths) -> int:
    """Pool words of streams of ``lengths`` (per windmill) had the farm shared
    the streams of windmills that differ only by their start angle (what
    ``share_streams = true`` saves without touching an echo)."""
    exact = dataclasses.replace(farm, sharing=dataclasses.replace(farm.sharing, aspect_tolerance_deg=0.0))
    groups = candidate_groups(exact)
    offsets = {k: word_offset(farm.windmills[k], farm.windmills[g[0]], int(lengths[g[0]]))[0]
               for g in groups for k in g}
    return pool_words_shared(lengths, groups, offsets)


def shared_replay_sfdr(windmill_max_doppler_hz: float, words, stream_rate_hz: float, cpi_s: float, *,
                       guard_bins: int = GUARD_BINS) -> float:
    """The SFDR (dB) of ``words`` (one period of N packed stream words,
    played at ``stream_rate_hz``) for a windmill of ``windmill_max_doppler_hz``,
    as the radar's SFDR is taken (``rast.model.radar.sfdr``): the strongest
    line of the period's spectrum over the strongest outside ±(max Doppler +
    ``guard_bins`` Doppler bins of a ``cpi_s`` CPI). The period repeats
    exactly, so its DFT needs no window. Measured on the stream, not on the
    radar's pulses: an air-traffic radar's PRF aliases a turbine's Doppler
    over its whole band, which would leave no line outside it to measure;
    the stream's rate holds the whole band. NaN when the stream's band holds
    nothing outside the windmill's (a stream at about twice its maximum
    Doppler): nothing measured, and the share is refused."""
    from rast.model.contract import fixedpoint as fx

    i, q = fx.unpack_iq(np.asarray(words, dtype=np.int64))
    power = np.abs(np.fft.fft(i + 1j * q)) ** 2
    freqs = np.fft.fftfreq(power.size, 1.0 / stream_rate_hz)
    outside = np.abs(freqs) > windmill_max_doppler_hz + guard_bins / cpi_s
    if not outside.any():
        return math.nan
    spur = power[outside].max()
    return math.inf if spur == 0 else float(10 * np.log10(power.max() / spur))
