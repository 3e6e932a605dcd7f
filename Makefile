# twbr: `make demo` runs the main job, `make test` runs every test (both set up everything first).
SHELL := /bin/bash
SCENARIO ?= dynamic_obstacles
N ?= 100
PERTURB ?= 0
RUN := tools/run.sh
# demo, montecarlo and suite check their arguments before anything is set up or built
CHECK := python3 tools/check_args.py

.PHONY: all setup test test-long unit e2e e2e-loaded demo montecarlo suite bench robustness lint clean
all: setup

# `make setup` (or plain `make`) also compiles the kernels when a source changed (tools/bootstrap.sh)
setup:
	@TWBR_WARM=$(if $(filter-out setup all,$(or $(MAKECMDGOALS),all)),$(TWBR_WARM),$(or $(TWBR_WARM),1)) bash tools/bootstrap.sh

# The tests run in two pytest-xdist workers (each draws its ROS_DOMAIN_IDs from its own block,
# test/conftest.py); a test marked `alone` runs with no other end-to-end test beside it. TEST_WORKERS=0 runs
# them in one process (figures: benchmarks/HISTORY.md, eighth session).
TEST_WORKERS ?= 2
test: setup
	@$(RUN) python -m pytest -q -n $(TEST_WORKERS) -m "not long"

test-long: setup
	@$(RUN) python -m pytest -q -n $(TEST_WORKERS) -m long

unit: setup
	@$(RUN) python -m pytest -q -m "not e2e and not long"

e2e: setup
	@$(RUN) python -m pytest -q -n $(TEST_WORKERS) -m "e2e and not long"

# The end-to-end tests with a busy loop on every core beside them (a loaded CI host): they must pass so too.
e2e-loaded: setup
	@TWBR_TEST_BUSY=1 $(RUN) python -m pytest -q -m "e2e and not long"

demo:
	@$(CHECK) --scenario '$(SCENARIO)' --perception '$(PERCEPTION)'
	@bash tools/bootstrap.sh
	@$(RUN) python -m twbr_runner.runner $(SCENARIO) $(if $(SENSORS),--sensors $(SENSORS)) $(if $(DRIVER),--driver $(DRIVER)) $(if $(PERCEPTION),--perception $(PERCEPTION)) $(if $(VIEW),--view)

montecarlo:
	@$(CHECK) --scenario '$(SCENARIO)' --runs '$(N)' --perturb '$(PERTURB)' --perception '$(PERCEPTION)'
	@bash tools/bootstrap.sh
	@$(RUN) python -m twbr_batch.montecarlo $(SCENARIO) -n $(N) --perturb $(PERTURB) $(if $(SENSORS),--sensors $(SENSORS)) $(if $(CONTROLLER),--controller $(CONTROLLER)) $(if $(PERCEPTION),--perception $(PERCEPTION))

SUITE_N ?= 1000
suite:
	@$(CHECK) --runs '$(SUITE_N)' $(if $(SCENARIOS),--scenarios '$(SCENARIOS)')
	@bash tools/bootstrap.sh
	@$(RUN) python -m twbr_batch.suite -n $(SUITE_N) $(if $(SCENARIOS),--scenarios $(SCENARIOS)) $(if $(METHODS),--methods $(METHODS)) $(if $(PERCEPTION),--perception $(PERCEPTION)) $(SUITE_ARGS)

BENCH_OUT ?= benchmarks/results
bench: setup
	@mkdir -p $(BENCH_OUT)
	@$(RUN) python benchmarks/bench_dynamics.py $(BENCH_OUT)/dynamics.json
	@$(RUN) python benchmarks/bench_batch.py --json $(BENCH_OUT)/batch.json
	@$(RUN) python benchmarks/bench_roofline.py --json $(BENCH_OUT)/roofline.json
	@$(RUN) python benchmarks/bench_graph.py --json $(BENCH_OUT)/graph.json
	@$(RUN) python benchmarks/bench_lockstep.py --json $(BENCH_OUT)/lockstep.json
	@$(RUN) python benchmarks/bench_control_loop.py --json $(BENCH_OUT)/control_loop.json
	@$(RUN) python benchmarks/bench_torque.py
	@$(RUN) python benchmarks/bench_viewer.py --json $(BENCH_OUT)/viewer.json
	@$(RUN) python benchmarks/bench_metrics.py --json $(BENCH_OUT)/metrics.json
	@$(RUN) python benchmarks/bench_startup.py --json $(BENCH_OUT)/startup.json
	@$(RUN) python benchmarks/bench_planner.py --json $(BENCH_OUT)/planner.json
	@$(RUN) python benchmarks/compare_engines.py --json $(BENCH_OUT)/engines.json
	@$(RUN) python benchmarks/study_paper_runs.py --json $(BENCH_OUT)/paper_runs.json
	@$(RUN) python benchmarks/bench_first_run.py --json $(BENCH_OUT)/first_run.json
	@$(RUN) python benchmarks/figures.py --write

# Issue 17's robustness table (pid and lqr, ideal and realistic sensors, nominal / ±20 / ±40 % robots)
ROBUST_N ?= 1000
robustness: setup
	@$(RUN) python benchmarks/study_robustness.py -n $(ROBUST_N)

lint: setup
	@$(RUN) ruff check src test tools benchmarks

clean:
	rm -rf build install log
