# icil-paper: `make reproduce` (experiments + book, small preset) and `make test`.
# Both work alone on a fresh machine with Python 3.11: they depend on `make setup`.
SHELL := /bin/bash
.SHELLFLAGS := -o pipefail -ec
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
PRESET ?= $(or $(ICIL_PRESET),small)
export ICIL_PRESET := $(PRESET)
export MUJOCO_GL ?= egl
export PYTHONUNBUFFERED := 1

# Stamps keyed on what they depend on, so that a repeated `make setup` takes seconds.
REQ_HASH := $(shell cat requirements.txt requirements-no-deps.txt pyproject.toml | sha256sum | cut -c1-16)
PY_STAMP := $(VENV)/.installed-$(REQ_HASH)
# Keyed on the script that installs system packages (lavapipe, chromium), so that a new
# requirement there runs again on a machine that was set up before it.
SYS_STAMP := $(VENV)/.system-$(shell sha256sum tools/system_deps.py | cut -c1-12)
# The book's browser assets (MathJax, the rerun web viewer), pinned in book/package.json.
NODE_HASH := $(shell cat book/package.json book/package-lock.json | sha256sum | cut -c1-16)
NODE_STAMP := book/node_modules/.installed-$(NODE_HASH)
TORCH_PIN := $(shell grep -E '^torch==' requirements.txt)
BOOK_OUT := book/_build
# What notebook outputs depend on besides their own code: the library, the preset, the
# results of this preset and the committed reference run's (shown beside them).
SRC_HASH = $(shell { find src -name '*.py' | LC_ALL=C sort | xargs cat; echo $(PRESET); \
	find results/$(PRESET) results/reference -name '*.json' -printf '%p %T@\n' 2>/dev/null \
	| LC_ALL=C sort; } | sha256sum | cut -c1-16)

.PHONY: help setup test test-all reproduce experiments book browser-check bench pilot lint clean \
	lerobot-setup lerobot-export

help:
	@echo "make setup      create $(VENV), install requirements, the package and the book's npm assets; check Vulkan and Chromium"
	@echo "make test       the whole test suite, on both cores (pytest-xdist; CI allows it 8 minutes on 2 cores)"
	@echo "make reproduce  run the experiments at PRESET=$(PRESET) and build the book"
	@echo "make book       execute the notebooks and build the book into $(BOOK_OUT)/html"
	@echo "make browser-check  load every page of the built book in headless Chromium, offline"
	@echo "make bench      throughput benchmarks (results/bench/*.json)"
	@echo "make pilot      the task-scale pilot (results/bench/pilot.json); PILOT_ARGS=regime: the regime pilot"
	@echo "make lint       ruff, and the package's import layers (lint-imports)"
	@echo "make lerobot-setup   a separate .venv-lerobot (Python 3.12, lerobot) for the LeRobot exporter"
	@echo "make lerobot-export FILE=data.hdf5 OUT=folder   a data set as a LeRobotDataset (v3.0)"

setup: $(PY_STAMP) $(SYS_STAMP) $(NODE_STAMP)

$(PY_STAMP):
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	@echo "Installing Python packages into $(VENV) (a few minutes the first time)"
	# torch first and pinned, so that no other package pulls a CUDA build of it
	$(BIN)/pip install --quiet --progress-bar off '$(TORCH_PIN)' 2>&1 | { grep -v 'is ignored' || true; }
	$(BIN)/pip install --quiet --progress-bar off -r requirements.txt 2>&1 | { grep -v 'is ignored' || true; }
	# robomimic (its tests run its own training on our data sets) and the torchvision it imports,
	# without their declared dependencies, which would replace the CPU torch (requirements-no-deps.txt)
	$(BIN)/pip install --quiet --progress-bar off --no-deps -r requirements-no-deps.txt 2>&1 | { grep -v 'is ignored' || true; }
	$(BIN)/pip install --quiet --no-deps -e . 2>&1 | { grep -v 'is ignored' || true; }
	$(BIN)/python -c "import logging; logging.getLogger('robosuite_logs').disabled = True; \
		import torch, robosuite, mani_skill, metaworld, robomimic.scripts.train, safetensors, icil_paper" \
		|| { echo "setup: the Python install is incomplete (see pip's messages above)"; exit 1; }
	@rm -f $(VENV)/.installed-*; touch $@

$(SYS_STAMP): $(PY_STAMP)
	$(BIN)/python -m tools.system_deps --install
	@rm -f $(VENV)/.system-*; touch $@

# npm ci installs exactly the lock file's versions (no registry addresses are recorded in it).
$(NODE_STAMP): book/package.json book/package-lock.json
	@if command -v npm >/dev/null; then \
		echo "Installing the book's browser assets (npm: mathjax, @rerun-io/web-viewer)"; \
		npm ci --prefix book --no-audit --no-fund --loglevel=error && touch $@; \
	else echo "setup: npm (Node.js) not found: install nodejs and npm, then rerun make setup;" \
		"everything but the book works without it"; fi

test: setup
	$(BIN)/python -m pytest -q -n 2 --dist loadfile --no-loadscope-reorder --durations=15

reproduce: setup
	$(BIN)/icil-paper reproduce --preset $(PRESET)
	$(MAKE) book

experiments: setup
	$(BIN)/icil-paper reproduce --preset $(PRESET)

# The execution cache keys on notebook code only, and Sphinx re-reads only pages whose
# source changed, so whenever src/, the preset or the results change the cache is cleared
# and every page is rebuilt (--all); otherwise a page would keep numbers from old results.
book: setup
	@mkdir -p $(BOOK_OUT)
	@all=""; if [ "$$(cat $(BOOK_OUT)/.src-hash 2>/dev/null)" != "$(SRC_HASH)" ]; then \
		echo "src/, the preset or the results changed: re-executing every chapter"; \
		rm -rf $(BOOK_OUT)/.jupyter_cache $(BOOK_OUT)/recordings $(BOOK_OUT)/html/_static/recordings; \
		all="--all"; fi; \
	$(BIN)/jupyter-book build . --path-output book $$all
	@echo "$(SRC_HASH)" > $(BOOK_OUT)/.src-hash
	@echo "Book: $(BOOK_OUT)/html/index.html"

# Serves the built book on loopback and loads every page in headless Chromium with every
# other request blocked; fails on JS errors, failed requests, raw TeX, broken links or
# images, and recording viewers that did not start. Screenshots: $(BOOK_OUT)/screenshots.
browser-check: setup
	$(BIN)/python -m tools.browser_check $(BOOK_OUT)/html --screenshots $(BOOK_OUT)/screenshots

# The benchmarks CONTRIBUTING.md's "Benchmarks" section lists, one module of tools/bench/ each
# (tests/test_repository.py keeps the three equal). The tools run from the repository root
# (`python -m` puts it on the path), beside the installed library; nothing installs them.
BENCHMARKS := eval tokenizers policies sim kitchen cells datasets
bench: setup
	@for m in $(BENCHMARKS); do \
		echo "== bench $$m"; $(BIN)/python -m tools.bench.$$m || exit 1; done

# The pilot behind the reference preset's task scale (results/bench/pilot.json); with
# PILOT_ARGS=regime, the regime pilot (results/bench/regime.json). Trains and evaluates cells
# at the reference scale; a rerun skips what is stored. Like the benchmarks, a tool of tools/.
PILOT_ARGS ?=
pilot: setup
	$(BIN)/python -m tools.pilot $(PILOT_ARGS)

# LeRobot 0.6 needs Python >= 3.12 and numpy >= 2, which robosuite and ManiSkill here cannot
# share: it gets an environment of its own, used only by icil_paper.interop.lerobot_export.
LEROBOT_VENV ?= .venv-lerobot
# Empty: .ci/find-python312 looks for a Python 3.12 that runs (a pyenv shim of an unselected
# version does not); PYTHON312=/path/to/python3.12 chooses one.
PYTHON312 ?=
# exported, not pasted into the recipe: a path with quotes or spaces reaches the finder as it is
export PYTHON312
LEROBOT_STAMP := $(LEROBOT_VENV)/.installed-lerobot-0.6.1

lerobot-setup: $(LEROBOT_STAMP)

$(LEROBOT_STAMP):
	@test -x $(LEROBOT_VENV)/bin/python || { py=$$(.ci/find-python312) \
		&& echo "lerobot-setup: $(LEROBOT_VENV) from $$py" && "$$py" -m venv $(LEROBOT_VENV); }
	$(LEROBOT_VENV)/bin/pip install --quiet --progress-bar off 'lerobot[dataset]==0.6.1' h5py
	@touch $@

lerobot-export: lerobot-setup
	@test -n "$(FILE)" -a -n "$(OUT)" || { echo "usage: make lerobot-export FILE=data.hdf5 OUT=folder"; exit 2; }
	PYTHONPATH=src $(LEROBOT_VENV)/bin/python -m icil_paper.interop.lerobot_export "$(FILE)" "$(OUT)"

# ruff, then the import contracts of pyproject.toml ([tool.importlinter]: the layers, no
# import loop between packages, no import of tools/) on this checkout's src/.
lint: setup
	$(BIN)/ruff check src tests notebooks book/_ext tools
	PYTHONPATH=src $(BIN)/lint-imports

clean:
	rm -rf $(BOOK_OUT) .pytest_cache
