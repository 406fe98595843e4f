# Two entry points for a fresh machine with Python 3.11 and pip: `make demo` and `make test`.
# Both create or update .venv themselves, each installing only what it needs: the demo the
# package and its run-time dependencies, the tests also pytest and Playwright (test extra) and
# rclpy with the standard ROS 2 interfaces from PyPI (ros2 extra: the ROS 2 helm's tests and
# the --helm ros2 mission run rather than skip), the benchmarks also the reference solvers
# (bench extra).
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
BASE   := $(VENV)/.installed
TESTS  := $(VENV)/.installed-test
BENCH  := $(VENV)/.installed-bench

.PHONY: demo test lint bench clean

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip

# Re-run whenever pyproject.toml changes (new dependencies); the extras follow, being newer.
$(BASE): pyproject.toml | $(PY)
	$(PY) -m pip install --quiet -e .
	touch $@

$(TESTS): $(BASE)
	$(PY) -m pip install --quiet -e '.[test,ros2]'
	touch $@

$(BENCH): $(BASE)
	$(PY) -m pip install --quiet -e '.[bench]'
	touch $@

# The main job: a dynamic mission (the map is a prior, the fleet finds the reef) emulated with
# the live dashboard and an abort; each run in a fresh directory under runs/ (its scenario,
# journals, logs and report).
demo: $(BASE)
	@dir=runs/demo-$$(date +%Y%m%d-%H%M%S) && mkdir -p $$dir && \
	$(VENV)/bin/cotsfleet scenario --paper --dynamic --seed 0 -o $$dir/dyn.json && \
	$(VENV)/bin/cotsfleet run --scenario $$dir/dyn.json --run-dir $$dir --abort auv2@1200

# The linters first (configured in pyproject.toml): a style or type error fails the run early.
# Two workers (pytest-xdist), a test file at a time: a file's tests share its fixtures (one
# mission per integration module), and a warp-paced mission mostly waits on its clock, so the
# other worker has the CPU. (Not --dist loadgroup: with pytest 9, xdist 3.8 cannot group.)
# Files go out in the suite's order, the long ones first (tests/conftest.py), not xdist's
# order by test count, which sent a 7-minute file out among the last.
# The browser test runs after, alone: it measures the web viewer's latency, which beside
# another worker's mission measured the shared machine instead (9.1 s and 5.7 s against its
# 5 s limit in 2 of 4 full runs of stop 52; it passed alone every time).
test: lint
	$(PY) -m pytest -q -n 2 --dist loadfile --no-loadscope-reorder -m "not browser"
	$(PY) -m pytest -q -m browser

lint: $(TESTS)
	$(PY) -m ruff check .
	$(PY) -m mypy


# Every benchmark; each prints its figures and rewrites its own section of benchmarks/RESULTS.md.
bench: $(BENCH)
	$(PY) -m benchmarks.run_all

clean:
	rm -rf $(VENV) .pytest_cache build *.egg-info
