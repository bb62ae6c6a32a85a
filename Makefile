# nemc: `make run` compiles and simulates the book's double pendulum; `make test` runs the tests;
# `make stress` regenerates the stress report of the book's four systems (docs/stress/).
# Each sets up everything on a fresh machine (a virtual environment in .venv).
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
PEERS_STAMP := $(VENV)/.peers-installed
export NEMC_CACHE ?= $(CURDIR)/.nemc-cache

.PHONY: run test bench bench-quick stress lint clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[dev,sweep]'
	touch $(STAMP)

run: $(STAMP)
	$(BIN)/nemc compile examples/double_pendulum.yaml
	$(BIN)/nemc simulate examples/double_pendulum.yaml --plot generated/double_pendulum.png

test: $(STAMP)
	$(BIN)/python -m pytest -q

# The peers are optional: without them (no network, no wheel) the benchmarks record them as absent.
$(PEERS_STAMP): $(STAMP)
	$(BIN)/pip install --quiet -e '.[dev,peers]' || echo "peers not installed: benchmarks skip them"
	touch $(PEERS_STAMP)

bench: $(PEERS_STAMP)
	$(BIN)/nemc bench
	$(BIN)/python benchmarks/scaling.py
	$(BIN)/python benchmarks/stiff.py
	$(BIN)/python benchmarks/native.py
	$(BIN)/python benchmarks/sweep.py

bench-quick: $(STAMP)
	$(BIN)/nemc bench --quick

stress: $(STAMP)
	$(BIN)/nemc stress --suite book --out docs/stress

lint: $(STAMP)
	$(BIN)/ruff check nemc tests benchmarks

clean:
	rm -rf generated/* .nemc-cache
