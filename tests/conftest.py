# Shared pytest hooks: the cosimulation's --waves option (rast.sim.pytest_support).
from rast.sim.pytest_support import pytest_addoption, pytest_configure  # noqa: F401

#: The longest tests, longest first (seconds of a fresh clone's run on two
#: cores, 2026-12-08 at a0f23ce, on a machine slower per core than the one
#: before; docs/cosim_speed.md): they start before everything else, so that
#: the suite does not end with one worker waiting on a long test that started late.
LONGEST_FIRST = (
    "test_sdram_engine_cosim.py::test_64_realistic_turbines",       # 179 s
    "test_gateware_build.py::test_engine_bitstream",                # 124 s
    "test_cosim_netlist.py::test_netlist_top",                      # 120 s (the netlist's build)
    "test_load_bridge.py::test_load_manifest_end_to_end",           # 99 s
    "test_hdl_scan_engine.py::test_the_beam_follows_acp_and_arp",   # 97 s
    "test_cosim_top.py::test_top_time_multiplexed[icarus",          # 97 s
    "test_cosim_top.py::test_top_farm_scale",                       # 83 s (the 64-channel top's build)
    "test_default_chain.py::test_make_run_bitstream_load_chain",    # 83 s
    "test_cosim_netlist.py::test_wrong_primitive_setting_fails",    # 69 s
    "test_load_bridge.py::test_a_word_damaged_on_the_line",         # 68 s
    "test_cosim_e2e.py::test_two_windmills_one_second_verilator",   # 67 s
    "test_cosim_follow.py::test_a_revolution",                      # 64 s
    "test_sdram_load_chain.py::",                                   # 63 s
    "test_cosim_scan.py::test_rast_cosim_of_a_turning_config",      # 58 s
)


def pytest_collection_modifyitems(config, items):
    """The longest tests first (LONGEST_FIRST), then the other slow ones (a
    bitstream build, cosimulations), then the rest, so that the two workers
    end on short tests rather than one waiting for the other's last long
    test; the order within each group is kept."""
    def rank(item):
        for k, key in enumerate(LONGEST_FIRST):
            if key in item.nodeid:
                return (0, k)
        return (1 if item.get_closest_marker("slow") else 2, 0)
    items.sort(key=rank)
