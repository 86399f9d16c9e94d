#!/usr/bin/env bash
# talus's own physics regression: every case in cases/ (and cases/bench/) against its
# golden file in cases/golden/ (bench: cases/bench/golden/), with the case's [compare]
# tolerances (python -m compare regress). Long cases are cut by their
# compare.regress_steps. Of the drag cases (talus drag, 5 beds each), the four fast
# ones run here; tests/drag.rs runs the rest of the drag physics.
#   bash scripts/regress_all.sh [--update-golden] [--junit-dir DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
update=()
junit=""
while [ $# -gt 0 ]; do
  case "$1" in
    --update-golden) update=(--update-golden) ;;
    --junit-dir) junit=$2; shift ;;
    *) echo "regress_all.sh: unknown option $1" >&2; exit 2 ;;
  esac
  shift
done
cases=(cases/*.toml cases/bench/*.toml cases/drag/c1.toml cases/drag/c12.toml cases/drag/c22.toml cases/drag/d12.toml)
failed=()
for c in "${cases[@]}"; do
  args=(regress "$c" "${update[@]}")
  [ -n "$junit" ] && { mkdir -p "$junit"; args+=(--junit "$junit/$(basename "$c" .toml).xml"); }
  t=$SECONDS
  python3 -m compare "${args[@]}" || failed+=("$c")
  echo "regress_all.sh: $c took $((SECONDS - t)) s"
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "regress_all.sh: outside tolerance or failed: ${failed[*]}" >&2
  exit 1
fi
echo "regress_all.sh: ${#cases[@]} cases within tolerance of their golden files"
