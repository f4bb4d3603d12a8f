#!/usr/bin/env bash
# Every publishable crate packaged and verified (`cargo package`: the .crate file built on its own, as crates.io
# would build it) in publishing order: the two forks first, then the workspace's crates, each resolving the ones
# before it as crates.io would hand them out. The forks are not on crates.io yet, so `--config patch.crates-io`
# stands in for the registry they will be published to; the workspace's own crates are packaged in one call,
# which hands each the ones packaged before it (cargo's local overlay).
#
# Usage: .ci/package.sh [--no-verify]   (the .crate files land in target/user-crate/target/package/)
set -euo pipefail
cd "$(dirname "$0")/.."
verify=()
[ "${1:-}" = --no-verify ] && verify=(--no-verify)
# The verify builds build radar_ros as a crate outside this workspace does, as tests/user_crate.rs's crates do:
# they share that test's target directory and settings, so that the test (which runs after this) finds the
# dependencies built (minutes on 2 cores).
export CARGO_TARGET_DIR="$PWD/target/user-crate/target" CARGO_INCREMENTAL=0 CARGO_PROFILE_DEV_DEBUG=line-tables-only
# the patches for the forks are used by some crates only; cargo's "patch was not used" notes are not news
quiet() { grep -v -e 'was not used in the crate graph' -e '^help: Check that the patched' -e '^      with the dependency' \
  -e '^      what is locked' -e '^      version. This may' -e '^warning: manifest has no documentation' -e '^  |$' \
  -e '= note: see https://doc.rust-lang.org/cargo/reference/manifest.html#package-metadata' || true; }
# Cargo unpacks the crates of the local overlay registry (this workspace's crates, packaged, handed to the later
# ones) into $CARGO_HOME/registry/src/<hash of the overlay's path>/ and never again for the same name and
# version: a run from the same checkout path as an earlier one would verify the later crates against the earlier
# run's sources (CI failed so: radar_tools built against an older radar_ros). Those copies go first; the
# crates.io ones are never touched.
home=${CARGO_HOME:-$HOME/.cargo}
for d in "$home"/registry/src/* "$home"/registry/cache/*; do
  case "$(basename "$d")" in index.crates.io-*) continue ;; esac
  rm -rf "$d"/radar_* "$d"/radar-*
done
rustdds=(--config 'patch.crates-io.radar-rustdds.path="third_party/rustdds"')
ros2_client=(--config 'patch.crates-io.radar-ros2-client.path="third_party/ros2-client"')

# 1. radar-rustdds: crates.io dependencies only
cargo package "${verify[@]}" --locked --manifest-path third_party/rustdds/Cargo.toml 2>&1 | quiet
# 2. radar-ros2-client: on radar-rustdds
cargo package "${verify[@]}" --manifest-path third_party/ros2-client/Cargo.toml "${rustdds[@]}" 2>&1 | quiet
# 3. the workspace's crates, in the order of their dependencies (publish = false: the Python package, the checker,
#    the tests, the examples and the bench)
cargo package "${verify[@]}" "${rustdds[@]}" "${ros2_client[@]}" \
  -p radar_semantics -p radar_idl -p radar_spec -p radar_ros -p radar_tools 2>&1 | quiet
ls "$CARGO_TARGET_DIR"/package/*.crate | sed 's|.*/|packaged: |'
