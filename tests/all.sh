#!/usr/bin/env bash
# Every test of the workspace, as CI runs them (README.md's test command), inside tests/isolated.sh's private
# network namespace:
#   1. `cargo nextest run --workspace`: every unit and integration test, each in a process of its own, several
#      at a time across the test binaries (.config/nextest.toml says which must run alone or in turns);
#   2. `cargo test --doc --workspace`: the doc tests (nextest does not run them).
# `tests/isolated.sh cargo test --workspace` runs the same tests, one binary after another (slower).
# Installs cargo-nextest (from crates.io, a few minutes once per machine) when it is missing.
#
#   tests/all.sh                 # extra arguments go to nextest: tests/all.sh -E 'binary(actions)'
set -euo pipefail
cd "$(dirname "$0")/.."
NEXTEST_VERSION=0.9.143
if ! cargo nextest --version >/dev/null 2>&1; then
  echo "all.sh: installing cargo-nextest $NEXTEST_VERSION (once per machine)" >&2
  cargo install --locked "cargo-nextest@$NEXTEST_VERSION"
fi
status=0
tests/isolated.sh cargo nextest run --workspace "$@" || status=$?
# with a filter given, the doc tests are left out (nextest's filters do not reach them)
if [ $# -eq 0 ]; then
  tests/isolated.sh cargo test --doc --workspace || status=$?
fi
exit "$status"
