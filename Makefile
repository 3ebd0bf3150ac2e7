# The two commands of the README: `make run` and `make test`. Both create and
# reuse a local virtual environment in .venv; nothing needs root.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
EXAMPLE ?= examples/two_windmills.toml
BITSTREAM_OUT ?= build/bitstream
OUT ?= out/two_windmills

.PHONY: run test test-fast venv bench bench-cosim bench-bitstream timing-table bitstream clean

venv: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[test]'
	touch $(STAMP)

run: $(STAMP)
	$(BIN)/rast stream $(EXAMPLE) --out $(OUT)
	$(BIN)/rast preview $(EXAMPLE) --out $(OUT)/spectrogram.png

test: $(STAMP)
	$(BIN)/python -m pytest -n 2 --dist worksteal -ra --durations=25 $(PYTEST_ARGS)

# The edit-test tier: everything but the tests marked slow (bitstream builds,
# long cosimulations), which `make test` and CI still run.
test-fast: $(STAMP)
	$(BIN)/python -m pytest -n 2 --dist worksteal -m "not slow" -q --durations=10 $(PYTEST_ARGS)

bench: $(STAMP)
	$(BIN)/python bench/bench_streams.py
	$(BIN)/python bench/bench_interpolation.py
	$(BIN)/python bench/bench_load.py
	$(BIN)/python bench/bench_capacity.py

bench-cosim: $(STAMP)
	$(BIN)/python bench/bench_cosim.py

bench-bitstream: $(STAMP)
	$(BIN)/python bench/bench_bitstream.py $(BENCH_ARGS)

# The README's timing table from the builds' reports: every seed of README_ROWS
# (bench/bench_bitstream.py) of the current netlist, the missing ones built
# (hours: one place and route at a time); TIMING_ARGS=--no-build writes it from
# what is there.
timing-table: $(STAMP)
	$(BIN)/python bench/bench_bitstream.py --readme $(TIMING_ARGS)

# ULX3S-85F, 64 channels at 20 MS/s on a 160 MHz fabric (M = 8) by default (docs/bitstream.md); BUILD_ARGS for others.
bitstream: $(STAMP)
	$(BIN)/rast build --out $(BITSTREAM_OUT) $(BUILD_ARGS)

clean:
	rm -rf out build sim_build
