"""Netlist cosimulation: the replay top after synth_ecp5, with the ECP5 cell models, under the
same bulk testbench and scoreboard as the behavioural top (every output sample compared with the
bit-exact model as integers); and a wrong primitive setting in a copy of the netlist must fail.

The replay top at the default build's delays, interpolation and slots, and a pool of two of its
banks (so the block RAMs are in the build's width-sliced modes, the pool's banks behind their
multiplexer, and one pipeline of 8 slots is time-multiplexed as in the build), with two channels: the netlist of the whole 64-channel build is the same
pipeline seven times, and its simulation would take most of CI's two cores.
"""

import pytest

from rast.gateware.build import BuildConfig
from rast.model.contract.fixedpoint import POOL_BANK_WORDS
from rast.sim import runner
from rast.sim.netlist import edit_cell, replay_netlist_sources
from rast.sim.pytest_support import cocotb_run

MODULE = "rast.sim.tb_top"
_D = BuildConfig()
#: The default build's delays and slots, and a pool of two of its banks (its
#: four banks' block RAMs are the same slices and multiplexer, twice over;
#: half the cells halve the netlist's Verilator build, the suite's longest).
DEFAULT_CONTRACT = dict(pool_words=2 * POOL_BANK_WORDS, max_delay=_D.max_delay, max_tap=_D.max_tap,
                        slots=_D.slots)
assert _D.pool_words > 2 * POOL_BANK_WORDS


def _run(kind, seed, *, channels=2, netlist_edit=None, name=""):
    sources, top = replay_netlist_sources(channels, interpolation=_D.interpolation, cmult_form=_D.cmult_form,
                                          netlist_edit=netlist_edit, **DEFAULT_CONTRACT)
    cocotb_run(sources, top, MODULE, "replay_bulk", simulator="verilator", bulk=True,
               label=f"netlist{channels}", name=f"netlist-{kind}-{channels}ch-s{seed}{name}",
               tb_params=dict(kind=kind, channels=channels, seed=seed, gap_thresh=48, stall_thresh=48,
                              contract=DEFAULT_CONTRACT))


@pytest.mark.slow
@pytest.mark.parametrize("kind, seed", [
    ("farm", 14),          # golden-model farm, reloaded with a second farm mid-run
    ("saturate", 15),      # full-scale input and streams: the sum saturates (the testbench checks it did)
    ("random", 16),        # random register sequences: gains, enables, delays with APPLY, reloads, forced switches
])
def test_netlist_top(kind, seed):
    _run(kind, seed)


#: A register mode flipped in one primitive of a netlist copy (cell, key, right, wrong, which
#: instance having it), under the random register sequences (channels at different taps): the
#: output register of the window's DP16KD holding bits 9 to 17 of its words, read at each
#: slot's tap, a different address each clock. The common delay line's slice was the case until
#: the line's step count moved a clock after the accept (its read address is now held in the
#: clock before and the clock of the read that matters, so a slice one clock early returns the
#: same word); the stream pool's until the pool read every clock (a bank's address is held
#: between reads of that bank). Each case costs a Verilator build of the whole netlist
#: (about 3 minutes of CI); the sign settings of MULT18X18D are checked against hand-worked
#: products on the cell model itself (tests/test_ecp5_models.py, ``mult_sign_modes``), so one
#: case shows that this cosimulation sees a wrong primitive setting. (A flipped SIGNEDA of the
#: real-part gain multiplier, the fifth MULT18X18D, was also caught here; a sign of the first
#: complex-product multiplier was not: in this short farm its operands stay of one sign.)
WRONG_SETTINGS = {
    "dp16kd_regmode": ("DP16KD", "REGMODE_B", '"OUTREG"', '"NOREG"', "pipe0.window.line.mem_bits9.bram0"),
}


@pytest.mark.slow
@pytest.mark.parametrize("setting", list(WRONG_SETTINGS))
def test_wrong_primitive_setting_fails(setting):
    cell, key, old, new, which = WRONG_SETTINGS[setting]
    with pytest.raises(runner.SimulationFailed, match=r"mismatch|differ"):
        _run("random", 16, netlist_edit=lambda text: edit_cell(text, cell, key, old, new, which), name=f"-{setting}")
