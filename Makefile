# The two commands of the README. Each creates its own virtual environment in .venv.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test results install browser clean

$(STAMP): pyproject.toml constraints.txt
	$(PY) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[dev]' -c constraints.txt
	touch $(STAMP)

install: $(STAMP)

# Headless Chromium for the HTML report's browser test (Debian package; needs root or sudo).
browser:
	@command -v chromium >/dev/null 2>&1 || { \
	  if [ "$$(id -u)" = 0 ]; then apt-get update -qq && apt-get install -y -qq chromium >/dev/null; \
	  elif command -v sudo >/dev/null 2>&1; then sudo apt-get update -qq && sudo apt-get install -y -qq chromium >/dev/null; \
	  else echo "chromium missing and no root: the browser test will be skipped"; fi; }

demo: $(STAMP)
	$(BIN)/pathmotion demo --out out/demo

test: $(STAMP) browser
	$(BIN)/lint-imports
	$(BIN)/python -m pytest -q -n 2

# docs/results.md from the benchmarks' JSON tables (benchmarks/results/*.json; each benchmark writes its own with
# --json PATH, e.g. python benchmarks/bench_irb140.py demo --json benchmarks/results/irb140_demo.json).
results:
	$(PY) benchmarks/results.py

clean:
	rm -rf $(VENV) out
