#!/usr/bin/env bash
# Listing 1 with every component in its own process (no ROS install needed):
#   count_up, start_event, end_event, and the deliberative statement
#   `once start_event start count_up until end_event`.
# The components find each other through DDS discovery; ROS_DOMAIN_ID is honoured.
#
#   launch_scripts/count_up_processes.sh [--duration SECONDS]
#
# Uses the built example binary (cargo build --example count_up_nodes), or RADAR_EXAMPLES=<dir> to point at it.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
bin="${RADAR_EXAMPLES:-$here/target/debug/examples}/count_up_nodes"
if [ ! -x "$bin" ]; then
  (cd "$here" && cargo build --example count_up_nodes)
fi
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null || true; done
  for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
}
trap cleanup EXIT INT TERM
for role in count_up start_event end_event; do
  "$bin" "$role" > >(sed -u "s/^/[$role] /") &
  pids+=("$!")
done
"$bin" statement "$@" | sed -u "s/^/[statement] /"
