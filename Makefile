# The two commands the README opens with: `make demo` and `make test`.
# Both create or refresh the virtual environment first, so a fresh clone on a
# machine with only Python, pip and gcc needs nothing else.

PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp

.PHONY: demo test lint typecheck unit bench bench-fleet bench-fleet-1000 broker clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

# The main job: the mock fleet (PX4 personality) and the service, a convoy moving on a
# straight road, 1200 s of sim time at 20x; report, plot and tlog land in out/.
demo: $(STAMP)
	mkdir -p out && rm -f out/mission.tlog  # (a --tlog that exists is kept: a new file is written beside it)
	$(BIN)/convoy-mav demo --scenario moving --duration 1200 --speedup 20 \
	  --report out/report.json --plot out/mission.png --tlog out/mission.tlog

# One pytest-xdist worker per core; an idle worker takes tests queued for a busy one
# (worksteal), so neither waits alone on the long flights at the end. Then the rover
# flights held at their speedup, each a core to itself, two at a time; then the tests
# that need the whole host (one loads it on purpose, the road flights hold 40x), alone.
test: $(STAMP) broker lint typecheck
	$(BIN)/python -m pytest -n auto --dist worksteal -m "not alone and not paired"
	$(BIN)/python -m pytest -n 2 --dist worksteal -m paired
	$(BIN)/python -m pytest -m alone

# The MQTT tests run against a real mosquitto broker (Debian package); install it
# once if the machine does not have it (as root, or through sudo).
broker:
	@command -v mosquitto >/dev/null 2>&1 || test -x /usr/sbin/mosquitto || { \
	  sudo=$$( [ "$$(id -u)" = 0 ] || echo sudo ); \
	  $$sudo apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive $$sudo apt-get install -y -qq mosquitto >/dev/null; }

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

typecheck: $(STAMP)
	$(BIN)/mypy

unit: $(STAMP)
	$(BIN)/python -m pytest -n auto --dist worksteal tests/unit

bench: $(STAMP)
	$(BIN)/python -m pytest benchmarks --benchmark-only --benchmark-columns=median,iqr,ops,rounds
	$(BIN)/python benchmarks/bench_mock_realtime.py
	$(BIN)/python benchmarks/bench_mock_pace.py

# convoy-mav (uvloop, asyncio) and MAVSDK-Python flying 10..1000 PX4 planes at 20 Hz (~30 min).
bench-fleet: $(STAMP)
	mkdir -p out
	$(BIN)/python benchmarks/bench_fleet.py 10 100 500 1000 --seconds 15 --json out/bench_fleet.json

# The 1000-UAV target, five runs on each event loop, interleaved; medians (about 4 min).
bench-fleet-1000: $(STAMP)
	mkdir -p out
	$(BIN)/python benchmarks/bench_fleet.py 1000 --clients convoy-mav convoy-mav-asyncio \
		--seconds 15 --repeat 5 --json out/bench_fleet_1000.json

clean:
	rm -rf $(VENV) .pytest_cache .mypy_cache .ruff_cache .benchmarks
