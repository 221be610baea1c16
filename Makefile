# Two entry points (README quick start): `make report` and `make test`.
# Both prepare the machine first (scripts/setup.sh: system libraries + .venv).
VENV := .venv
BIN := $(VENV)/bin
OUT ?= runs/report

.PHONY: setup report test doctor clean

setup:
	@bash scripts/setup.sh

report: setup
	$(BIN)/volcaustics report --out $(OUT)

test: setup
	@bash scripts/run_tests.sh

doctor: setup
	$(BIN)/volcaustics doctor

clean:
	rm -rf runs test-output .pytest_cache .hypothesis
