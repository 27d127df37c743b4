# The two commands: `make run` and `make test`. Both create .venv on first use.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
ARGS ?=

# Keep DDS discovery on this host unless the caller says otherwise.
export ROS_AUTOMATIC_DISCOVERY_RANGE ?= LOCALHOST
export MPLBACKEND ?= Agg

.PHONY: run test test-slow test-busy lint bench clean control_msgs

$(STAMP): pyproject.toml setup.py
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --disable-pip-version-check -e '.[dev]'
	touch $(STAMP)

# control_msgs (FollowJointTrajectory) has no wheel: built once into the venv from interfaces/control_msgs,
# unless a sourced ROS 2 has it. Checked on every call; seconds once built.
control_msgs: $(STAMP)
	$(BIN)/python tools/build_control_msgs.py

run: $(STAMP) control_msgs egl
	$(BIN)/robot-controller run $(ARGS)

# Every test but the long experiments (marked slow), which `make test-slow` runs; CI runs both.
# The 15 slowest are listed at the end: the suite is meant to stay within a few minutes.
test: $(STAMP) lint control_msgs egl
	$(BIN)/python -m pytest -q -m "not slow" --durations=15 $(ARGS)

test-slow: $(STAMP) control_msgs egl
	$(BIN)/python -m pytest -q -m slow $(ARGS)

# The suite beside a one-core CPU hog (a busy host is not a fault): it must pass all the same.
test-busy: $(STAMP) lint control_msgs egl stress-ng
	stress-ng --cpu 1 --quiet & HOG=$$!; \
	$(BIN)/python -m pytest -q -m "not slow" $(ARGS); CODE=$$?; kill $$HOG; exit $$CODE

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

clean:
	rm -rf $(VENV) runs .pytest_cache

# Debian's EGL and Mesa, for MuJoCo's offscreen rendering (MUJOCO_GL=egl): the camera of run --sensing camera.
.PHONY: egl
egl:
	ldconfig -p | grep -q libEGL_mesa || (apt-get update && apt-get install -y --no-install-recommends libegl1 libegl-mesa0 libgl1)

# Debian's chromium, for the live view's headless browser test (tests/view).
.PHONY: chromium
chromium:
	command -v chromium >/dev/null || (apt-get update && apt-get install -y --no-install-recommends chromium)

# nftables, for the network bench's packet loss (robot-controller network; tests/lab/network).
.PHONY: nftables
nftables:
	command -v nft >/dev/null || (apt-get update && apt-get install -y --no-install-recommends nftables)

# stress-ng, a CPU hog to run the suite or a verb beside (`stress-ng --cpu 1`): a busy host is not a fault.
.PHONY: stress-ng
stress-ng:
	command -v stress-ng >/dev/null || (apt-get update && apt-get install -y --no-install-recommends stress-ng)

# faketime (libfaketime), to run one side of a split run on a shifted wall clock (tests/runner/test_split_run.py).
.PHONY: faketime
faketime:
	command -v faketime >/dev/null || (apt-get update && apt-get install -y --no-install-recommends faketime)

# franka-sim, a stand-in Franka robot speaking libfranka's protocol on port 1337 (MuJoCo inside), for pylibfranka's
# client side (robot_controller/hardware/franka_server.py, tests/hardware). It pins numpy and mujoco below ours, so it
# lives in a venv of its own, made once (again when this file changes: a new pin).
FRANKA_SIM_VENV ?= build/franka-sim-venv
.PHONY: franka-sim
franka-sim: $(FRANKA_SIM_VENV)/.installed
$(FRANKA_SIM_VENV)/.installed: Makefile
	test -x $(FRANKA_SIM_VENV)/bin/python || $(PYTHON) -m venv $(FRANKA_SIM_VENV)
	$(FRANKA_SIM_VENV)/bin/python -m pip install --quiet --disable-pip-version-check franka-sim==1.1.7
	touch $@

# The stand-in robot served on 127.0.0.1 until Ctrl-C (robot-controller run --robot panda --hardware franka://127.0.0.1).
.PHONY: franka-sim-serve
franka-sim-serve: $(STAMP) franka-sim
	$(BIN)/python -m robot_controller.hardware.franka_server build/franka-sim
