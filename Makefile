# OpenAIR kit — the two promises: `make serve` and `make test`.
# Everything runs from the project's own virtual environment (.venv), created on demand.

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
HOST   ?= 127.0.0.1
PORT   ?= 10000
PYTEST_ARGS ?=

.PHONY: all venv serve test test-python lint typecheck generate check-generated bench fuzz clean

all: test

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

venv: $(STAMP)

## Run the reference whiteboard server on its embedded default configuration.
serve: $(STAMP)
	$(VENV)/bin/openair serve --host $(HOST) --port $(PORT)

## Regenerate the files derived from the spec (error classes, requirements catalogue).
generate: $(STAMP)
	$(PY) tools/gen_errors.py
	$(PY) tools/gen_catalogue.py
	$(PY) tools/gen_frame_vectors.py
	$(PY) tools/gen_message_vectors.py
	$(PY) tools/gen_session_vectors.py

## Fail if a generated file is stale.
check-generated: $(STAMP)
	$(PY) tools/gen_errors.py --check
	$(PY) tools/gen_catalogue.py --check
	$(PY) tools/gen_frame_vectors.py --check
	$(PY) tools/gen_message_vectors.py --check
	$(PY) tools/gen_session_vectors.py --check

lint: $(STAMP)
	$(VENV)/bin/ruff check reference conformance tests tools bench
	$(VENV)/bin/ruff format --check reference conformance tests tools bench

typecheck: $(STAMP)
	$(VENV)/bin/mypy

test-python: $(STAMP)
	$(VENV)/bin/pytest -m "not fuzz" $(PYTEST_ARGS)

## Install what is needed and pass every test.
test: check-generated lint typecheck test-python

## Benchmarks (never part of `make test`).
bench: $(STAMP)
	$(PY) -m bench

## Long fuzzing runs (never part of `make test`).
fuzz: $(STAMP)
	HYPOTHESIS_PROFILE=soak $(VENV)/bin/pytest tests -m fuzz -p no:cacheprovider

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .mypy_cache .ruff_cache .hypothesis
