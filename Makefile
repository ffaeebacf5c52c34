# poir-mjx: every target creates the virtual environment it needs; every Python command goes through the one
# command line, python -m poir_mjx.cli <subcommand> (--help lists its flags).
#
# Two locked dependency sets (README "Dependencies"); STACK picks one for any target:
#   STACK=cpu      .venv          Python 3.11, jax 0.7.0, mujoco 3.3.7, robosuite (default: fastest MJX on a CPU)
#   STACK=current  .venv-current  Python 3.12+, jax 0.11.2, mujoco 3.17.0, numpy 2, no robosuite
#   STACK=gpu      .venv-gpu      the current set plus jax's CUDA plugin (CUDA=cuda13, or cuda12)
#   STACK=warp     .venv-warp     the current set plus warp-lang (physics "warp": MuJoCo Warp behind MJX's API)
STACK  ?= cpu
CUDA   ?= cuda13
# The first interpreter of at least the given version: plain names, then pyenv's folders.
find_python = $(firstword $(foreach p,$(1) $(wildcard $(HOME)/.pyenv/versions/$(2)*/bin/python$(2)),$(shell $(p) -c 'import sys; sys.exit(sys.version_info < ($(subst .,$(comma),$(2))))' >/dev/null 2>&1 && echo $(p))))
comma := ,
ifeq ($(STACK),cpu)
  PYTHON ?= $(call find_python,python3.11,3.11)
  VENV   := .venv
  LOCKS  := requirements/cpu.txt
else ifeq ($(STACK),current)
  PYTHON ?= $(call find_python,python3.12 python3.13,3.12)
  VENV   := .venv-current
  LOCKS  := requirements/current.txt
  # jax 0.11.2 segfaulted writing a CPU executable to the persistent cache (tests/eval, once): off on the CPU.
  export JAX_ENABLE_COMPILATION_CACHE ?= false
else ifeq ($(STACK),gpu)
  PYTHON ?= $(call find_python,python3.12 python3.13,3.12)
  VENV   := .venv-gpu
  LOCKS  := requirements/current.txt requirements/$(CUDA).txt
else ifeq ($(STACK),warp)
  PYTHON ?= $(call find_python,python3.12 python3.13,3.12)
  VENV   := .venv-warp
  LOCKS  := requirements/current.txt requirements/warp.txt
  export JAX_ENABLE_COMPILATION_CACHE ?= false
else
  $(error STACK must be cpu, current, gpu or warp, got '$(STACK)')
endif
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
# JAX's persistent compilation cache (one per stack: programs differ): MJX compiles for minutes on a CPU. It lives
# in the user's cache folder, not the clone, so every clone on a machine (a CI run's fresh one included) reuses the
# programs any of them compiled; a cache entry is keyed by the program and jax's version, so it never changes a result.
CACHE_HOME ?= $(or $(XDG_CACHE_HOME),$(HOME)/.cache)/poir-mjx
export JAX_COMPILATION_CACHE_DIR ?= $(CACHE_HOME)/jax-$(STACK)
export PYTHONHASHSEED := 0
# The sweep config `make sweep` runs; e.g. make sweep SWEEP=experiments/cpu-small-online.json
SWEEP  ?= experiments/cpu-small.json
# Extra flags for make sweep / sweep-online, e.g. SWEEP_ARGS='--planner.sigma 0.1 --replace-config' (any POIR field).
SWEEP_ARGS ?=
# Where make sweep / sweep-online put their run folder: a published run (results/<name>/ whose config.json git tracks)
# is read-only for every command, so rerunning a published config goes to results/local/<name>/ (ignored by git).
RESULTS ?= results/local
# Where `make demos` records the scripted expert: robosuite (MuJoCo C) or mjx (vectorised, no robosuite).
DEMO_SIM ?= robosuite
# How the expert acts in `make demos`: scripted, or human_like (an operator's variability; -> <task>[-mjx]-human.hdf5).
DEMO_STYLE ?= scripted
# Extra flags for make demos, e.g. DEMO_ARGS='--tasks lift'.
DEMO_ARGS ?=

.PHONY: help venv venv-current venv-warp envs demos expert-success diagnose test test-cpu test-current test-current-check test-current-core test-warp test-fast warp-parts warp-install bench-env bench-planner bench-e2e bench-robosuite bench-l2 bench sweep sweep-online eval xsim video ablations prior-study report wheels gpu-check gpu-carry gpu-demos clean

help:
	@echo "make test       - both dependency sets: the full suite on the CPU set, the current-stack suite (CI runs this)"
	@echo "make test-cpu   - the full suite in .venv (Python 3.11, jax 0.7.0, robosuite)"
	@echo "make test-current - the suite in .venv-current (Python 3.12, jax 0.11.2, numpy 2, no robosuite; robosuite tests skipped)"
	@echo "make test-warp  - MuJoCo Warp as the physics (physics \"warp\") on the CPU, in .venv-warp (the current set plus warp-lang)"
	@echo "make wheels     - download the current set's wheels (+ CUDA plugin) to wheels/ for a machine with no network"
	@echo "any target with STACK=current or STACK=gpu uses that set, e.g. make sweep STACK=gpu SWEEP=experiments/paper.json"
	@echo "make sweep      - main job on the CPU-sized default (see README)"
	@echo "make envs       - export the robosuite tasks to MJX-ready MJCF under envs/"
	@echo "make demos      - 200 scripted-expert demos per task -> data/demos/<task>.hdf5 (robomimic layout; DEMO_SIM=mjx: <task>-mjx.hdf5)"
	@echo "make expert-success - the expert's success rate over 100 episodes -> results/expert/"
	@echo "make bench-env  - MJX vs robosuite control-step throughput -> results/bench/env-<STACK>.{json,md}; physics presets side by side -> physics-<STACK>.{json,md}"
	@echo "make bench-planner - POIR planner calls/s -> results/bench/planner.{json,md}"
	@echo "make bench-l2   - the L2 reward's nearest-expert search, full scan vs shortlist, in a run's planner -> results/bench/l2-search.{json,md}"
	@echo "make bench-e2e  - evaluated episodes per minute, EBC and POIR-DRIL -> results/bench/e2e.{json,md}"
	@echo "make bench-robosuite - robosuite bare stepping vs EBC / POIR-DRIL collection -> results/bench/robosuite-e2e.{json,md}"
	@echo "make bench      - all benchmarks -> results/bench/"
	@echo "make sweep      - success rate vs noise, experiments/cpu-small.json -> results/cpu-small/ (SWEEP=other.json)"
	@echo "make sweep-online - offline vs online fine-tuning, experiments/cpu-small-online.json -> results/cpu-small-online/"
	@echo "make eval CKPT=... - evaluate one checkpoint on a noise grid, print the table (EVAL_ARGS='--simulator robosuite --out F')"
	@echo "make xsim CKPT=... - the same checkpoint in MJX and in robosuite side by side, Fisher exact test per cell"
	@echo "make video      - a sweep cell's episodes re-run in MJX, drawn offscreen -> results/videos/*.mp4 (VIDEO_ARGS='--run ... --method ...')"
	@echo "make ablations  - POIR-DRIL planner/normaliser ablations on Lift in robosuite (experiments/ablations/) -> results/ablations.md"
	@echo "make diagnose   - planner forensics with the robosuite oracle -> results/diagnose/<run>/ (DIAGNOSE_ARGS='--run ...')"
	@echo "make report     - results/README.md from each published run's own files (config, notes.md, tables, plots)"

$(STAMP): pyproject.toml $(LOCKS)
	@test -n "$(PYTHON)" || { echo "error: no Python interpreter for STACK=$(STACK) (cpu: 3.11; current/gpu: 3.12 or newer); set PYTHON=/path/to/python"; exit 2; }
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet $(addprefix -r ,$(LOCKS))
	$(PY) -m pip install --quiet --no-deps -e .
	touch $(STAMP)

venv: $(STAMP)

envs: $(STAMP)
	$(PY) -m poir_mjx.cli envs --out envs

demos: $(STAMP)
	$(PY) -m poir_mjx.cli demos generate --out data/demos --simulator $(DEMO_SIM) --demo-style $(DEMO_STYLE) $(DEMO_ARGS)

expert-success: $(STAMP)
	$(PY) -m poir_mjx.cli demos success --simulator robosuite --episodes 100

# CI (.ci/run) runs exactly this: the CPU set's suite (both cores), then the current set's two pytest processes and
# MuJoCo Warp's tests, two at a time (each keeps one core busy; --output-sync keeps each one's output in one piece).
test:
	$(MAKE) test-cpu
	$(MAKE) -j2 --output-sync=target test-current test-warp

# The CPU set's suite runs in TEST_WORKERS pytest-xdist processes (a test file stays in one, so its module fixtures
# and compiled programs are shared): one pytest process keeps one core busy (compiling XLA programs most of its time),
# so two use a 2-core machine's second. The longest files start first (tests/conftest.py, LONGEST_FIRST; xdist's own
# reorder, by test count, is off) so the two finish together. Each holds its own programs: with a cold compilation
# cache the workers peaked at 9.0 and 8.6 GB (docs/reliability.md, class 9); TEST_WORKERS=1 runs one process.
TEST_WORKERS ?= 2
test-cpu:
	$(MAKE) STACK=cpu venv
	.venv/bin/python -m poir_mjx.cli envs --out envs --check
	JAX_COMPILATION_CACHE_DIR=$(CACHE_HOME)/jax-cpu .venv/bin/python -m pytest -q --durations=15 \
	  -n $(TEST_WORKERS) --dist loadfile --no-loadscope-reorder tests

# The current set (the GPU machine's jax) has no robosuite; on a CPU its MJX is slow (a PickPlaceCan step takes
# about 15 s at batch 2). It runs what only it can show: the GPU check's dry run (every stage of the prepared GPU
# run: Lift's MJX reset and step, the planner, MJX demos, training, the e2e evaluation and a tiny sweep) and the
# POIR core, rollout and online tests; the CPU set runs every test. One pytest process per group, so one jax CPU
# crash names its test (-v, no faulthandler dump burying it) and state does not pile up.
# One target per group: `make -j2 test-current` runs them side by side; the venv is made once, before either.
test-current: test-current-check test-current-core
test-current-check: PYTEST_ARGS = -m current_stack tests/test_gpu_check.py
test-current-core: PYTEST_ARGS = -m 'not slow' tests/core tests/rollout tests/online tests/test_layers.py
test-current-check test-current-core: venv-current
	JAX_ENABLE_COMPILATION_CACHE=false .venv-current/bin/python -m pytest -v -p no:faulthandler --durations=10 \
	  $(PYTEST_ARGS)

venv-current:
	$(MAKE) STACK=current venv

# MuJoCo Warp (physics "warp") on the CPU: Warp compiles its CPU kernels once per machine (about a minute, cached in
# ~/.cache/warp), then the Lift tests step it against MJX's JAX pipeline at batch 2-3 (tests/envs/test_warp.py).
test-warp: venv-warp
	JAX_ENABLE_COMPILATION_CACHE=false .venv-warp/bin/python -m pytest -v -p no:faulthandler --durations=5 \
	  -m "needs_warp or not slow" tests/envs/test_warp.py tests/envs/test_physics.py tests/sweep/test_config_and_stats.py

venv-warp:
	$(MAKE) STACK=warp venv

test-fast: $(STAMP)
	$(PY) -m pytest -q -m "not slow" tests

# PickPlaceCan / NutAssemblySquare cost about 1 s per control step per episode on a 2-core CPU:
# override on a GPU, e.g. make bench-env BENCH_ENV_ARGS="--contact-rich-batch-sizes 1 16 64 256 1024".
BENCH_ENV_ARGS ?= --contact-rich-batch-sizes 1 16
# The physics presets side by side (ms per substep at batch 1/16/64, Lift; 1/16 the others; error against robosuite).
BENCH_PHYSICS_ARGS ?=

bench-env: $(STAMP)
	$(PY) -m poir_mjx.cli bench env --out results/bench --name env-$(STACK) $(BENCH_ENV_ARGS)
	$(PY) -m poir_mjx.cli bench physics --out results/bench --name physics-$(STACK) $(BENCH_PHYSICS_ARGS)

bench-planner: $(STAMP)
	$(PY) -m poir_mjx.cli bench planner --out results/bench

# The L2 reward's exact search, full scan against shortlist, in a run's POIR-L2 planner (needs the run's agent).
BENCH_L2_ARGS ?=
bench-l2: $(STAMP)
	$(PY) -m poir_mjx.cli bench l2 --out results/bench $(BENCH_L2_ARGS)

bench-e2e: $(STAMP)
	$(PY) -m poir_mjx.cli bench e2e --out results/bench

# robosuite's bare stepping next to EBC / POIR-DRIL collection (plain and overlapped), one worker per core.
bench-robosuite: $(STAMP)
	$(PY) -m poir_mjx.cli bench robosuite --out results/bench

bench: bench-env bench-planner bench-e2e bench-robosuite

sweep: $(STAMP)
	$(PY) -m poir_mjx.cli sweep --config $(SWEEP) --results $(RESULTS) $(SWEEP_ARGS)

sweep-online: $(STAMP)
	$(PY) -m poir_mjx.cli sweep --config experiments/cpu-small-online.json --results $(RESULTS) $(SWEEP_ARGS)

eval: $(STAMP)
	@test -n "$(CKPT)" || { echo "usage: make eval CKPT=checkpoints/<task>/<file>.ckpt [EVAL_ARGS='--sigma-init 0.02 0.2 --episodes 10']"; exit 2; }
	$(PY) -m poir_mjx.cli eval --ckpt "$(CKPT)" $(EVAL_ARGS)

# cpu-ablate-demos-si0.3 trains on scripted demos recorded at sigma_init 0.3 (wider coverage than make demos' 0.02).
ablations: $(STAMP)
	$(PY) -m poir_mjx.cli demos generate --tasks lift --sigma-init 0.3 --out data/demos-si0.3
	for f in experiments/ablations/*.json; do $(PY) -m poir_mjx.cli sweep --config $$f || exit $$?; done
	$(PY) -m poir_mjx.cli compare results/cpu-ablate-* --out results/ablations.md

# The prior study (docs/results-prior.md): the BC prior's training space alone on both demo sets, the grids with the
# controls, the 'excess' rewards; then one table of the prior runs -> results/prior-choice.md.
PRIOR_RUNS = experiments/prior/cpu-prior-normalized.json experiments/prior/cpu-prior-weighted.json \
	experiments/prior/cpu-prior-raw.json experiments/prior/cpu-prior-normalized-wide-demos.json \
	experiments/prior/cpu-prior-weighted-wide-demos.json experiments/prior/cpu-prior-raw-wide-demos.json
prior-study: $(STAMP)
	$(PY) -m poir_mjx.cli demos generate --tasks lift --sigma-init 0.3 --out data/demos-si0.3
	for f in $(PRIOR_RUNS) experiments/cpu-prior-wide-demos.json experiments/cpu-prior.json \
	  experiments/prior/cpu-prior-excess-wide-demos.json experiments/prior/cpu-prior-excess.json; do \
	  $(PY) -m poir_mjx.cli sweep --config $$f || exit $$?; done
	$(PY) -m poir_mjx.cli compare $(patsubst experiments/prior/%.json,results/%,$(PRIOR_RUNS)) --out results/prior-choice.md

# The index of the published runs, from their own files (commit it with the runs; a test checks it is current).
report: $(STAMP)
	$(PY) -m poir_mjx.cli report --results results

xsim: $(STAMP)
	@test -n "$(CKPT)" || { echo "usage: make xsim CKPT=checkpoints/<task>/<file>.ckpt [EVAL_ARGS='--sigma-init 0.02 0.2 --episodes 20']"; exit 2; }
	$(PY) -m poir_mjx.cli eval --ckpt "$(CKPT)" --simulator both $(EVAL_ARGS)

# Episodes of a sweep cell re-run in MJX and drawn offscreen (EGL) to an MP4; the flags are VideoConfig's
# fields (python -m poir_mjx.cli video --help). The default: `make sweep`'s run, EBC and POIR-DRIL side by side.
VIDEO_ARGS ?= --run results/cpu-small --method EBC --versus POIR-DRIL --sigma-init 0.4 --episodes 0

video: $(STAMP)
	$(PY) -m poir_mjx.cli video $(VIDEO_ARGS)

# Planner forensics with the robosuite oracle on a run's cells -> results/diagnose/<run>/<task>.md (docs/diagnose.md)
DIAGNOSE_ARGS ?= --run results/cpu-prior --sigma-init 0.02 0.3 --episodes 0 1 2 3 --every 20
diagnose: $(STAMP)
	$(PY) -m poir_mjx.cli diagnose $(DIAGNOSE_ARGS)

# Wheels of the current set (and CUDA=cuda13 plugin) for an x86-64 Linux machine with no network:
# copy wheels/ there, then: pip install --no-index --find-links wheels -r requirements/current.txt -r requirements/cuda13.txt
wheels:
	python3 -m pip download --quiet --only-binary=:all: --python-version 3.12 --implementation cp \
	  --platform manylinux_2_28_x86_64 --platform manylinux_2_27_x86_64 --platform manylinux_2_17_x86_64 \
	  --platform manylinux2014_x86_64 --platform manylinux1_x86_64 --platform any \
	  -d wheels -r requirements/current.txt $(if $(NO_CUDA),,-r requirements/$(CUDA).txt) "setuptools>=68"

# The prepared GPU run (docs/gpu.md): the machine's own python3 and packages plus the wheels carried in .whl/
# (make gpu-carry), nothing installed from a network, no virtual environment. On a lent machine:
# make gpu-check GPU_OUT=$$OUT; here, the same stages at tiny sizes: make gpu-check GPU_CHECK_ARGS=--dry-run.
GPU_PYTHON     ?= python3
GPU_SITE       ?= /tmp/poir-mjx-site
GPU_OUT        ?= results/gpu
GPU_CHECK_ARGS ?=
GPU_ENV = PYTHONPATH=$(CURDIR):$(GPU_SITE) JAX_COMPILATION_CACHE_DIR=$(CURDIR)/.cache/jax-gpu MUJOCO_GL=disable

gpu-check:
	@if ls .whl/*.whl >/dev/null 2>&1; then $(GPU_PYTHON) -m pip install -q --no-index --no-deps --no-compile \
	  --no-cache-dir --upgrade --target $(GPU_SITE) .whl/*.whl; fi
	$(GPU_ENV) $(GPU_PYTHON) -m poir_mjx.gpucheck.preflight
	$(GPU_ENV) $(GPU_PYTHON) -m poir_mjx.cli gpu-check --out $(GPU_OUT) $(GPU_CHECK_ARGS)

# What the lent GPU machine lacks (its image has jax 0.11.2, flax, optax, numpy 2, h5py, scipy, matplotlib,
# tqdm, absl-py, etils): MuJoCo, MJX and what they and the command line import, as wheels in .whl/ (< 64 MiB).
GPU_CARRY_PINS = mujoco==3.17.0 mujoco-mjx==3.17.0 trimesh==5.2.0 glfw==2.11.0 PyOpenGL==3.1.10 \
	tyro==1.0.16 typeguard==4.6.1 docstring_parser==0.18.0
gpu-carry:
	rm -rf .whl && python3 -m pip download --quiet --no-deps --only-binary=:all: --python-version 3.12 \
	  --implementation cp --platform manylinux_2_28_x86_64 --platform manylinux_2_27_x86_64 \
	  --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64 --platform any -d .whl $(GPU_CARRY_PINS)
	@du -sh .whl && ls .whl
	$(MAKE) gpu-demos

# MuJoCo Warp on a lent GPU (physics "warp"; the GPU check's last stage): warp-lang's wheel (149 MB) is more than
# one device call carries (64 MiB), so make warp-parts cuts it here into parts of 48 MiB with their digests, each
# carried by one call to a warm machine; the last call runs make warp-install there (docs/gpu.md, "MuJoCo Warp").
WARP_PARTS ?= .warp-parts
WARP_PIN   ?= warp-lang==1.18.0
warp-parts:
	rm -rf $(WARP_PARTS) && mkdir -p $(WARP_PARTS)/wheel
	python3 -m pip download --quiet --no-deps --only-binary=:all: --python-version 3.12 --implementation cp \
	  --platform manylinux_2_28_x86_64 --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64 \
	  -d $(WARP_PARTS)/wheel $(WARP_PIN)
	cd $(WARP_PARTS) && whl=$$(ls wheel/*.whl) && basename $$whl > WHEEL && split -b 48M -d $$whl part- && \
	  sha256sum $$whl | sed "s| wheel/| /tmp/|" > SHA256 && ls part-* | wc -l > PARTS && rm -r wheel
	@ls -l $(WARP_PARTS)

# On the lent machine, after every part was carried: join, check the digest, install beside the carried MuJoCo.
warp-install:
	@test -f $(WARP_PARTS)/WHEEL -a -f $(WARP_PARTS)/SHA256 -a -f $(WARP_PARTS)/PARTS || \
	  { echo "$(WARP_PARTS): WHEEL, SHA256 or PARTS missing (carry them with any part)"; exit 2; }
	@n=$$(ls $(WARP_PARTS)/part-* 2>/dev/null | wc -l); test "$$n" = "$$(cat $(WARP_PARTS)/PARTS)" || \
	  { echo "$(WARP_PARTS): $$n of $$(cat $(WARP_PARTS)/PARTS) parts here (carry the rest, one call each)"; exit 2; }
	cat $(WARP_PARTS)/part-* > /tmp/$$(cat $(WARP_PARTS)/WHEEL) && sha256sum -c $(WARP_PARTS)/SHA256
	$(GPU_PYTHON) -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target $(GPU_SITE) \
	  /tmp/$$(cat $(WARP_PARTS)/WHEEL)
	$(GPU_ENV) $(GPU_PYTHON) -c "from poir_mjx.optional import warp_installed; assert warp_installed(); print('MuJoCo Warp: ready')"

# The demos the GPU check trains on, recorded here (robosuite, make demos) and carried as compact copies (the same
# transitions and digest, about a sixth of the size): .gpu-demos/lift.hdf5 and pick_place_can.hdf5.
GPU_DEMO_TASKS ?= lift pick_place_can
gpu-demos: $(STAMP)
	$(PY) -m poir_mjx.cli demos generate --tasks $(GPU_DEMO_TASKS) --out data/demos
	$(PY) -m poir_mjx.cli demos compact --data $(foreach t,$(GPU_DEMO_TASKS),data/demos/$(t).hdf5) --out .gpu-demos
	@du -sh .gpu-demos

clean:
	rm -rf .venv .venv-current .venv-gpu .cache .pytest_cache $(CACHE_HOME)
