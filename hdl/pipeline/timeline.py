"""The slot schedule of a pipeline, made from its stages' latencies: which
clock of a period does what for slot s (docs/tdm_engine.md's table).

``python -m rast.hdl.pipeline.timeline`` prints the table for the default
build; ``tests/test_hdl_docs.py`` checks that docs/tdm_engine.md holds it."""

import warnings

from amaranth.hdl import UnusedElaboratable

from rast.model.contract.fixedpoint import ReplayContract, ACCEPT_LAG, tree_cycles, mac_merge_cycles
from .fir_mac import FirMac
from .interpolator import LinearStep
from .product import ProductSum
from .schedule import SlotSchedule
from .slot_state import SlotState, SlotInit, MIRROR_LAG, REQUEST_CYCLES
from .window_tap import WindowTap, COMMON_OUT_CYCLES

__all__ = ["slot_schedule", "schedule_markdown", "TABLE_BEGIN", "TABLE_END"]

TABLE_BEGIN = "<!-- slot-schedule:begin (python -m rast.gateware.schedule_doc) -->"
TABLE_END = "<!-- slot-schedule:end -->"


def slot_schedule(contract: ReplayContract) -> list[tuple[str, str, int]]:
    """``[(event, clock, clock of slot 0)]``: each event of slot s's visit of a
    period, in the pipeline's clocks from the period start (its slot counter
    at 0), as the stages' latency properties give it."""
    from ..replay_top import SATURATION_CYCLES
    M, P = contract.slots, contract.pipelines
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnusedElaboratable)          # made for their properties only
        schedule = SlotSchedule(contract)
        state = SlotState(contract, [SlotInit()] * M, _rsel_layout(contract))
        step, product = LinearStep(contract.interpolation), ProductSum(contract)
    V = schedule.visit_cycles
    A = schedule.accept_clock
    rows = [
        ("the top accepts input sample n (i.ready)", f"-{ACCEPT_LAG}", -ACCEPT_LAG),
        ("the period's step reaches the pipeline (accept)", f"{A}", A),
        ("c[n] from the common line on win_data", f"{COMMON_OUT_CYCLES}", COMMON_OUT_CYCLES),
        ("slot s's registers read (RegisterSelect)", "s", 0),
        ("slot s visits: its state at the ring's head, stage A", f"s + {V}", V),
        ("its state update complete (stage B)", f"s + {V + state.update_stage}", V + state.update_stage),
        ("its pending and bank mirrors", f"s + {V + state.update_stage + MIRROR_LAG}",
         V + state.update_stage + MIRROR_LAG),
        ("its fetch request to the pool", f"s + {V + REQUEST_CYCLES}", V + REQUEST_CYCLES),
        ("the interpolator's operands (cache words or U values)", f"s + {V + step.OPERAND_CYCLES}",
         V + step.OPERAND_CYCLES),
    ]
    if contract.interpolation == "fir":
        rows += [("the FIR MAC's tap word from the cache", f"s + {V + FirMac.WORD_LATENCY}", V + FirMac.WORD_LATENCY),
                 ("a finished job's U value into the slot's state", f"s + {V + mac_merge_cycles(M)}",
                  V + mac_merge_cycles(M))]
    write = WindowTap.window_write_cycles(M)
    rows += [
        ("c[n] written into the pipeline's window", f"{write}", write),
        ("the word and the tap's sample in the multiplier's operand registers", f"s + {V + step.latency}",
         V + step.latency),
        ("the period's sum over the slots (pipeline ``sum``)", f"{M - 1 + V + product.sum_cycles}",
         M - 1 + V + product.sum_cycles),
        (f"the sum over the {P} pipeline(s) (adder tree)", f"{M - 1 + V + product.sum_cycles + tree_cycles(P)}",
         M - 1 + V + product.sum_cycles + tree_cycles(P)),
        ("output n in its register, saturated", f"{M - 1 + V + product.sum_cycles + tree_cycles(P) + SATURATION_CYCLES}",
         M - 1 + V + product.sum_cycles + tree_cycles(P) + SATURATION_CYCLES),
    ]
    return rows


def _rsel_layout(contract):
    from amaranth.lib import data
    from rast.model.contract.regmap import register_map
    from ..registers import channel_regs_layout, slot_values_layout
    rmap = register_map(contract)
    rl, vl = channel_regs_layout(rmap), slot_values_layout(rmap)
    return data.StructLayout({**dict(rl.members), **dict(vl.members)})


def schedule_markdown(contract: ReplayContract) -> str:
    """The table of :func:`slot_schedule`, in Markdown."""
    rows = slot_schedule(contract)
    head = (f"{contract.channels} channels, M = {contract.slots} slots, {contract.pipelines} pipelines, "
            f"{contract.interpolation} interpolation: clocks from a pipeline's period start\n\n"
            "| event | clock | slot 0 |\n| --- | ---: | ---: |\n")
    return head + "\n".join(f"| {what} | {formula} | {clock} |" for what, formula, clock in rows) + "\n"
