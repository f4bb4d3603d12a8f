# Shared by the launch scripts (source it): run_processes EXAMPLE MAIN_ROLE "ROLE ..." [ARGS...]
# Starts the example binary once per background role (output prefixed with [role]), then MAIN_ROLE in the
# foreground with ARGS; when it ends (or on Ctrl-C) the others get SIGTERM and are waited for.
# The binary comes from RADAR_EXAMPLES=<dir>, else target/debug (built on demand).
# ROS_ARGS (a word list, e.g. "--ros-args -r __ns:=/robot1") is appended to every command line, as ros2 launch
# appends a node's; PREFIX goes before the role in the output prefix ([PREFIXrole]).
run_processes() {
  local example="$1" main_role="$2" roles="$3"
  shift 3
  local here bin
  here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
  bin="${RADAR_EXAMPLES:-$here/target/debug}/$example"
  if [ ! -x "$bin" ]; then
    (cd "$here" && cargo build --bin "$example")
  fi
  pids=()
  cleanup() {
    for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null || true; done
    for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
  }
  trap cleanup EXIT INT TERM
  local prefix="${PREFIX:-}"
  # shellcheck disable=SC2206 # ROS_ARGS is a word list
  local ros_args=(${ROS_ARGS:-})
  for role in $roles; do
    "$bin" "$role" "${ros_args[@]}" > >(sed -u "s/^/[$prefix$role] /") &
    pids+=("$!")
  done
  "$bin" "$main_role" "$@" "${ros_args[@]}" | sed -u "s/^/[$prefix$main_role] /"
}
