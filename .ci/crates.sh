#!/usr/bin/env bash
# The crates a user's build of radar_ros compiles (normal and build dependencies, each name and version once),
# for the default build (DDS only) and each feature; the radar_tools command line and the Python package beside.
#   .ci/crates.sh            # a table
set -euo pipefail
cd "$(dirname "$0")/.."
count() {
  cargo tree --offline "$@" -e normal,build --prefix none 2>/dev/null |
    awk '{print $1, $2}' | sort -u | wc -l
}
printf '%-40s %s\n' "build" "crates"
printf '%-40s %s\n' "radar_ros (default: DDS)" "$(count -p radar_ros)"
for f in codec security zenoh; do
  printf '%-40s %s\n' "radar_ros --features $f" "$(count -p radar_ros --features "$f")"
done
printf '%-40s %s\n' "radar_tools (the radar command)" "$(count -p radar_tools)"
printf '%-40s %s\n' "radar_ros_python (the Python package)" "$(count -p radar_ros_python)"
