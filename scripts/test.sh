#!/usr/bin/env bash
# The whole test suite (release build: the physics tests run real collisions and a hopper fill).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo test --release -- --test-threads=2
cargo bench --no-run --quiet
# the Python module, rebuilt from this tree, its tests and examples
python3 -m pip install -q --disable-pip-version-check --root-user-action=ignore ./python
python3 -m pytest -q python/tests compare/tests
# every case against its golden file (python -m compare regress)
bash scripts/regress_all.sh
bash scripts/compare_all.sh
