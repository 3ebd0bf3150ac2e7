"""Range calibration on the board's sample path, ADC pins to DAC pins.

Cosimulates :class:`rast.gateware.top.BoardCore` (everything of the board top
but the PLL: DDR cells, fabric registers, UART bridge, replay block) with the
ECP5 cells it really instantiates (:mod:`rast.sim.board_io`), one sample per
fabric clock (M = 1) and four (M = 4, the converter clocks made from the slot
counter). A manifest of one windmill with a constant stream is loaded through
the UART bridge with the writes of ``manifest_to_register_writes(...,
target="board")``; one impulse on the ADC pins must come out of the DAC pins
exactly ``delay_samples`` later (less the converters' latencies, which lie
outside the pins). With the bare block's formula (``COMMON_DELAY + DELAY =
delay_samples - L``) the same impulse comes out ``board_latency - L`` samples
later than asked.
"""

import json

import pytest

from rast.model.contract.fixedpoint import ReplayContract, pack_iq, board_input_latency, board_output_latency
from rast.model.contract.loadplan import manifest_to_register_writes
from rast.model.contract.regmap import register_map
from rast.sim import runner
from rast.sim.board_io import BUILD_ARGS, board_io_sources

#: Cosimulations: left out of `make test-fast`, run by `make test` and CI.
pytestmark = pytest.mark.slow

MODULE = "rast.sim.tb_board_io"
BUILD = dict(channels=2, pool_words=16, max_delay=62, max_tap=6, interpolation="hold")
SAMPLE_HZ = 20e6
DIVISOR = 4
DELAY = 48                       # samples: the windmill's delay_samples (beyond M = 1's 43 with the converters)
IMPULSE = (16384, -8192)         # (I, Q) on the ADC pins; the stream word is 32767 + 0j, gain 1.0
ECHO = (16384, -8192)            # round_half_up(x * 32767, 15), gain 1.0: the same


def _contract(slots):
    """The replay block inside the simulated board (BoardCore states SAMPLE_RATE = clock / slots)."""
    return ReplayContract(**BUILD, slots=slots, sample_rate_hz=round(SAMPLE_HZ))


def _manifest(adc=None, dac=None):
    words = [int(pack_iq([32767], [0])[0])] * 8
    m = {
        "sample_rate_hz": SAMPLE_HZ, "interpolation": "hold",
        "windmills": [{"name": "w0", "hex_file": "w0.hex", "length": len(words), "delay_samples": DELAY}],
        "registers": {"channels": [{"windmill": "w0", "enable": 1, "length": len(words),
                                    "phase_increment": 0, "gain": 1 << 16, "delay_samples": DELAY}]},
    }
    if adc is not None:
        m["calibration"] = {"adc_latency_samples": adc, "dac_latency_samples": dac}
    return m, [words]


@pytest.mark.parametrize("slots", [1, 4])
def test_impulse_from_adc_pins_to_dac_pins(slots):
    contract = _contract(slots)
    L, board = contract.latency, contract.board_latency
    cases = []          # (what, writes, expected pin-to-pin samples)
    m, s = _manifest()
    cases.append(("board, no calibration", manifest_to_register_writes(m, contract, streams=s,
                                                                       target="board"), DELAY))
    cases.append(("bare block's formula", manifest_to_register_writes(m, contract, streams=s,
                                                                       target="block"),
                  DELAY + board - L))
    m, s = _manifest(adc=2, dac=3)
    # The converters' 5 samples lie outside the pins: pin to pin is 5 shorter,
    # antenna to antenna exactly DELAY.
    cases.append(("board, adc 2 + dac 3", manifest_to_register_writes(m, contract, streams=s,
                                                                      target="board"), DELAY - 5))
    window = DELAY + board + 16
    steps = [{"writes": w, "settle": 64, "impulse": list(IMPULSE), "window": window}
             for _, w, _ in cases]

    sources, top = board_io_sources(clk_hz=SAMPLE_HZ * slots, divisor=DIVISOR, slots=slots, **BUILD)
    b = runner.build(sources, top, simulator="verilator", label=f"board_io_m{slots}",
                     build_args=BUILD_ARGS)
    run_dir = runner.run(b, MODULE, name=f"board-io-impulse-m{slots}", testcase="board_io", quiet=True,
                         extra_env={"RAST_TB_PARAMS": json.dumps({"divisor": DIVISOR, "slots": slots,
                                                                  "steps": steps})})
    rep = json.loads((run_dir / "board_io.json").read_text())

    assert rep["acks"] == rep["frames"] == rep["replies"], rep
    assert rep["overflow"] == 0
    # forwarded clocks high for the first half of every sample (M half clocks),
    # low for the second, the DAC's I marker with them
    pattern = [a for a, _, _ in rep["pattern"]]
    assert all(tuple(p) == (a, a, a) for p, a in zip(rep["pattern"], pattern))
    first = next(k for k in range(1, len(pattern)) if pattern[k - 1:k + 1] == [0, 1])
    assert pattern[first:first + 4 * slots] == ([1] * slots + [0] * slots) * 2
    measured = []
    for (what, _, expected), step in zip(cases, rep["steps"]):
        assert step["iq_marker"] == [[1, 0]], what
        assert step["unsteady"] == [], f"{what}: the DAC pins changed within a phase of dac_clk"
        assert len(step["nonzero"]) == 1, f"{what}: {step['nonzero']}"
        at, i, q = step["nonzero"][0]
        assert (i, q) == ECHO, what
        assert at == expected, f"{what}: echo {at} samples after the ADC pin sample, expected {expected}"
        measured.append(at)
    # the bare block's formula places every turbine board_latency - L samples too far out
    assert measured[1] - measured[0] == board - L


def test_refuses_a_windmill_inside_the_board_latency():
    contract = _contract(1)
    m, s = _manifest(adc=2, dac=3)
    fixed = contract.board_latency + 5
    m["registers"]["channels"][0]["delay_samples"] = fixed - 1
    with pytest.raises(ValueError, match=rf"^Delay of {fixed - 1} samples \(windmill 'w0'\) is shorter "
                                         rf"than the board's fixed latency of {fixed} samples "
                                         rf"\(replay block L {contract.latency} \+ ADC pins to the block "
                                         rf"{board_input_latency(1)} \+ the block's pipeline to the DAC "
                                         rf"pins {board_output_latency(contract)} \+ ADC 2 \(adc_latency\) "
                                         rf"\+ DAC 3 \(dac_latency\)\)$"):
        manifest_to_register_writes(m, contract, streams=s, target="board")
    m["registers"]["channels"][0]["delay_samples"] = fixed
    w = manifest_to_register_writes(m, contract, streams=s, target="board")
    # COMMON_DELAY = DELAY = 0 is the nearest a board places a windmill
    assert dict(w)[register_map(contract).addr("COMMON_DELAY")] == 0
