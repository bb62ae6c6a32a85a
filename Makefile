# nemc: `make run` compiles and simulates the book's double pendulum; `make test` runs the tests;
# `make stress` regenerates the stress report of the book's four systems (docs/stress/);
# `make docs` builds the documentation site from docs/ into site/ (no network needed);
# `make figures` redraws the tutorials' figures.
# Each sets up everything on a fresh machine (a virtual environment in .venv).
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
PEERS_STAMP := $(VENV)/.peers-installed
DOCS_STAMP := $(VENV)/.docs-installed
OTHER_VENV := .venv-abi3
OTHER_STAMP := $(OTHER_VENV)/.installed
export NEMC_CACHE ?= $(CURDIR)/.nemc-cache

.PHONY: run figures test test-slow wheel-check bench bench-quick stress lint docs other-python clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[dev,sweep]'
	touch $(STAMP)

# The README's figures (docs/figures/double_pendulum.{png,gif}) come from here.
run: $(STAMP)
	$(BIN)/nemc compile examples/double_pendulum.yaml
	$(BIN)/nemc simulate examples/double_pendulum.yaml --plot docs/figures/double_pendulum.png
	$(BIN)/nemc animate examples/double_pendulum.yaml --out docs/figures/double_pendulum.gif

# The figures of the docs' tutorials (docs/figures/): the book's four systems, then those the
# other tutorials' code blocks draw (docs/tutorials/blocks.py runs them and checks their output).
BOOK := compound_pendulum double_pendulum robot_arm two_link_robot_arm
TUTORIALS := slider-crank events sweep friction
figures: $(STAMP)
	for name in $(BOOK); do \
	  $(BIN)/nemc simulate examples/$$name.yaml --plot docs/figures/$$name.png > /dev/null && \
	  $(BIN)/nemc animate examples/$$name.yaml --out docs/figures/$$name.gif || exit 1; done
	$(BIN)/python docs/tutorials/blocks.py --figures docs/figures \
	  $(foreach name,$(TUTORIALS),docs/tutorials/$(name).md)

# Two workers (pytest-xdist), each taking whole test files (their module fixtures build once);
# the 15 slowest tests are listed at the end, to keep the run under about 10 minutes.
test: $(STAMP) other-python
	$(BIN)/python -m pytest -q -n 2 --dist loadfile --durations=15

# The tests marked slow (over 20 s each, the benchmarks' smoke runs and the largest scale
# checks), left out of `make test`; CI runs them too.
test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -m slow

# Another CPython (the newest >= 3.10 found that is not the .venv's) with cffi and numpy, for the
# test that loads a standalone package's stable-ABI extension in it; without one it is skipped.
other-python: $(STAMP)
	@[ -f $(OTHER_STAMP) ] || { other=$$($(BIN)/python tests/other_python.py); \
	  if [ -n "$$other" ] && "$$other" -m venv $(OTHER_VENV) && \
	     $(OTHER_VENV)/bin/pip install --quiet cffi numpy; then touch $(OTHER_STAMP); \
	  else echo "no other CPython >= 3.10 set up: the stable-ABI test will be skipped"; fi; }

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
	cd $(WHEEL_CHECK) && NEMC_CACHE=$(CURDIR)/$(WHEEL_CHECK)/cache venv/bin/nemc simulate \
		$(CURDIR)/examples/fourbar.yaml --t-end 1 | tail -1 | grep -q "reached the end"
	cd $(WHEEL_CHECK) && NEMC_CACHE=$(CURDIR)/$(WHEEL_CHECK)/cache venv/bin/nemc compile \
		$(CURDIR)/examples/two_link_robot_arm.yaml -o out
	cd $(WHEEL_CHECK)/out && ../venv/bin/python -c "import two_link_robot_arm as m; \
		r = m.simulate(method='nemc.Radau'); assert r.success, r.message; print('wheel OK:', r.y[:, -1])"

# The peers are optional: without them (no network, no wheel) the benchmarks record them as absent.
$(PEERS_STAMP): $(STAMP)
	$(BIN)/pip install --quiet -e '.[dev,peers]' || echo "peers not installed: benchmarks skip them"
	$(BIN)/pip install --quiet -e '.[numbalsoda]' || echo "numbalsoda not installed: benchmarks skip it"
	touch $(PEERS_STAMP)

bench: $(PEERS_STAMP)
	$(BIN)/nemc bench
	$(BIN)/python benchmarks/scaling.py
	$(BIN)/python benchmarks/stiff.py
	$(BIN)/python benchmarks/native.py
	$(BIN)/python benchmarks/batch.py
	$(BIN)/python benchmarks/dop853_peer.py
	$(BIN)/python benchmarks/rhs_forms.py
	$(BIN)/python benchmarks/loops.py
	$(BIN)/python benchmarks/sweep.py
	$(BIN)/python benchmarks/events.py
	$(BIN)/python benchmarks/auto.py
	$(BIN)/python benchmarks/plant.py
	$(BIN)/python benchmarks/sensitivities.py
	$(BIN)/python benchmarks/loop_sensitivities.py
	$(BIN)/python benchmarks/ensemble_sensitivities.py
	$(BIN)/python benchmarks/friction.py
	$(BIN)/python benchmarks/fitting.py

bench-quick: $(STAMP)
	$(BIN)/nemc bench --quick

stress: $(STAMP)
	$(BIN)/nemc stress --suite book --out docs/stress

# The docs site (mkdocs-material, its search index built locally: no network at build time).
$(DOCS_STAMP): $(STAMP)
	$(BIN)/pip install --quiet -e '.[dev,docs]'
	touch $(DOCS_STAMP)

docs: $(DOCS_STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict

lint: $(STAMP)
	$(BIN)/ruff check nemc tests benchmarks

clean:
	rm -rf generated/* .nemc-cache site
