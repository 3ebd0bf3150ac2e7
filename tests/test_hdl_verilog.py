"""`rast verilog`: Verilog of the top with a parameter header, Verilator lint clean."""

import json

import pytest

from rast import verilog as rv
from rast.model.fixedpoint import pack_iq


@pytest.mark.parametrize("args", [
    ["--channels", "1", "--stream-depth", "16", "--max-delay", "14", "--max-increment", "0"],
    ["--channels", "3", "--stream-depth", "64", "--max-delay", "62", "--max-increment", "14",
     "--interpolation", "linear", "--cmult-form", "3mult"],
    ["--channels", "16", "--stream-depth", "16", "--max-delay", "30", "--max-increment", "6",
     "--interpolation", "hold"],
])
def test_verilog_lints_clean(tmp_path, args):
    out = tmp_path / "replay.v"
    assert rv.main(args + ["-o", str(out), "--lint"]) == 0
    text = out.read_text()
    assert text.startswith("// wind_farm_replay: RAST wind-farm replay block")
    assert f"channels={args[1]} " in text.splitlines()[1]
    assert "module wind_farm_replay(" in text


def test_lint_fails_on_unwaived_warning(tmp_path):
    bad = tmp_path / "bad.v"
    bad.write_text("module bad(input [3:0] a, output y);\n  assign y = a < 4'h0;\nendmodule\n")
    with pytest.raises(RuntimeError, match=r"UNSIGNED"):
        rv.lint(bad, "bad")


def test_waivers_have_reasons():
    assert all(isinstance(w, str) and w.isupper() and len(why) > 20 for w, why in rv.VERILATOR_WAIVERS)


def test_manifest_baked_into_power_up_state(tmp_path):
    words = pack_iq([100, 200, 300], [0, 0, 0])
    (tmp_path / "a.hex").write_text("".join(f"{int(w):08x}\n" for w in words))
    manifest = {
        "windmills": [{"name": "a", "hex_file": "a.hex", "length": 3}],
        "registers": {"channels": [{"windmill": "a", "enable": 1, "length": 3,
                                    "phase_increment": 1 << 31, "gain": 1 << 16,
                                    "delay_increment": 100}]},
    }
    (tmp_path / "manifest.json").write_text(json.dumps(manifest))
    out = tmp_path / "baked.v"
    rv.main(["--channels", "2", "--stream-depth", "16", "--max-delay", "126", "--max-increment", "2",
             "--manifest", str(tmp_path / "manifest.json"), "-o", str(out)])
    text = out.read_text()
    assert "initial contents from manifest.json: a" in text
    assert "32'd300" in text or "32'h0000012c" in text
