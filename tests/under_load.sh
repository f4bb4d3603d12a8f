#!/usr/bin/env bash
# Repeats the tests most sensitive to timing N times each (default 30) while the machine is under double CPU
# load (two busy loops per core), in the private network namespace of tests/isolated.sh, and prints how many
# runs of each passed. Exits 1 if any run failed. Not part of the README's test command (it takes about an
# hour on 2 cores); issue 23 asks for it, docs/reliability.md shows its last result.
#
#   tests/under_load.sh [N] [all|plain|secured]
#
# `secured` runs only the secured programs' tests (issue 32: the secured examples once logged RustDDS errors as
# programs ended). Every run is of the workspace's test build (`cargo test --workspace`, the README's: it has the
# `security` and `zenoh` features on, tests/Cargo.toml), so what CI built is reused.
#
# The tests: a `ros2 topic pub --once` from a fresh rclpy process (30 starts and 30 interrupts per run), a
# service call from a fresh process, a signal emitted right before its component exits, programs
# whose main returns (their exit slots run and their goodbye is heard at once), and issue 32's: Ctrl-C under
# ros2 launch, a stopping program relaying nothing, a dead owner's connection suspended within a second, a
# respawned target seen replaced, a peer an hour ahead, an until bounding a queued run.
set -euo pipefail
n=${1:-30}
which=${2:-all}
here=$(cd "$(dirname "$0")" && pwd)
cd "$here/.."
if [ "${RADAR_ISOLATED:-}" != 1 ]; then
  cargo test -q --workspace --no-run
  exec tests/isolated.sh bash tests/under_load.sh "$n" "$which"
fi
cores=$(nproc)
pids=()
for _ in $(seq $((2 * cores))); do
  (while :; do :; done) &
  pids+=($!)
done
trap 'kill "${pids[@]}" 2>/dev/null || true' EXIT
echo "under_load: $((2 * cores)) busy loops on $cores cores, $n runs per test"
tests=(
  "interop every_one_shot_publish_from_a_fresh_process_is_acted_on"
  "interop every_service_call_from_a_fresh_process_is_answered"
  "failure a_signal_sent_just_before_the_component_exits_is_delivered_not_reported_lost"
  "shutdown returning_from_main_runs_the_exit_slot_and_sends_exited"
  "shutdown ctrl_c_under_ros2_launch_two_sigints_let_the_exit_slots_finish"
  "shutdown a_program_told_to_stop_starts_nothing_more_while_its_exit_slots_run"
  "failure a_dead_owners_connection_stops_within_a_second_not_at_its_lease"
  "failure a_target_respawned_within_its_lease_is_seen_replaced"
  "clocks a_start_from_a_host_an_hour_ahead_does_not_blind_the_response_to_its_own_hosts_interrupts"
  "connections cases::until_bounds_the_run_of_a_start_that_waited_for_another_run"
)
# PACKAGE TEST NAME, built with the security feature
secured=(
  "radar_ros_examples count_up_secured secured_deliberative_example_follows_figure_3"
  "radar_ros_examples count_up_secured secured_count_up_follows_listing_1"
  "radar_ros secure secured_programs_signal_each_other_and_a_plain_one_is_kept_out"
  "radar_ros secure one_secured_program_hears_its_own_signals_on_every_subscription"
)
runs=()
if [ "$which" != secured ]; then
  for t in "${tests[@]}"; do runs+=("radar_ros_tests $t plain"); done
fi
if [ "$which" != plain ]; then
  for t in "${secured[@]}"; do runs+=("$t secured"); done
fi
failed=0
for t in "${runs[@]}"; do
  set -- $t
  shift # the package: every run is of the workspace's test build
  ok=0
  for i in $(seq "$n"); do
    run=(cargo test -q --workspace --test "$1" -- --exact "$2")
    if "${run[@]}" > "/tmp/under_load_$2_$i.log" 2>&1; then
      ok=$((ok + 1))
      rm -f "/tmp/under_load_$2_$i.log"
    else
      echo "under_load: $2 run $i failed (log: /tmp/under_load_$2_$i.log)"
      failed=1
    fi
  done
  echo "under_load: $2: $ok of $n passed"
done
exit $failed
