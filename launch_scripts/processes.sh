# Shared by the launch scripts (source it): run_processes EXAMPLE MAIN_ROLE "ROLE ..." [ARGS...]
# Starts the example binary once per background role (output prefixed with [role]), then MAIN_ROLE in the
# foreground with ARGS; when it ends (or on Ctrl-C) the others get SIGTERM and are waited for.
# The binary comes from RADAR_EXAMPLES=<dir>, else target/debug/examples (built on demand).
run_processes() {
  local example="$1" main_role="$2" roles="$3"
  shift 3
  local here bin
  here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
  bin="${RADAR_EXAMPLES:-$here/target/debug/examples}/$example"
  if [ ! -x "$bin" ]; then
    (cd "$here" && cargo build --example "$example")
  fi
  pids=()
  cleanup() {
    for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null || true; done
    for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
  }
  trap cleanup EXIT INT TERM
  for role in $roles; do
    "$bin" "$role" > >(sed -u "s/^/[$role] /") &
    pids+=("$!")
  done
  "$bin" "$main_role" "$@" | sed -u "s/^/[$main_role] /"
}
