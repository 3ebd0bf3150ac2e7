"""The documents match what they describe."""

from pathlib import Path

import numpy as np

from rast.model.datapath import cmult, gain_scale
from rast.model.fixedpoint import ReplayContract, saturate
from rast.model.regdoc import registers_doc

DOCS = Path(__file__).resolve().parents[1] / "docs"


def test_registers_md_is_generated_from_the_map():
    assert (DOCS / "registers.md").read_text() == registers_doc(), \
        "docs/registers.md is stale: python -m rast.model.regdoc > docs/registers.md"


def test_fixed_point_worked_example():
    p = cmult(12000, -5000, 20000, 10000)
    assert (int(p[0]), int(p[1])) == (8850, 610)
    q = gain_scale(np.array(p), 49152)
    assert q.tolist() == [6638, 458]
    y, over = saturate(5 * q)
    assert y.tolist() == [32767, 2290] and over.tolist() == [True, False]
    # two delay lines 3 + 3, cmult 3, gain 2, adder tree max(1, ceil(log2 N))
    assert [ReplayContract(channels=n).latency for n in (1, 2, 4, 8, 16, 64)] == [12, 12, 13, 14, 15, 17]
    text = (DOCS / "fixed_point.md").read_text()
    for s in ("8850", "6638", "458", "26552", "32767", "N = 1 or 2 → 12, 4 → 13, 8 → 14, 16 → 15, 64 → 17"):
        assert s in text
