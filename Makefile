# Two commands do all the set-up on a fresh machine with only python3:
#   make figures   -> creates .venv from environment.txt if needed, regenerates every figure
#   make test      -> same bootstrap, then the whole test suite (notebooks in quick mode)
# Extras: make lab (JupyterLab on notebooks/), make bench (speed + accuracy benchmark), make lint.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
KERNEL := vehicle-observers
export MPLBACKEND := Agg
export PYTHONHASHSEED := 0

.PHONY: figures test lab bench lint env clean

env: $(STAMP)

$(STAMP): environment.txt pyproject.toml
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -r environment.txt
	$(BIN)/python -m pip install --quiet --no-deps -e .
	$(BIN)/python -m ipykernel install --sys-prefix --name $(KERNEL) --display-name "Python (vehicle-observers)" >/dev/null
	@touch $(STAMP)

figures: $(STAMP)
	$(BIN)/python -m vehicle_observers.results.pipeline --figures figures --build build/notebooks

test: $(STAMP)
	$(BIN)/python -m pytest -n 2 --dist loadgroup

lab: $(STAMP)
	$(BIN)/jupyter lab --notebook-dir=notebooks

bench: $(STAMP)
	$(BIN)/python -m vehicle_observers.bench

lint: $(STAMP)
	$(BIN)/ruff check lib tests notebooks

clean:
	rm -rf build .pytest_cache
