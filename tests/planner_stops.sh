#!/usr/bin/env bash
# Stops the soak's planner for 5 s, N times (default 25), and checks after each that its `once` scopes reach
# robot A's `a_once` again (issue 32: twice, under load, every `once` for ~50 s after a planner stop fired and
# none arrived). The soak's processes (tests/bin/soak.rs) on one host, in tests/isolated.sh's network namespace.
# Not part of the test command: a tool for finding that failure.
#
#   tests/planner_stops.sh [N]        LOAD=1: two busy loops per core; LOG=...: the processes' RUST_LOG
#                                     (e.g. LOG=warn,rustdds::rtps::reader=debug); logs in $OUT (/tmp/planner_stops)
set -u
n=${1:-25}
here=$(cd "$(dirname "$0")" && pwd)
cd "$here/.."
if [ "${RADAR_ISOLATED:-}" != 1 ]; then
  cargo build -q -p radar_ros_tests --bin radar_test_soak || exit 1
  exec tests/isolated.sh bash tests/planner_stops.sh "$n"
fi
B=$PWD/target/debug/radar_test_soak
OUT=${OUT:-/tmp/planner_stops}
export ROS_DOMAIN_ID=${ROS_DOMAIN_ID:-77} ROS_DISTRO=jazzy NO_COLOR=1 RUST_LOG=${LOG:-warn}
mkdir -p "$OUT" && cd "$OUT" && rm -f ./*.out ./*.err
pids=()
for role in robot-a bumper robot-b; do
  $B $role > $role.out 2> $role.err &
  pids+=($!)
done
$B planner > planner.out 2> planner.err &
P=$!
pids+=($P)
for _ in $(seq 300); do grep -q ready planner.out 2>/dev/null && break; sleep 0.2; done
if [ "${LOAD:-0}" = 1 ]; then
  for _ in $(seq $((2 * $(nproc)))); do (while :; do :; done) & pids+=($!); done
fi
trap 'kill "${pids[@]}" 2>/dev/null' EXIT
sleep 2
bad=0
for it in $(seq "$n"); do
  sleep 0.$((RANDOM % 10))
  kill -STOP $P; sleep 5; kill -CONT $P
  t=$(date +%s%N)
  sleep 9
  # scopes that began 3 s or more after the planner was continued and fired, and the starts a_once ran
  fired=$(awk -v t="$t" '$1=="once" && $3=="fired" && $2 > t+3000000000' planner.out | wc -l)
  started=$(awk -v t="$t" '$1=="start" && $2=="a_once" && $3 > t+3000000000' robot-a.out | wc -l)
  echo "stop $it: $fired once scopes fired, a_once started $started times"
  if [ "$started" -lt $((fired - 1)) ]; then
    bad=$((bad + 1))
    echo "stop $it: once starts lost (logs in $OUT)"
  fi
done
echo "planner_stops: $bad of $n stops lost once starts"
[ "$bad" = 0 ]
