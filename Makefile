# Set-up is two commands on a fresh machine: `make demo` and `make test`.
# The venv sees the system's site-packages (Debian's petsc4py, mpi4py and Open MPI: one MPI for NGSolve, PETSc
# and mpi4py), so it is made by the system's Python where there is one.
PYTHON ?= $(shell test -x /usr/bin/python3 && echo /usr/bin/python3 || echo python3)
VENV := .venv
BIN := $(VENV)/bin

.PHONY: install demo lint test test-all bench clean

$(VENV): pyproject.toml tools/install-system.sh
	bash tools/install-system.sh
	$(PYTHON) -m venv --system-site-packages $(VENV)
	ls -d /usr/lib/petscdir/*/*-real/lib/python3/dist-packages /usr/lib/slepcdir/*/*-real/lib/python3/dist-packages \
		2>/dev/null > $$($(BIN)/python -c "import sysconfig; print(sysconfig.get_path('purelib'))")/petsc4py-system.pth
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test,fast]"
	touch $(VENV)

install: $(VENV)

demo: $(VENV)
	$(BIN)/fsivsp paper --dt 1e-2 --levels 0-3 --json demo/paper.json
	$(BIN)/fsivsp study examples/fluid_over_solid_2d.toml --levels 0-2 --json demo/study.json
	$(BIN)/fsivsp run examples/pressure_wave_2d.toml --out demo/pressure_wave_2d
	$(BIN)/fsivsp run examples/artery_2d.toml --out demo/artery_2d
	$(BIN)/fsivsp modes examples/modes_2d.toml --out demo/modes_2d
	$(BIN)/fsivsp harmonic examples/harmonic_3d.toml --out demo/harmonic_3d

# pytest-xdist on every core (tests/conftest.py keeps the MPI and thread tests on one worker, and each run's default
# threads are the cores divided among the workers): 5 min 34 s against 6 min 4 s in one process here (BENCHMARKS.md).
# Lint first (ruff; the layers and no import circles: lint-imports, docs/design.md), then the suite.
lint: $(VENV)
	$(BIN)/ruff check .
	$(BIN)/lint-imports

test: lint
	$(BIN)/python -m pytest -n auto

test-all: lint
	$(BIN)/python -m pytest -n auto -m ""

bench: $(VENV)
	$(BIN)/python benchmarks/scheme_timings.py --levels 0-4 --json benchmarks/scheme_timings.json

clean:
	rm -rf $(VENV) demo .pytest_cache
