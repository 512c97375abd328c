# Set-up is two commands on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin

.PHONY: install demo test test-all bench clean

$(VENV): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test,fast]"
	touch $(VENV)

install: $(VENV)

demo: $(VENV)
	$(BIN)/fsivsp paper --dt 1e-2 --levels 0-3 --json demo/paper.json
	$(BIN)/fsivsp study examples/fluid_over_solid_2d.toml --levels 0-2 --json demo/study.json
	$(BIN)/fsivsp run examples/pressure_wave_2d.toml --out demo/pressure_wave_2d

test: $(VENV)
	$(BIN)/python -m pytest

test-all: $(VENV)
	$(BIN)/python -m pytest -m ""

bench: $(VENV)
	$(BIN)/python benchmarks/scheme_timings.py --levels 0-4 --json benchmarks/scheme_timings.json

clean:
	rm -rf $(VENV) demo .pytest_cache
