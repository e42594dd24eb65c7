#!/usr/bin/env bash
# The test command of the README: set up (idempotent), then run every test of the workspace's host
# crates — the core's unit and property tests, host-sim's (incl. serial round trips over socat ptys),
# the end-to-end scene tests, and the core on the emulated Cortex-M4F compared bit for bit with the
# host (qemu-check). CI=true makes missing tools an error instead of a skipped test.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
export CI=${CI:-true}
cargo test --workspace --exclude firmware
cargo test -p firmware --lib
