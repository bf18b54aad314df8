# Two commands do everything: `make run` and `make test`.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
PIP := $(VENV)/bin/pip
# Torch: pin the CPU wheel version so pip never resolves the multi-GB CUDA build where a local
# CPU wheel is offered (TORCH_SPEC can be overridden, e.g. TORCH_SPEC=torch on a GPU machine).
TORCH_SPEC ?= torch==2.13.0
# Headless rendering backend on Linux (EGL); other systems keep MuJoCo's default.
GL_ENV := $(if $(filter Linux,$(shell uname -s)),MUJOCO_GL=$${MUJOCO_GL:-egl},)

.PHONY: help test-soak run test setup gpu lab lint format clean gl docs docs-serve
# `make` alone lists the targets (it used to set up .venv and say only "is up to date")
.DEFAULT_GOAL := help

# The GPU extra (MuJoCo Warp, ~0.4 GB: `--executor gpu`, docs/gpu.md) is installed only where
# it can be used or is asked for: GPU=1 (make setup GPU=1, or make gpu), or by default where
# `nvidia-smi -L` finds a GPU, or where it was installed before (.venv/.stamp-gpu); GPU=0 skips
# it. CI asks for it (.ci/run): its Warp tests run on Warp's CPU device. Without it those tests
# skip and say why.
ifeq ($(origin GPU),undefined)
GPU := $(if $(wildcard $(VENV)/.stamp-gpu),1,$(shell nvidia-smi -L >/dev/null 2>&1 && echo 1))
endif
WITH_GPU := $(filter 1 yes true,$(GPU))

# pip's output (hundreds of lines) goes to a log named in one line; a failed step prints the
# end of the log and stops.
SETUP_LOG := $(VENV)/setup.log
LOGGED = >>$(SETUP_LOG) 2>&1 || { tail -n 40 $(SETUP_LOG); echo "setup failed: see $(SETUP_LOG)"; exit 1; }

$(VENV)/.stamp-setup: pyproject.toml Makefile
	@echo "setting up $(VENV): ariel and its dependencies$(if $(WITH_GPU),, for the CPU (the GPU extra: make gpu)) (about 3 minutes; pip's log: $(SETUP_LOG))"
	@$(PYTHON) -m venv $(VENV)
	@: >$(SETUP_LOG)
	@$(PIP) install --upgrade pip $(LOGGED)
	@$(PIP) install "$(TORCH_SPEC)" $(LOGGED)
	@$(PIP) install -e ".[dev,distributed,analysis,docs]" $(LOGGED)
	@touch $@

# The GPU extra on top of the CPU setup (mujoco-warp, warp-lang).
$(VENV)/.stamp-gpu: $(VENV)/.stamp-setup
	@echo "installing the GPU extra into $(VENV): mujoco-warp, warp-lang (pip's log: $(SETUP_LOG))"
	@$(PIP) install -e ".[gpu]" $(LOGGED)
	@touch $@

help:
	@echo "make run        set up .venv (first time, about 3 minutes), then run the default experiment"
	@echo "make test       set up, then run the tests (make test-soak: the long ones)"
	@echo "make setup      only set up .venv (GPU=1: with the GPU extra; make gpu adds it later)"
	@echo "make lab        JupyterLab on the analysis/ notebooks"
	@echo "make docs       build the docs site into site/ (make docs-serve: a live preview)"
	@echo "make lint       ruff, the import layers and pyright; make format fixes what it can"
	@echo "make clean      remove .venv and the caches"

setup: $(VENV)/.stamp-setup $(if $(WITH_GPU),$(VENV)/.stamp-gpu)

gpu:
	@$(MAKE) --no-print-directory setup GPU=1

# JupyterLab on the analysis/ notebooks (installed into .venv on first use; the default setup
# has what runs them headless: nbconvert, ipykernel). make lab ARIEL_RUN_DIR=data/runs/<id>
# opens them on that run.
lab: setup
	@$(PY) -c "import jupyterlab" 2>/dev/null || { echo "installing JupyterLab into $(VENV) (pip's log: $(SETUP_LOG))"; $(PIP) install jupyterlab $(LOGGED); }
	$(VENV)/bin/jupyter lab analysis/ $(if $(filter 0,$(shell id -u)),--allow-root)

# Headless OpenGL (EGL/OSMesa) for rendering, installed with apt where we may (root or
# passwordless sudo); otherwise a note, and rendering tests skip saying why.
gl:
	@bash .ci/install-gl.sh || echo "note: GL libraries not installed; rendering will be unavailable"

# The main job: the default co-evolution experiment (experiments/coevolve_flat.toml) into
# data/runs/<run-id>/. Pass options through ARGS, e.g. make run ARGS="--set generations=20".
run: setup gl
	$(GL_ENV) $(PY) -m ariel.cli run $(ARGS)

test: setup gl
	$(GL_ENV) MPLBACKEND=Agg $(PY) -m pytest -q

# The soak tests `make test` leaves out (pytest's "soak" marker: runs killed again and again,
# the benchmarks' smoke runs, headless-browser views, slower signal variants); CI runs them
# after `make test`.
test-soak: setup gl
	$(GL_ENV) MPLBACKEND=Agg $(PY) -m pytest -q -m soak

# The docs site (mkdocs.yml) into site/, warnings as errors (a broken link, a missing reference
# or an API name mkdocstrings cannot resolve fails it). It runs the tutorials and the analysis
# notebooks, on a small run and campaign it makes first under .cache/docs/ (a few minutes the
# first time; reused after). Open site/index.html, or `make docs-serve` for a live preview.
# No MPLBACKEND: the notebooks' kernels then draw inline (Agg made plt.show() draw nothing).
DOCS_ENV := $(GL_ENV) NO_MKDOCS_2_WARNING=1
docs: setup gl
	$(DOCS_ENV) $(VENV)/bin/mkdocs build --strict
	@echo "the site is in site/: open site/index.html, or run make docs-serve"

docs-serve: setup gl
	$(DOCS_ENV) $(VENV)/bin/mkdocs serve --strict

# ruff, then the layering of the package (import-linter: [tool.importlinter] in pyproject.toml),
# its types (pyright: [tool.pyright]) and its faces (tests/test_public_imports.py: no package
# imports another's private parts).
lint: setup
	$(VENV)/bin/ruff check . && $(VENV)/bin/ruff format --check . && $(VENV)/bin/lint-imports
	$(VENV)/bin/pyright
	$(PY) -m pytest -q -p no:cacheprovider tests/test_public_imports.py

format: setup
	$(VENV)/bin/ruff format . && $(VENV)/bin/ruff check --fix .

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache .import_linter_cache *.egg-info site .cache/docs .cache/mkdocs-jupyter
