"""`rast verilog`: Verilog of the top with a parameter header, Verilator lint clean."""

import json
import re

import pytest

from rast import verilog as rv
from rast.gateware import verilog as gv
from rast.model.contract.fixedpoint import ReplayContract, pack_iq


@pytest.mark.parametrize("args", [
    ["--channels", "1", "--pool-words", "16", "--max-delay", "14", "--max-tap", "1"],
    ["--channels", "3", "--pool-words", "64", "--max-delay", "62", "--max-tap", "14",
     "--interpolation", "linear", "--cmult-form", "3mult"],
    ["--channels", "16", "--pool-words", "16", "--max-delay", "30", "--max-tap", "6",
     "--interpolation", "hold"],
    ["--channels", "5", "--pool-words", "64", "--max-delay", "30", "--max-tap", "6", "--scan"],
])
def test_verilog_lints_clean(tmp_path, args):
    out = tmp_path / "replay.v"
    assert rv.main(args + ["-o", str(out), "--lint"]) == 0
    text = out.read_text()
    assert text.startswith("// wind_farm_replay: RAST wind-farm replay block")
    assert f"channels={args[1]} " in text.splitlines()[1]
    assert "module wind_farm_replay(" in text
    assert ("input acp" in text and " scan=1" in text.splitlines()[1]) == ("--scan" in args)


def test_lint_fails_on_unwaived_warning(tmp_path):
    bad = tmp_path / "bad.v"
    bad.write_text("module bad(input [3:0] a, output y);\n  assign y = a < 4'h0;\nendmodule\n")
    with pytest.raises(RuntimeError, match=r"UNSIGNED"):
        gv.lint(bad, "bad")


def test_waivers_have_reasons():
    assert all(isinstance(w, str) and w.isupper() and len(why) > 20 for w, why in gv.VERILATOR_WAIVERS)


def _modules(text):
    """{module name: body} of a Verilog file (escaped names without the backslash)."""
    return {m.group(1).lstrip("\\"): m.group(2) for m in
            re.finditer(r"^module (\S+)\s*\(.*?\);\n(.*?)^endmodule", text, re.M | re.S)}


def _literal(width, base, digits):
    return int(digits.replace("_", ""), {"h": 16, "d": 10, "b": 2}[base]), int(width)


def _reg_init(body, name):
    """Initial value of ``reg [...] name = <width>'<base><digits>;`` in a module body."""
    m = re.search(rf"^\s*reg (?:\[(\d+):0\] )?{re.escape(name)} = (\d+)'([hdb])([0-9a-fA-F_]+);", body, re.M)
    assert m, f"no initialised register {name}"
    value, width = _literal(m.group(2), m.group(3), m.group(4))
    assert width == (int(m.group(1)) + 1 if m.group(1) else 1)
    return value


def _memory_init(body, name="storage"):
    """The ``initial`` contents of memory ``name`` as a list (unassigned words are None)."""
    m = re.search(rf"^\s*reg \[(\d+):0\] {name} \[(\d+):0\];", body, re.M)
    assert m, f"no memory {name}"
    words = [None] * (int(m.group(2)) + 1)
    for k, width, base, digits in re.findall(rf"^\s*{name}\[(\d+)\] = (\d+)'([hdb])([0-9a-fA-F_]+);", body, re.M):
        value, w = _literal(width, base, digits)
        assert w == int(m.group(1)) + 1
        words[int(k)] = value
    return words


def test_manifest_baked_into_power_up_state(tmp_path):
    """Each manifest value lands where it belongs: the stream words at the pool's
    start, gain, delay (less the fixed latency), base, length, increment and
    enable in channel 0's registers; channel 1 stays empty and off."""
    n = 8
    words = [int(w) for w in pack_iq([100 * (k + 1) for k in range(n)], [-7 * (k + 1) for k in range(n)])]
    (tmp_path / "a.hex").write_text("".join(f"{w:08x}\n" for w in words))
    increment, gain, delay = 0x12345, 0x0C000, 100
    manifest = {
        "windmills": [{"name": "a", "hex_file": "a.hex", "length": n}],
        "registers": {"channels": [{"windmill": "a", "enable": 1, "length": n,
                                    "phase_increment": increment, "gain": gain,
                                    "delay_samples": delay}]},
    }
    (tmp_path / "manifest.json").write_text(json.dumps(manifest))
    out = tmp_path / "baked.v"
    args = ["--channels", "2", "--pool-words", "16", "--max-delay", "126", "--max-tap", "2"]
    assert rv.main(args + ["--manifest", str(tmp_path / "manifest.json"), "-o", str(out)]) == 0
    text = out.read_text()
    assert "initial contents from manifest.json: a" in text
    latency = ReplayContract(channels=2, pool_words=16, max_delay=126, max_tap=2).latency
    modules = _modules(text)

    pool = _memory_init(modules["wind_farm_replay.pool.bank0"])
    assert pool == words + [0] * (16 - n)                     # from address 0, in order, nothing else

    regs = modules["wind_farm_replay.regs"]
    M = ReplayContract(channels=2, pool_words=16, max_delay=126, max_tap=2).slots

    def ram_init(body, field, channel):
        """Channel ``channel``'s word in its pipeline's RAM of ``field``
        (rast.hdl.registers.RAM_FIELDS: channel p*M + s at word s of group p)."""
        return _memory_init(body, f"ram_{field}_g{channel // M}")[channel % M]
    assert _reg_init(regs, "ctrl0_enable") == 1 and _reg_init(regs, "ctrl1_enable") == 0
    assert ram_init(regs, "gain", 0) == gain and ram_init(regs, "gain", 1) == 0
    assert _reg_init(regs, "common_delay_delay") == delay - latency
    assert _reg_init(regs, "delay0_delay") == 0 and _reg_init(regs, "delay1_delay") == 0
    assert ram_init(regs, "length", 0) == n and ram_init(regs, "base", 0) == 0
    assert ram_init(regs, "increment", 0) == increment and ram_init(regs, "increment", 1) == 0

    # Without the manifest every one of them powers up empty.
    plain = _modules(gv.verilog_text(2, pool_words=16, max_delay=126, max_tap=2))
    assert _memory_init(plain["wind_farm_replay.pool.bank0"]) == [0] * 16
    assert ram_init(plain["wind_farm_replay.regs"], "gain", 0) == 0


def test_objcache_caches_verilators_runtime_library_only(tmp_path, monkeypatch):
    """The OBJCACHE setup_verilator sets, as Verilator's make files expand it in
    a recipe: ccache before a compile of $(VERILATOR_ROOT)/include's sources,
    nothing before the design's own."""
    import shutil
    import subprocess
    import os
    monkeypatch.setenv("OBJCACHE", "")          # recorded: restored as it was after the test
    monkeypatch.delenv("OBJCACHE")
    monkeypatch.setenv("CCACHE_DIR", str(tmp_path / "cache"))
    root = gv.setup_verilator()
    objcache = os.environ["OBJCACHE"]
    assert "ccache" in objcache and (tmp_path / "cache").is_dir()
    (tmp_path / "design.cpp").write_text("")
    (tmp_path / "Makefile").write_text(
        "all: lib.o design.o\n"
        "lib.o: $(VERILATOR_ROOT)/include/verilated.cpp\n\t@echo 'lib[$(OBJCACHE)]'\n"
        "design.o: design.cpp\n\t@echo 'design[$(OBJCACHE)]'\n")
    out = subprocess.run([shutil.which("make") or "make", "-s", "-C", str(tmp_path)], capture_output=True,
                         text=True, check=True).stdout.split()
    assert (root / "include" / "verilated.cpp").exists()
    assert out[0].startswith("lib[/") and out[0].endswith("ccache]") and out[1] == "design[]"
