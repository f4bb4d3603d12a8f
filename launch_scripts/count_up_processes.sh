#!/usr/bin/env bash
# Listing 1 with every component in its own process (no ROS install needed):
#   count_up, start_event, end_event, and the deliberative statement
#   `once start_event start count_up until end_event`.
# The components find each other through DDS discovery; ROS_DOMAIN_ID is honoured.
#
#   launch_scripts/count_up_processes.sh [--duration SECONDS]
#
# Uses the built example binary (cargo build --bin count_up_nodes), or RADAR_EXAMPLES=<dir> to point at it.
set -euo pipefail
source "$(dirname "$0")/processes.sh"
run_processes count_up_nodes statement "count_up start_event end_event" "$@"
