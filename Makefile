# poir-mjx: every target creates the virtual environment it needs.
PYTHON ?= python3.11
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
# JAX's persistent compilation cache: MJX programs take minutes to compile on CPU.
export JAX_COMPILATION_CACHE_DIR ?= $(CURDIR)/.cache/jax
export PYTHONHASHSEED := 0
# The sweep config `make sweep` runs; e.g. make sweep SWEEP=experiments/cpu-small-online.json
SWEEP  ?= experiments/cpu-small.json

.PHONY: help venv envs demos expert-success test test-fast bench-env bench-planner bench-e2e bench sweep sweep-online eval clean

help:
	@echo "make test       - create .venv, export envs if needed, run the test suite"
	@echo "make sweep      - main job on the CPU-sized default (see README)"
	@echo "make envs       - export the robosuite tasks to MJX-ready MJCF under envs/"
	@echo "make demos      - 200 scripted-expert demos per task -> data/demos/<task>.hdf5 (robomimic layout)"
	@echo "make expert-success - the expert's success rate over 100 episodes -> results/expert/"
	@echo "make bench-env  - MJX vs robosuite control-step throughput -> results/bench/env.{json,md}"
	@echo "make bench-planner - POIR planner calls/s -> results/bench/planner.{json,md}"
	@echo "make bench-e2e  - evaluated episodes per minute, EBC and POIR-DRIL -> results/bench/e2e.{json,md}"
	@echo "make bench      - all benchmarks -> results/bench/"
	@echo "make sweep      - success rate vs noise, experiments/cpu-small.json -> results/cpu-small/ (SWEEP=other.json)"
	@echo "make sweep-online - offline vs online fine-tuning, experiments/cpu-small-online.json -> results/cpu-small-online/"
	@echo "make eval CKPT=... - evaluate one checkpoint on a noise grid, print the table"

$(STAMP): pyproject.toml
	@command -v $(PYTHON) >/dev/null || { echo "error: $(PYTHON) not found (Python 3.11 is required)"; exit 1; }
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[test]"
	touch $(STAMP)

venv: $(STAMP)

envs: $(STAMP)
	$(PY) -m poir_mjx.envs.export --out envs

demos: $(STAMP)
	$(PY) -m poir_mjx.data.demos generate --num 200 --out data/demos

expert-success: $(STAMP)
	$(PY) -m poir_mjx.data.demos success --simulator robosuite --episodes 100

test: $(STAMP)
	$(PY) -m poir_mjx.envs.export --out envs --check
	$(PY) -m pytest -q tests

test-fast: $(STAMP)
	$(PY) -m pytest -q -m "not slow" tests

# PickPlaceCan / NutAssemblySquare cost about 1 s per control step per episode on a 2-core CPU:
# override on a GPU, e.g. make bench-env BENCH_ENV_ARGS="--contact-rich-batch-sizes 1 16 64 256 1024".
BENCH_ENV_ARGS ?= --contact-rich-batch-sizes 1 16

bench-env: $(STAMP)
	$(PY) -m poir_mjx.bench.env --out results/bench $(BENCH_ENV_ARGS)

bench-planner: $(STAMP)
	$(PY) -m poir_mjx.bench.planner --out results/bench

bench-e2e: $(STAMP)
	$(PY) -m poir_mjx.bench.e2e --out results/bench

bench: bench-env bench-planner bench-e2e

sweep: $(STAMP)
	$(PY) -m poir_mjx.cli sweep --config $(SWEEP)

sweep-online: $(STAMP)
	$(PY) -m poir_mjx.cli sweep --config experiments/cpu-small-online.json

eval: $(STAMP)
	@test -n "$(CKPT)" || { echo "usage: make eval CKPT=checkpoints/<task>/<file>.ckpt [EVAL_ARGS='--sigma-init 0.02 0.2 --episodes 10']"; exit 2; }
	$(PY) -m poir_mjx.cli eval --ckpt "$(CKPT)" $(EVAL_ARGS)

clean:
	rm -rf $(VENV) .cache .pytest_cache
