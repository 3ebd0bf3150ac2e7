"""The replay top's Verilog cache (``rast.sim.top``): generated once per
parameter set, the same text as a fresh generation, and keyed so that other
parameters or other sources generate again."""

from rast.sim import runner, top


def test_cached_verilog_is_generated_once_per_key(tmp_path, monkeypatch):
    monkeypatch.setattr(runner, "SIM_BUILD", tmp_path)
    calls = []

    def generate(text):
        def make():
            calls.append(text)
            return text
        return make

    a = top._cached_verilog(2, {"pool_words": 4096}, generate("module a; endmodule\n"))
    b = top._cached_verilog(2, {"pool_words": 4096}, generate("module b; endmodule\n"))
    assert (a, b) == ("module a; endmodule\n",) * 2 and calls == ["module a; endmodule\n"]
    c = top._cached_verilog(2, {"pool_words": 8192}, generate("module c; endmodule\n"))
    assert c == "module c; endmodule\n" and len(calls) == 2
    # another source digest (an edited hdl/ file) is another key
    monkeypatch.setattr(top, "_source_digest", lambda: "edited")
    d = top._cached_verilog(2, {"pool_words": 4096}, generate("module d; endmodule\n"))
    assert d == "module d; endmodule\n" and len(calls) == 3
    assert len(list((tmp_path / "verilog").glob("*.v"))) == 3
    assert not list((tmp_path / "verilog").glob("*.tmp"))


def test_cached_top_equals_a_fresh_generation(tmp_path, monkeypatch):
    from rast.gateware.verilog import verilog_text
    monkeypatch.setattr(runner, "SIM_BUILD", tmp_path)
    kwargs = dict(pool_words=1024, max_delay=30, max_tap=6, interpolation="hold")
    top.top_sources.cache_clear()
    first, _ = top.top_sources(1, **kwargs)
    top.top_sources.cache_clear()
    again, _ = top.top_sources(1, **kwargs)             # from the file
    top.top_sources.cache_clear()
    fresh = verilog_text(1, name=top.TOP_MODULE, cmult_form="4mult", **kwargs)
    assert first[f"{top.TOP_MODULE}.v"] == again[f"{top.TOP_MODULE}.v"] == fresh
    assert len(list((tmp_path / "verilog").glob("*.v"))) == 1
