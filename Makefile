# Two entry points for a fresh machine with Python 3.11 and pip: `make demo` and `make test`.
# Both create or update .venv themselves.
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: demo test bench bench-top lint clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

$(VENV)/.bench: $(STAMP)
	$(PY) -m pip install --quiet -e '.[test,bench]'
	touch $@

# The main job: an emulated mission with the live dashboard, on embedded defaults.
demo: $(STAMP)
	$(VENV)/bin/cotsfleet run --abort auv2@1200

test: $(STAMP)
	$(PY) -m pytest -q

# Every benchmark; each prints its figures and rewrites its own section of benchmarks/RESULTS.md.
bench: $(VENV)/.bench
	$(PY) -m benchmarks.run_all

clean:
	rm -rf $(VENV) .pytest_cache build *.egg-info
