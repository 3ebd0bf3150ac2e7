"""Driving a replay block built with the antenna scan clock by clock: its
radar pulses (ACP, ARP) as pin levels, which of them the block's filter
passes and which step each one counts for, and the bit-exact model fed the
same accesses and pulses. Shared by the Amaranth-simulator tests
(``tests/hdl_harness.py``) and the cocotb testbench (``rast.sim.tb_scan``).

A pulse is ``(pin, clock, high)``: ``pin`` ("acp" or "arp") high from
``clock`` for ``high`` clocks. An access done is ``(k, "w"|"r", addr,
value)``, ``k`` the inputs accepted before it lands; a pulse the filter
passes becomes ``(k, "e", arp, acp)`` (an ARP and an ACP rising in one
clock: one event), k the inputs accepted before the clock ``acp_lead`` after
its rise.
"""

from __future__ import annotations

import numpy as np

from rast.model.contract.datapath import ReplayModel

__all__ = ["radar_pulses", "pin_levels", "pulse_events", "merge", "model_replay"]


def radar_pulses(rng, start: int, per_rev: int, revolutions: int, spacing: int, jitter: int, high: int,
                 missing=(), glitch: int | None = None) -> list:
    """A turning radar's pins from clock ``start``: an ACP every ``spacing``
    clocks (each moved by up to ``jitter``, ``high`` clocks long) for
    ``revolutions`` of ``per_rev`` and a few more, an ARP halfway between the
    last ACP of a revolution and the first of the next, except in the
    revolutions ``missing``; with ``glitch`` (clocks, shorter than the
    filter) a short ACP between two and a short ARP where none belongs."""
    pulses = [("acp", int(start + k * spacing + rng.integers(-jitter, jitter + 1)), high)
              for k in range(per_rev * revolutions + per_rev // 8)]
    rev = per_rev * spacing
    pulses += [("arp", start + r * rev - spacing // 2, high + 1) for r in range(revolutions + 1) if r not in missing]
    if glitch:
        pulses += [("acp", start + 5 * spacing + spacing // 2, glitch),
                   ("arp", start + rev + 7 * spacing + spacing // 2, glitch)]
    return pulses


def pin_levels(pulses) -> dict:
    """clock -> the pins high in it."""
    high = {}
    for pin, at, length in pulses:
        for c in range(at, at + length):
            high.setdefault(c, set()).add(pin)
    return high


def pulse_events(pulses, accepted_at, acp_lead: int, filter_clocks: int) -> list:
    """The events of the pulses the filter passes (``high`` at least
    ``filter_clocks``; a pin's pulses taken to be as far apart), given the
    clock of every input accepted (ascending)."""
    events = {}
    for pin, at, length in pulses:
        if length >= filter_clocks:
            k = int(np.searchsorted(accepted_at, at + acp_lead))
            events.setdefault((k, at), set()).add(pin)
    return [(k, "e", "arp" in pins, "acp" in pins) for (k, _), pins in sorted(events.items())]


def merge(done, events) -> list:
    """Accesses and events in step order; an event counted for step k before
    the accesses that land before it (a read samples the generator as it
    takes step k)."""
    return sorted(list(done) + list(events), key=lambda d: (d[0], d[1] != "e"))


def model_replay(contract, inits, xi, xq, done_ops, common_delay=0):
    """Inputs, the recorded accesses and the pulses' events through the model:
    ``(yi, yq, reads, model)``, reads ``(k, addr, model's value, block's value)``."""
    model = ReplayModel(contract, inits, common_delay)
    yi, yq, reads = [], [], []
    pos = 0
    for k, kind, addr, value in done_ops:
        if k > pos:
            a, b = model.run(xi[pos:k], xq[pos:k])
            yi.append(a)
            yq.append(b)
            pos = k
        if kind == "e":
            model.scan_event(addr, value)          # (k, "e", arp, acp)
        elif kind == "w":
            model.write(addr, value)
        else:
            reads.append((k, addr, model.read(addr), value))
    if pos < len(xi):
        a, b = model.run(xi[pos:], xq[pos:])
        yi.append(a)
        yq.append(b)
    empty = np.zeros(0, np.int64)
    return (np.concatenate(yi) if yi else empty), (np.concatenate(yq) if yq else empty), reads, model
