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
# the comparisons against LIGGGHTS and YADE (which run on one core each) beside
# pytest and the regression, in a process group of their own (stopped if this
# script stops first); their log is shown when they end
mkdir -p out
cmp_log=out/compare_all.log
setsid bash scripts/compare_all.sh > "$cmp_log" 2>&1 &
cmp_pid=$!
trap 'kill -- -"$cmp_pid" 2> /dev/null || true' EXIT
python3 -m pytest -q --durations=15 python/tests compare/tests
lap pytest
# every case against its golden file (python -m compare regress)
bash scripts/regress_all.sh
lap regress_all.sh
if wait "$cmp_pid"; then
  cat "$cmp_log"
else
  cat "$cmp_log"; echo "test.sh: scripts/compare_all.sh FAILED" >&2; exit 1
fi
trap - EXIT
lap 'compare_all.sh (beside pytest and regress_all.sh)'
