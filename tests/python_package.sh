#!/usr/bin/env bash
# Builds the radar_ros Python package (radar_ros/python, PyO3 + maturin) and installs it into the interop venv
# (tests/python_env.sh), as a user's `pip install ./radar_ros/python` would, but with cargo's dev profile (the
# tests need the behaviour, not the speed; `pip install` builds release).
#
#   tests/python_package.sh        # prints the venv's path
#
# The build has a target directory of its own (target/python-pkg): it runs while `cargo test` holds target/.
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
VENV=$("$ROOT/tests/python_env.sh")
export CARGO_TARGET_DIR="${RADAR_PY_TARGET:-$ROOT/target/python-pkg}"
WHEELS="$CARGO_TARGET_DIR/wheels"
rm -rf "$WHEELS"
# RADAR_PY_FEATURES: the package's cargo features (`zenoh`: a Radar on Zenoh; tests/python_package.rs builds with it)
(cd "$ROOT/radar_ros/python" && "$VENV/bin/maturin" build --profile dev -i "$VENV/bin/python" -o "$WHEELS" \
  ${RADAR_PY_FEATURES:+--features "$RADAR_PY_FEATURES"} >&2)
"$VENV/bin/pip" install --disable-pip-version-check -q --force-reinstall --no-deps "$WHEELS"/radar_ros-*.whl >&2
"$VENV/bin/python" -c 'import radar_ros, sys; print("python_package: radar_ros", radar_ros.__file__, file=sys.stderr)'
echo "$VENV"
