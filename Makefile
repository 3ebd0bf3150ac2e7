# The two commands of the README: `make run` and `make test`. Both create and
# reuse a local virtual environment in .venv; nothing needs root.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
EXAMPLE ?= examples/two_windmills.toml
BITSTREAM_OUT ?= build/bitstream
OUT ?= out/two_windmills

.PHONY: run test venv bench bench-cosim bench-bitstream bitstream clean

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

bench: $(STAMP)
	$(BIN)/python bench/bench_streams.py
	$(BIN)/python bench/bench_interpolation.py
	$(BIN)/python bench/bench_load.py

bench-cosim: $(STAMP)
	$(BIN)/python bench/bench_cosim.py

bench-bitstream: $(STAMP)
	$(BIN)/python bench/bench_bitstream.py $(BENCH_ARGS)

# ULX3S-85F, 64 channels, 20 MS/s on a 200 MHz fabric by default; BUILD_ARGS="--clock-mhz 160 --seed 3" for the same 64 channels at M = 8, met at that nextpnr seed (docs/bitstream.md).
bitstream: $(STAMP)
	$(BIN)/rast build --out $(BITSTREAM_OUT) $(BUILD_ARGS)

clean:
	rm -rf out build sim_build
