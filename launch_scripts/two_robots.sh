#!/usr/bin/env bash
# Listings 2 and 3 for two robots side by side in one ROS domain: the deliberative example's four processes
# twice, one set under /robot1 and one under /robot2, their settings from robots.yaml. These are the command
# lines two_robots.launch.py makes `ros2 launch` run (`--ros-args -r __ns:=/robotN --params-file robots.yaml`),
# for machines without a ROS installation. ROS_DOMAIN_ID is honoured.
#
#   launch_scripts/two_robots.sh [--loop-secs N] [--duration S]
#
# Uses the built example binary (cargo build --bin deliberative), or RADAR_EXAMPLES=<dir> to point at it.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
source "$here/processes.sh"
roles="test_event test_event2 test_response"
(
  ROS_ARGS="--ros-args -r __ns:=/robot1 --params-file $here/robots.yaml" PREFIX="robot1 " \
    run_processes deliberative main "$roles" "$@"
) &
robot1=$!
ROS_ARGS="--ros-args -r __ns:=/robot2 --params-file $here/robots.yaml" PREFIX="robot2 " \
  run_processes deliberative main "$roles" "$@"
wait "$robot1"
