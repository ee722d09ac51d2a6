# Two commands do all the set-up on a fresh machine with only python3:
#   make figures   -> creates .venv from environment.txt if needed, regenerates every figure
#   make test      -> same bootstrap, then the whole test suite (notebooks in quick mode)
# Extras: make lab (JupyterLab on notebooks/; extra options in LAB_ARGS, e.g.
#   make lab LAB_ARGS="--no-browser --port 8890"; --allow-root is added when run as root;
#   LAB_DIR=<folder> serves another folder),
#   make html (figures + rendered HTML of the executed notebooks in build/html/),
#   make check (regenerate into build/check and compare with the committed metrics and verdicts),
#   make bench (speed + accuracy benchmark), make lint.
# The browser test (tests/lab/) needs the system Chromium: apt-get install -y chromium.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
KERNEL := vehicle-observers
LAB_ARGS ?=
LAB_DIR  ?= notebooks
ROOT_ARGS := $(if $(filter 0,$(shell id -u 2>/dev/null)),--allow-root)
export PYTHONHASHSEED := 0

.PHONY: figures html check test lab bench lint env clean

# Headless targets draw with Agg; `make lab` does not set it, so its kernels render inline.
figures html check test bench: export MPLBACKEND := Agg

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

html: $(STAMP)
	$(BIN)/python -m vehicle_observers.results.pipeline --figures figures --build build/notebooks --html build/html

check: $(STAMP)
	$(BIN)/python -m vehicle_observers.results.check

test: $(STAMP)
	$(BIN)/python -m pytest -n 2 --dist loadgroup

lab: $(STAMP)
	$(BIN)/jupyter lab --notebook-dir=$(LAB_DIR) $(ROOT_ARGS) $(LAB_ARGS)

bench: $(STAMP)
	$(BIN)/python -m vehicle_observers_papers.benchmark_study
	$(BIN)/python -m vehicle_observers.bench.campaign
	$(BIN)/python -m vehicle_observers.bench.lmi_layer

lint: $(STAMP)
	$(BIN)/ruff check lib tests notebooks

clean:
	rm -rf build .pytest_cache
