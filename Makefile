# Translucent: two commands for a fresh Linux machine with Python 3.13 (and 3.11 for Blender 4.5):
#   make demo   renders the bundled back-lit marble bunny into out/ (Blender 5.2 LTS as a module)
#   make test   builds the extension zips and runs every test on Blender 5.2 LTS, the GPU tests on 5.3 under
#               Vulkan and OpenGL, then the zip-only and image-parity tests (install with only the zip's wheels,
#               every operator, every method's frame against the reference frame) on 5.2.4, 5.3.0 (Vulkan and
#               OpenGL) and 4.5.15. Without a Vulkan driver the Vulkan cases are skipped, in one line; CI fails then.
# `scripts/find_python.sh` finds each Python (PATH, then pyenv) or says how to get it.
PYTHON ?= $(shell sh scripts/find_python.sh 3.13)
PYTHON311 ?= $(shell sh scripts/find_python.sh 3.11)
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
PYTEST_PIN := pytest==8.3.5
# The Blenders the zip-only tests install the zip into: version and the Python it needs.
ZIP_BLENDERS := 5.2.4:$(PYTHON) 5.3.0:$(PYTHON) 4.5.15:$(PYTHON311)
# Blender x GPU backend cases (scripts/test_backends.sh); the reference Blender (5.2.4, OpenGL) first: it bakes the
# parity scene and renders the reference frames (tests/zip_only/test_parity.py).
ZIP_CASES := 5.2.4:OPENGL 5.3.0:VULKAN 5.3.0:OPENGL 4.5.15:OPENGL
GPU53_CASES := 5.3.0:VULKAN 5.3.0:OPENGL
VENV53 := .venv-5.3

.PHONY: demo test test-dev test-gpu53 test-zip lint extension wheels venv bench bench-exact bench-frame bench-gpu \
	bench-material bench-suite bench-instances clean

$(STAMP): requirements.txt
	@case "$(PYTHON)" in *not-found) echo "make: Python 3.13 not found (Blender 5.2 needs it): pyenv install 3.13, or PYTHON=..."; exit 1;; esac
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -r requirements.txt
	touch $(STAMP)

venv: $(STAMP)

wheels: $(STAMP)
	$(PY) scripts/build_extension.py wheels

extension: $(STAMP)
	$(PY) scripts/build_extension.py build

lint: $(STAMP)
	$(PY) -m ruff check .

# A venv holding only bpy and pytest per Blender: what the zip lacks cannot come from anywhere else.
.venv-zip-%/.installed:
	@py="$(filter $*:%,$(ZIP_BLENDERS))"; py="$${py#*:}"; \
	case "$$py" in ""|*not-found) echo "make: no Python for bpy $*: pyenv install 3.11 / 3.13"; exit 1;; esac; \
	$$py -m venv .venv-zip-$* && .venv-zip-$*/bin/python -m pip install --quiet --upgrade pip && \
	.venv-zip-$*/bin/python -m pip install --quiet bpy==$* $(PYTEST_PIN)
	touch $@

test-dev: extension lint
	$(PY) -m pytest tests --ignore=tests/zip_only

test-zip: extension $(foreach b,$(ZIP_BLENDERS),.venv-zip-$(firstword $(subst :, ,$(b)))/.installed)
	@sh scripts/test_backends.sh "$(ZIP_CASES)" -- sh -c 'TRANSLUCENT_ZIP_ONLY=1 \
	  TRANSLUCENT_PARITY_PYTHON=.venv-zip-5.2.4/bin/python .venv-zip-$$BPY_VERSION/bin/python \
	  -m pytest tests/zip_only -p no:cacheprovider'

# The development environment on Blender 5.3 (bpy 5.3.0 in place of 5.2's pin, the rest as requirements.txt).
$(VENV53)/.installed: requirements.txt
	@case "$(PYTHON)" in *not-found) echo "make: Python 3.13 not found (Blender 5.3 needs it)"; exit 1;; esac
	$(PYTHON) -m venv $(VENV53)
	sed 's/^bpy==.*/bpy==5.3.0/' requirements.txt > $(VENV53)/requirements.txt
	$(VENV53)/bin/python -m pip install --quiet --upgrade pip
	$(VENV53)/bin/python -m pip install --quiet -r $(VENV53)/requirements.txt
	touch $@

# The suite's GPU tests (marker gpu: every GPU pass against its CPU twin, the frames of every method) on 5.3 under
# Vulkan and OpenGL.
test-gpu53: extension $(VENV53)/.installed
	@sh scripts/test_backends.sh "$(GPU53_CASES)" -- $(VENV53)/bin/python -m pytest tests --ignore=tests/zip_only \
	  -m gpu -p no:cacheprovider -q

test: test-dev test-gpu53 test-zip

demo: $(STAMP)
	$(PY) scripts/demo.py --output out

bench: $(STAMP)
	$(PY) scripts/bench.py
	$(PY) scripts/bench_frame.py
	$(PY) scripts/bench_exact.py
	$(PY) scripts/bench_exact.py --sweep --output bench/results/exact_sweep
	$(PY) scripts/bench_suite.py
	$(PY) scripts/bench_quadgraph.py
	$(PY) scripts/bench_geocube.py
	$(PY) scripts/bench_caustics.py
	$(PY) scripts/bench_grass.py
	$(PY) scripts/bench_interval.py
	$(PY) scripts/bench_stability.py
	$(PY) scripts/bench_auto.py
	$(PY) scripts/look_world_light.py

# The subsurface methods against exact transport (Cycles brute force, index-matched): about 40 minutes here.
bench-exact: $(STAMP)
	$(PY) scripts/bench_exact.py

# The generalisation suite: every subsurface method against exact transport on 24 drawn scenes (ten shapes, 1 cm to
# 1 m, the presets and Principled looks, four lights from four sides, IOR 1 and 1.3-1.4): about 75 minutes here, or
# 30 with the references kept in bench/suite_references/.
bench-suite: $(STAMP)
	$(PY) scripts/bench_suite.py

# The artist's material (textured, glossy, normal-mapped spot) against Cycles' random walk, and the surface layer's
# cost on the demo frame: about 8 minutes here.
bench-material: $(STAMP)
	$(PY) scripts/bench_material.py

# Where a frame's time goes (CPU work outside GPU calls, GPU calls), demo bunny at 64x64: about 3 minutes here.
bench-frame: $(STAMP)
	$(PY) scripts/bench_frame.py

# Scenes of many: 1, 10 and 100 linked duplicates of a baked ball per method and 1,000 geometry-nodes instances, frame
# time and Blender's peak memory, each count in a fresh process: about 25 minutes here.
bench-instances: $(STAMP)
	$(PY) scripts/bench_instances.py

# Each method at 1920x1080 on the demo and bench scenes, frames per second and the split, the GPU named; at
# most 5 minutes (what does not fit is listed as skipped). Run it on a machine with a GPU: on llvmpipe it draws
# 480x270 and labels its figures software rendering.
bench-gpu: $(STAMP)
	$(PY) scripts/bench_frame.py --gpu --budget 270

clean:
	rm -rf dist wheels out .pytest_cache .venv-zip-* .parity
