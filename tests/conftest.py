# Shared pytest hooks: the cosimulation's --waves option (rast.sim.pytest_support).
from rast.sim.pytest_support import pytest_addoption, pytest_configure  # noqa: F401


def pytest_collection_modifyitems(config, items):
    """The slow tests first (a bitstream build, long cosimulations, each minutes
    long), so that the two workers end on short tests rather than one waiting
    for the other's last long test; the order within each group is kept."""
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)
