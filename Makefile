# The two commands of the README: `make demo` and `make test`. Both set up .venv on a fresh machine.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test lint tshark bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[test]'
	touch $(STAMP)

# The ESC's busiest modules compiled with mypyc, again whenever a source changed
# (emulator/esc/compiled.py); without a C compiler everything runs as Python, and says so.
COMPILED := $(VENV)/.compiled
SOURCES := $(shell find emulator skinframes -name '*.py')

$(COMPILED): $(STAMP) $(SOURCES)
	@$(BIN)/python -m emulator.esc.build || true
	@touch $@

demo: $(STAMP) $(COMPILED)
	$(BIN)/skinframes demo --out out

# tshark is Wireshark's judge of every pcap we write; install Debian's package when missing and root.
tshark:
	@if ! command -v tshark >/dev/null 2>&1; then \
	  if [ "$$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then \
	    echo "installing Debian's tshark"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq tshark >/dev/null; \
	  else \
	    echo "WARNING: tshark missing and not root: Wireshark conformance tests will SKIP"; \
	  fi; \
	fi

test: $(STAMP) $(COMPILED) tshark
	$(BIN)/python -m pytest $(PYTEST_ARGS)

lint: $(STAMP)
	$(BIN)/ruff check skinframes emulator skinframes_cli tests benchmarks
	$(BIN)/mypy

bench: $(STAMP)
	$(BIN)/python benchmarks/bench_codecs.py

clean:
	rm -rf $(VENV) out .pytest_cache .mypy_cache .ruff_cache emulator/esc/_compiled
