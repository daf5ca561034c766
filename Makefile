# Two commands for a fresh clone with only python3 (>= 3.11) and make:
#   make run   - create .venv, install, run the insulator-cleaning scenario
#   make test  - create .venv with the test extras, run the test suite
#   make lint  - ruff: the linter and the formatter's check (CI runs it beside the tests)
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: run test lint bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

run: $(STAMP)
	$(BIN)/twin run scenarios/insulator_cleaning.toml --rrd out/insulator_cleaning.rrd --mcap out/insulator_cleaning.mcap

test: $(STAMP)
	$(BIN)/python -m pytest -q

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

bench: $(STAMP)
	$(BIN)/twin bench

clean:
	rm -rf $(VENV) out
