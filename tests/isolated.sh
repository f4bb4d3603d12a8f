#!/usr/bin/env bash
# Runs a command in a private network namespace, so DDS discovery and traffic of the tests never leave this
# machine, while DDS still sees an ordinary multicast-capable subnet (as on a robot):
#   lo (127.0.0.1) + a veth pair radar0 (10.77.0.1/24) <-> radar1, both ends inside the namespace.
# Multicast sent on radar0 arrives on radar1, inside the namespace; nothing is routed out of it.
# Needs root (or CAP_SYS_ADMIN + CAP_NET_ADMIN) and iproute2.
#
#   tests/isolated.sh cargo test --workspace
#
# Nothing inside the namespace reaches the internet, so first, outside it, this fetches the crates
# (`cargo fetch`, also for the vendored RustDDS and ros2-client, whose unit tests tests/vendored_rustdds.rs and
# tests/vendored_ros2_client_zenoh.rs run, and the crates.io RustDDS that tests/user_crate.rs builds radar_ros's
# guard against) and builds
# the rclpy venv of the interop tests (tests/python_env.sh, cached; exported as RADAR_VENV). If the venv
# cannot be built the other tests still run and the interop tests fail, saying why.
set -euo pipefail
if [ "${RADAR_ISOLATED:-}" = 1 ]; then exec "$@"; fi
# The tests build crates of their own too (the vendored RustDDS and ros2-client with their unit tests, the Python
# package, colcon's packages, a user's crate): line tables only, as the workspace's own dev profile has it (a
# panic still names file:line), not full debug info, which doubles what they write to disk.
export CARGO_PROFILE_DEV_DEBUG="${CARGO_PROFILE_DEV_DEBUG:-line-tables-only}"
here=$(cd "$(dirname "$0")" && pwd)
if [ "${1:-}" = cargo ]; then
  # the vendored ros2-client's lock starts from the workspace's (its Zenoh crates pinned as the workspace's)
  (cd "$here/.." && cargo fetch --quiet && cargo fetch --quiet --manifest-path third_party/rustdds/Cargo.toml \
    && cargo fetch --quiet --manifest-path tests/fixtures/crates_io_rustdds/Cargo.toml \
    && { [ -f third_party/ros2-client/Cargo.lock ] || cp Cargo.lock third_party/ros2-client/Cargo.lock; } \
    && cargo fetch --quiet --manifest-path third_party/ros2-client/Cargo.toml)
fi
if venv=$("$here/python_env.sh"); then
  export RADAR_VENV="$venv"
else
  echo "isolated.sh: tests/python_env.sh failed (above); the interop tests will fail" >&2
fi
command -v unshare >/dev/null || { echo "isolated.sh: unshare (util-linux) is missing" >&2; exit 1; }
command -v ip >/dev/null || { echo "isolated.sh: ip (iproute2) is missing: apt-get install -y iproute2" >&2; exit 1; }
exec unshare --net -- bash -c '
  set -e
  ip link set lo up
  ip link add radar0 type veth peer name radar1
  ip addr add 10.77.0.1/24 dev radar0
  ip link set radar0 up
  ip link set radar1 up
  ip link set radar0 multicast on
  ip route add 224.0.0.0/4 dev radar0
  export RADAR_ISOLATED=1
  exec "$@"
' isolated "$@"
