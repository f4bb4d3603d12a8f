#!/usr/bin/env bash
# Listings 2 and 3 with every component in its own process: test_event, test_event2, test_response, and the
# deliberative program (which finds them by name on the ROS graph). ROS_DOMAIN_ID is honoured.
#
#   launch_scripts/deliberative.sh [--loop-secs N] [--duration S]
#
# Uses the built example binary (cargo build --example deliberative), or RADAR_EXAMPLES=<dir> to point at it.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
bin="${RADAR_EXAMPLES:-$here/target/debug/examples}/deliberative"
if [ ! -x "$bin" ]; then
  (cd "$here" && cargo build --example deliberative)
fi
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null || true; done
  for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
}
trap cleanup EXIT INT TERM
for role in test_event test_event2 test_response; do
  "$bin" "$role" > >(sed -u "s/^/[$role] /") &
  pids+=("$!")
done
"$bin" main "$@" | sed -u "s/^/[main] /"
