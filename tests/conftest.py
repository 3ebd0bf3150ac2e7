# Shared pytest hooks: the cosimulation's --waves option (rast.sim.pytest_support).
from rast.sim.pytest_support import pytest_addoption, pytest_configure  # noqa: F401

#: The longest tests, longest first (seconds of a fresh clone's run on two
#: quiet cores, 2026-12-07; docs/cosim_speed.md): they start before
#: everything else, so that the suite does not end with one worker waiting
#: on a long test that started late.
LONGEST_FIRST = (
    "test_sdram_engine_cosim.py::test_64_realistic_turbines",       # 110 s
    "test_gateware_build.py::test_engine_bitstream",                # 83 s
    "test_cosim_netlist.py::test_netlist_top",                      # 68 s (the netlist's build)
    "test_cosim_e2e.py::test_two_windmills_icarus",                 # 67 s
    "test_cosim_top.py::test_top_time_multiplexed[icarus",          # 64 s
    "test_cosim_top.py::test_top_farm_scale",                       # 56 s
    "test_hdl_formal.py::test_formal[delay_exact_deep]",            # 49 s
    "test_load_bridge.py::test_load_manifest_end_to_end",           # 41 s
    "test_default_chain.py::test_make_run_bitstream_load_chain",    # 40 s
    "test_sdram_load_chain.py::",                                   # 39 s
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
