# Shared pytest hooks: the cosimulation's --waves option (rast.sim.pytest_support).
from rast.sim.pytest_support import pytest_addoption, pytest_configure  # noqa: F401
