"""Bare Verilator C++ harness for the benchmark (see build.py)."""
