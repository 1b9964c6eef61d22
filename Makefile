# Two commands set everything up on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
TEST_STAMP := $(VENV)/.installed-test

DOCS_STAMP := $(VENV)/.installed-docs

.PHONY: demo test bench docs clean

# The demo needs somite and its dependencies only; the tests add their own on top.
$(STAMP): pyproject.toml
	@echo "creating $(VENV) and installing somite with its dependencies into it (1-2 minutes on 2 cores)"
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --progress-bar off -e .
	touch $(STAMP)

$(TEST_STAMP): $(STAMP)
	$(BIN)/pip install --progress-bar off -e ".[test]"
	touch $(TEST_STAMP)

demo: $(STAMP)
	$(BIN)/somite demo --out demo
	@echo "next, the README's tutorial; in each new shell, first:  . $(BIN)/activate"

# --dist loadfile: a file's tests run on one worker, so that module fixtures (a campaign and its
# report, ~40 s each) are built once, not once per worker. --durations: the slowest stay visible.
test: $(TEST_STAMP)
	@echo "running the test suite on every core (5-7 minutes on 2 idle cores, 16-21 beside other work; the first tests compile the kernels)"
	$(BIN)/python -m pytest -q -n auto --dist loadfile --durations=25

$(DOCS_STAMP): $(STAMP)
	$(BIN)/pip install --progress-bar off -e ".[docs]"
	touch $(DOCS_STAMP)

# The user guide (docs/*.md) and the API reference (docs/api.rst) as a site; a warning fails it.
docs: $(DOCS_STAMP)
	$(BIN)/python -m sphinx -W --keep-going -q -b html docs build/docs
	@echo "open build/docs/index.html"

bench: $(STAMP)
	$(BIN)/somite bench

clean:
	rm -rf $(VENV) demo tour build/docs
