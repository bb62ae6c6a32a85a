# nemc: `make run` compiles and simulates the book's double pendulum; `make test` runs the tests;
# `make stress` regenerates the stress report of the book's four systems (docs/stress/).
# Each sets up everything on a fresh machine (a virtual environment in .venv).
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
PEERS_STAMP := $(VENV)/.peers-installed
export NEMC_CACHE ?= $(CURDIR)/.nemc-cache

.PHONY: run test wheel-check bench bench-quick stress lint clean

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

# The built wheel, installed alone into a fresh virtual environment (no source tree on the path),
# compiles and simulates an example, and its exported package runs on its own (CI runs this).
WHEEL_CHECK := build/wheel-check
wheel-check: $(STAMP)
	rm -rf $(WHEEL_CHECK) && mkdir -p $(WHEEL_CHECK)
	$(BIN)/pip wheel --quiet --no-deps . -w $(WHEEL_CHECK)/dist
	$(PYTHON) -m venv $(WHEEL_CHECK)/venv
	$(WHEEL_CHECK)/venv/bin/pip install --quiet $(WHEEL_CHECK)/dist/nemc-*.whl
	cd $(WHEEL_CHECK) && NEMC_CACHE=$(CURDIR)/$(WHEEL_CHECK)/cache venv/bin/nemc simulate \
		$(CURDIR)/examples/double_pendulum.yaml --method nemc.Taylor | tail -1 | grep -q "reached the end"
	cd $(WHEEL_CHECK) && NEMC_CACHE=$(CURDIR)/$(WHEEL_CHECK)/cache venv/bin/nemc compile \
		$(CURDIR)/examples/two_link_robot_arm.yaml -o out
	cd $(WHEEL_CHECK)/out && ../venv/bin/python -c "import two_link_robot_arm as m; \
		r = m.simulate(method='nemc.Radau'); assert r.success, r.message; print('wheel OK:', r.y[:, -1])"

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
