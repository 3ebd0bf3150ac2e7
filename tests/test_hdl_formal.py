"""Formal checks with yowasp-sby (smtbmc yices): see tests/formal/replay_formal.py."""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent / "formal"))
from replay_formal import run_check   # noqa: E402


@pytest.mark.parametrize("name", [
    "stream_address",          # k-induction, every ring position: index <= length - 1 < pool, fetches inside the stream
    "stream_address_m1",       # one slot: the update in one stage
    "stream_address_m3",       # three slots: a plain register in the ring
    "stream_address_interp",
    "stream_address_fir",
    "delay_exact",             # BMC: a read for step n at delay d returns the word of step n - lag - d
    pytest.param("delay_exact_deep", marks=pytest.mark.slow),
    "delay_exact_groups",      # the same, groups of block RAMs (the write a clock ahead)
    "delay_exact_copies",      # the common line's form: the read a clock ahead too, through address copies
])
def test_formal(name, tmp_path):
    ok, log = run_check(name, tmp_path)
    tail = "\n".join(line for line in log.splitlines() if "summary" in line or "DONE" in line)
    assert ok, f"{name} failed:\n{tail}\n(full log in {tmp_path})"
