# Translucent: two commands for a fresh Linux machine with Python 3.11:
#   make demo   renders the bundled back-lit marble bunny into out/
#   make test   builds the extension zip and runs every test
PYTHON ?= python3.11
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: demo test extension wheels venv bench clean

$(STAMP): requirements.txt
	@command -v $(PYTHON) >/dev/null || { echo "make: $(PYTHON) not found: bpy 5.0.1 needs Python 3.11 (set PYTHON=...)"; exit 1; }
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -r requirements.txt
	touch $(STAMP)

venv: $(STAMP)

wheels: $(STAMP)
	$(PY) scripts/build_extension.py wheels

extension: wheels
	$(PY) scripts/build_extension.py build

demo: $(STAMP)
	$(PY) scripts/demo.py --output out

test: extension
	$(PY) -m pytest tests

bench: $(STAMP)
	$(PY) scripts/bench.py
	$(PY) scripts/bench_quadgraph.py
	$(PY) scripts/bench_geocube.py
	$(PY) scripts/bench_caustics.py
	$(PY) scripts/bench_grass.py
	$(PY) scripts/bench_interval.py
	$(PY) scripts/bench_stability.py
	$(PY) scripts/bench_auto.py
	$(PY) scripts/look_world_light.py

clean:
	rm -rf dist wheels out .pytest_cache
