#!/usr/bin/env bash
# The state_hash of every case in cases/ and of every drag bed, one line each:
# the proof that a refactor did not change the physics (run before and after,
# then diff). Long cases are cut to a fixed number of steps.
#   bash scripts/state_hashes.sh [OUT_DIR] > hashes.txt
# QUICK=1 skips the drag beds; TALUS=path picks the binary (default target/release/talus).
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-$(mktemp -d)}
talus=${TALUS:-./target/release/talus}
steps_for() {
  case "$1" in
    H1-paper) echo 300 ;;
    H1-paper-300k) echo 100 ;;
    H1-small|shear-bed) echo 3000 ;;
    *) echo "" ;;
  esac
}
for c in cases/*.toml; do
  name=$(basename "$c" .toml)
  s=$(steps_for "$name")
  args=(run "$c" --out "$out/$name" --quiet)
  [ -n "$s" ] && args+=(--steps "$s")
  "$talus" "${args[@]}" > /dev/null
  h=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['state_hash'])" "$out/$name/summary.json")
  echo "$name ${s:-all} $h"
done
if [ -z "${QUICK:-}" ]; then
  for c in cases/drag/*.toml; do
    id=$(basename "$c" .toml)
    "$talus" drag "$c" --out "$out/drag/$id" > /dev/null
    tail -n +2 "$out/drag/$id/beds.csv" | while IFS=, read -r seed _ steps h; do
      echo "drag/$id seed $seed $h"
    done
  done
fi
