"""The documents match what they describe."""

from pathlib import Path

import numpy as np

from rast.model.contract.datapath import cmult, gain_scale
from rast.model.contract.fixedpoint import ReplayContract, saturate
from rast.model.contract.regdoc import registers_doc

DOCS = Path(__file__).resolve().parents[1] / "docs"


def test_registers_md_is_generated_from_the_map():
    assert (DOCS / "registers.md").read_text() == registers_doc(), \
        "docs/registers.md is stale: python -m rast.model.contract.regdoc > docs/registers.md"


def test_fixed_point_worked_example():
    p = cmult(12000, -5000, 20000, 10000)
    assert (int(p[0]), int(p[1])) == (8850, 610)
    q = gain_scale(np.array(p), 49152)
    assert q.tolist() == [6638, 458]
    y, over = saturate(5 * q)
    assert y.tolist() == [32767, 2290] and over.tolist() == [True, False]
    # in samples the two delay lines' lags, whatever N and M
    assert {ReplayContract(channels=n, slots=m).latency for n in (1, 8, 64) for m in (1, 2, 10)} == {2}
    # in clocks: the accept's two registers 2, the last slot 9, visit 2, word 7, cmult 5, gain 5, slot
    # sum 1, tree 7 (three levels of 2, the last one more), saturation 2
    assert ReplayContract(channels=64, slots=10).output_cycles == 40
    text = (DOCS / "fixed_point.md").read_text()
    for s in ("8850", "6638", "458", "26552", "32767", "L = 2", "M = 10 (P = 7): 40 clocks"):
        assert s in text


def test_tdm_engine_md_holds_the_slot_schedule_the_stages_make():
    """docs/tdm_engine.md's schedule table is the one the pipeline's stages'
    latencies give for the default build (rast.hdl.pipeline.timeline)."""
    from rast.gateware.schedule_doc import default_contract
    from rast.hdl.pipeline.timeline import TABLE_BEGIN, TABLE_END, schedule_markdown
    text = (DOCS / "tdm_engine.md").read_text()
    table = text.split(TABLE_BEGIN, 1)[1].split(TABLE_END, 1)[0].strip()
    assert table == schedule_markdown(default_contract()).strip(), \
        "docs/tdm_engine.md's slot schedule is stale: python -m rast.gateware.schedule_doc"


def test_the_slot_schedule_follows_the_contract():
    """The events the stages' properties place agree with the contract's own
    schedule (rast.model.contract.fixedpoint): the pipeline's sum, the tree
    and the output at engine_output_cycles, for several shapes."""
    from rast.hdl.pipeline.timeline import slot_schedule
    from rast.model.contract.fixedpoint import ACCEPT_LAG, engine_output_cycles, tree_cycles, visit_cycles
    for ch, m in ((1, 1), (16, 2), (64, 8), (66, 10), (5, 3)):
        c = ReplayContract(channels=ch, slots=m)
        rows = {what: clock for what, _, clock in slot_schedule(c)}
        visit = rows["slot s visits: its state at the ring's head, stage A"]
        assert visit == visit_cycles(m)
        out = rows["output n in its register, saturated"]
        assert out + ACCEPT_LAG == engine_output_cycles(m, c.pipelines) == c.output_cycles
        tree = next(v for k, v in rows.items() if k.startswith("the sum over the"))
        assert tree - rows["the period's sum over the slots (pipeline ``sum``)"] == tree_cycles(c.pipelines)
