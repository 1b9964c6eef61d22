# Two commands set everything up on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test bench clean

$(STAMP): pyproject.toml
	@echo "creating $(VENV) and installing somite with its dependencies into it (about a minute)"
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --progress-bar off -e ".[test]"
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/somite demo --out demo

# --dist loadfile: a file's tests run on one worker, so that module fixtures (a campaign and its
# report, ~40 s each) are built once, not once per worker.
test: $(STAMP)
	@echo "running the test suite on every core (about 10 minutes on 2; the first minutes compile the kernels)"
	$(BIN)/python -m pytest -q -n auto --dist loadfile

bench: $(STAMP)
	$(BIN)/somite bench

clean:
	rm -rf $(VENV) demo
