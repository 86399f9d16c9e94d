#!/usr/bin/env bash
# The whole test suite (release build: the physics tests run real collisions and a hopper fill).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo test --release -- --test-threads=2
cargo bench --no-run --quiet
bash scripts/compare_all.sh
