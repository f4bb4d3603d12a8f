#!/usr/bin/env bash
# Listings 2 and 3 with every component in its own process: test_event, test_event2, test_response, and the
# deliberative program (which finds them by name on the ROS graph). ROS_DOMAIN_ID is honoured.
#
#   launch_scripts/deliberative.sh [--loop-secs N] [--duration S]
#
# Uses the built example binary (cargo build --bin deliberative), or RADAR_EXAMPLES=<dir> to point at it.
set -euo pipefail
source "$(dirname "$0")/processes.sh"
run_processes deliberative main "test_event test_event2 test_response" "$@"
