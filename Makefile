# Two commands do all set-up on a fresh machine (see README.md):
#   make demo   - install into .venv, then run the main job
#   make test   - install into .venv (with dev tools), then lint and run the tests
# TORCH is installed first so pip does not pull a multi-GB CUDA build where a CPU one is wanted;
# override it for your machine, e.g. `make test TORCH=torch`.
PYTHON ?= python3
TORCH ?= torch==2.13.0
VENV ?= .venv
BIN := $(VENV)/bin

.PHONY: demo test install lint

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip

install: $(BIN)/python
	$(BIN)/pip install --quiet "$(TORCH)"
	$(BIN)/pip install --quiet -e ".[dev]"

demo: install
	$(BIN)/tangle-drake demo --picks 5

lint: install
	$(BIN)/ruff check .

test: lint
	$(BIN)/python -m pytest -q
