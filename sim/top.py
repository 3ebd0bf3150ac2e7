"""The wind-farm top wrapped for bulk cosimulation: Verilog sources and port map."""

from __future__ import annotations

from functools import lru_cache

from rast.sim.bulk import PortMap, bulk_verilog

__all__ = ["TOP_MODULE", "port_map", "top_sources"]

TOP_MODULE = "wind_farm_replay"


def port_map(addr_width: int) -> PortMap:
    return PortMap(module=TOP_MODULE, in_payload="i__payload", in_valid="i__valid",
                   in_ready="i__ready", in_width=32, out_payload="o__payload",
                   out_valid="o__valid", out_ready="o__ready", out_width=32,
                   bus_addr="bus__addr", bus_addr_width=addr_width, bus_w_data="bus__w_data",
                   bus_w_stb="bus__w_stb", tie={"bus__r_stb": (1, 0)},
                   observe={"overflow": 1}, open_outputs=("bus__r_data",))


@lru_cache(maxsize=None)
def top_sources(channels: int, *, pool_words: int, max_delay: int, max_increment: int,
                interpolation: str = "fir", cmult_form: str = "4mult", src_aw: int = 22):
    """``({file: text}, toplevel)`` of the replay top inside ``rast_bulk``."""
    from rast.gateware.verilog import verilog_text
    from rast.model.fixedpoint import ReplayContract
    from rast.model.regmap import register_map
    kwargs = dict(pool_words=pool_words, max_delay=max_delay, max_increment=max_increment,
                  interpolation=interpolation, cmult_form=cmult_form)
    text = verilog_text(channels, name=TOP_MODULE, **kwargs)
    aw = register_map(ReplayContract(channels=channels, **kwargs)).addr_width
    return {f"{TOP_MODULE}.v": text, "rast_bulk.v": bulk_verilog(port_map(aw), src_aw=src_aw)}, "rast_bulk"
