# Two commands do everything: `make run` and `make test`.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
PIP := $(VENV)/bin/pip
# Torch: pin the CPU wheel version so pip never resolves the multi-GB CUDA build where a local
# CPU wheel is offered (TORCH_SPEC can be overridden, e.g. TORCH_SPEC=torch on a GPU machine).
TORCH_SPEC ?= torch==2.13.0

.PHONY: run test setup lint format clean gl

$(VENV)/.stamp-setup: pyproject.toml Makefile
	$(PYTHON) -m venv $(VENV)
	$(PIP) install --upgrade pip >/dev/null
	$(PIP) install "$(TORCH_SPEC)"
	$(PIP) install -e ".[dev,distributed]"
	touch $@

setup: $(VENV)/.stamp-setup

# Headless OpenGL (EGL/OSMesa) for rendering; best effort without root.
gl:
	@bash .ci/install-gl.sh || echo "note: could not install GL libraries; rendering tests will skip"

run: setup
	MUJOCO_GL=$${MUJOCO_GL:-egl} $(PY) experiments/quickstart.py

test: setup
	MUJOCO_GL=$${MUJOCO_GL:-egl} MPLBACKEND=Agg $(PY) -m pytest -q

lint: setup
	$(VENV)/bin/ruff check . && $(VENV)/bin/ruff format --check .

format: setup
	$(VENV)/bin/ruff format . && $(VENV)/bin/ruff check --fix .

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache *.egg-info
