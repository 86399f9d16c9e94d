#!/usr/bin/env bash
# The whole test suite (optimised build: the physics tests run real collisions and a hopper fill).
set -euo pipefail
cd "$(dirname "$0")/.."
# each part's wall time, so a slow part shows in the log
t0=$SECONDS
lap() { echo "test.sh: $1 done at $((SECONDS - t0)) s"; }
# the release code without link-time optimisation (Cargo.toml's `ci` profile, target/ci/):
# the same results, built in about a third of the time
cargo test --profile ci -- --test-threads=2
lap 'cargo test'
cargo bench --profile ci --no-run --quiet
lap 'cargo bench --no-run'
# the Python module, rebuilt from this tree, its tests and examples
python3 -m pip install -q --disable-pip-version-check --root-user-action=ignore ./python
lap 'Python module build'
python3 -m pytest -q --durations=15 python/tests compare/tests
lap pytest
# every case against its golden file (python -m compare regress)
bash scripts/regress_all.sh
lap regress_all.sh
bash scripts/compare_all.sh
lap compare_all.sh
