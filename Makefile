# Two commands on a fresh machine (Python >= 3.11 and make):
#   make demo   set up .venv and run the closed-loop pushing demo (writes out/demo/)
#   make test   set up .venv and run ruff and the test suite
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

FRANKA := $(VENV)/.franka
ROS    := $(VENV)/.ros
CLUSTER := $(VENV)/.cluster
# a new user and network namespace with only the loopback up (and multicast on it, for DDS discovery)
LOOPBACK := unshare -rn sh -c 'ip link set lo up && ip route add 224.0.0.0/4 dev lo && exec "$$@"' sh

.PHONY: demo test test-slow test-franka test-franka-slow test-ros test-cluster ros-demo examples lint bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e ".[dev,camera]"
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/dexpush demo --out out/demo

test: $(STAMP)
	$(BIN)/ruff check src tests benchmarks examples
	$(BIN)/python -m pytest -q -m "not slow and not franka and not ros and not cluster" -n 2 --durations=15

$(FRANKA): $(STAMP)
	$(BIN)/pip install --quiet -e ".[dev,camera,franka]"
	touch $(FRANKA)

# the simulated Franka (the franka extra), in a network namespace with only the loopback up
FRANKA_TESTS := tests/test_franka_sim.py tests/test_clearing_sim.py
test-franka: $(FRANKA)
	unshare -rn sh -c 'ip link set lo up 2>/dev/null; $(BIN)/python -m pytest -q -m "franka and not slow" $(FRANKA_TESTS)'

# ... and its slow tests (a whole table clearing through dexpush clear, 2-3 min)
test-franka-slow: $(FRANKA)
	unshare -rn sh -c 'ip link set lo up 2>/dev/null; $(BIN)/python -m pytest -q -m "franka and slow" $(FRANKA_TESTS)'

$(ROS): $(STAMP)
	$(BIN)/pip install --quiet -e ".[dev,camera,ros]"
	touch $(ROS)

# the ROS 2 node (the ros extra) over DDS, in a network namespace with only the loopback up
test-ros: $(ROS)
	$(LOOPBACK) env ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST $(BIN)/python -m pytest -q -m ros tests/test_ros_node.py

$(CLUSTER): $(STAMP)
	$(BIN)/pip install --quiet -e ".[dev,camera,cluster]"
	touch $(CLUSTER)

# dexpush bench on a local Ray instance (the cluster extra), in a network namespace with only the loopback up
test-cluster: $(CLUSTER)
	$(LOOPBACK) env RAY_USAGE_STATS_ENABLED=0 $(BIN)/python -m pytest -q -m cluster tests/test_cluster.py

# the ROS 2 example system: one episode of Task I through the node (examples/ros_system.py makes the namespace)
ros-demo: $(ROS)
	$(BIN)/python examples/ros_system.py --out out/examples/ros

test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -m "slow and not franka and not ros and not cluster"

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
