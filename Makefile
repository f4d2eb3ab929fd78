# Two commands on a fresh machine (Python >= 3.11 and make):
#   make demo   set up .venv and run the closed-loop pushing demo (writes out/demo/)
#   make test   set up .venv and run ruff and the test suite
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

FRANKA := $(VENV)/.franka

.PHONY: demo test test-slow test-franka examples lint bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e ".[dev,camera]"
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/dexpush demo --out out/demo

test: $(STAMP)
	$(BIN)/ruff check src tests benchmarks examples
	$(BIN)/python -m pytest -q -m "not slow and not franka" -n 2

$(FRANKA): $(STAMP)
	$(BIN)/pip install --quiet -e ".[dev,camera,franka]"
	touch $(FRANKA)

# the simulated Franka (the franka extra), in a network namespace with only the loopback up
test-franka: $(FRANKA)
	unshare -rn sh -c 'ip link set lo up 2>/dev/null; $(BIN)/python -m pytest -q -m franka tests/test_franka_sim.py'

test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -m "slow and not franka"

examples: $(STAMP)
	$(BIN)/python examples/own_object.py --out out/examples
	$(BIN)/python examples/gym_env.py
	$(BIN)/python examples/robot_loop.py --out out/examples
	$(BIN)/python examples/camera_loop.py --out out/examples
	$(BIN)/python examples/read_results.py docs/results/benchmark --out out/examples

bench: $(STAMP)
	$(BIN)/python benchmarks/mppi_speed.py

clean:
	rm -rf $(VENV) out .pytest_cache .hypothesis
