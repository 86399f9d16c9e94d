#!/bin/bash
# The MPI figures on H1-paper (100,000 spheres): speed-up of 2 ranks over 1,
# imbalance of measured compute time with dynamic against static planes, and,
# on 8 oversubscribed ranks, the imbalance of the work counters (particles +
# contacts per rank), static against dynamic. All runs restart from the same
# end-of-fill checkpoint and run the same discharge steps.
#
#   bash scripts/measure_mpi.sh [OUT]        (STEPS, STEPS8, FILL_CHECKPOINT in the environment)
#
# Takes about half an hour on this 2-core machine (the fill on 2 ranks included);
# run it on an otherwise idle machine: it measures time.
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/mpi}
STEPS=${STEPS:-8000}
STEPS8=${STEPS8:-4000}
B=target/release/talus
CASE=cases/H1-paper.toml
MPI="mpirun --allow-run-as-root --oversubscribe"
mkdir -p "$OUT"
CK=${FILL_CHECKPOINT:-$OUT/fill/checkpoint_after_fill.bin}
if [ ! -f "$CK" ]; then
    echo "== fill on 2 ranks (to the end-of-fill checkpoint)"
    $MPI -n 2 $B run $CASE --out "$OUT/fill" --steps 13000 --quiet > "$OUT/fill.log"
fi
run() {  # name ranks balance steps (a run whose summary.json exists is kept)
    if [ -f "$OUT/$1/summary.json" ]; then echo "== $1: kept"; return; fi
    echo "== $1: $2 rank(s), balance $3, $4 discharge steps"
    if [ "$2" = 1 ]; then
        $B run $CASE --restart "$CK" --steps "$4" --balance "$3" --out "$OUT/$1" --quiet > "$OUT/$1.log"
    else
        $MPI -n "$2" $B run $CASE --restart "$CK" --steps "$4" --balance "$3" --out "$OUT/$1" --quiet > "$OUT/$1.log"
    fi
}
run p1 1 off "$STEPS"
run p2-dynamic 2 time "$STEPS"
run p2-static 2 off "$STEPS"
run p8-static 8 off "$STEPS8"
run p8-dynamic 8 contacts "$STEPS8"
python3 - "$OUT" <<'PY'
import json, sys
from pathlib import Path
out = Path(sys.argv[1])
s = {d: json.loads((out / d / "summary.json").read_text()) for d in ["p1", "p2-dynamic", "p2-static", "p8-static", "p8-dynamic"]}
assert len({v["state_hash"] for k, v in s.items() if k.startswith("p1") or k.startswith("p2")}) == 1, "P=1 and P=2 differ"
r = {
    "steps": s["p1"]["steps_this_run"],
    "p1_particle_steps_per_s": s["p1"]["particle_steps_per_s"],
    "p2_dynamic_particle_steps_per_s": s["p2-dynamic"]["particle_steps_per_s"],
    "p2_static_particle_steps_per_s": s["p2-static"]["particle_steps_per_s"],
    "speedup_2_over_1_dynamic": s["p2-dynamic"]["particle_steps_per_s"] / s["p1"]["particle_steps_per_s"],
    "speedup_2_over_1_static": s["p2-static"]["particle_steps_per_s"] / s["p1"]["particle_steps_per_s"],
    "p2_imbalance_time_dynamic": s["p2-dynamic"]["imbalance_time_discharge"],
    "p2_imbalance_time_static": s["p2-static"]["imbalance_time_discharge"],
    "p8_imbalance_work_static": s["p8-static"]["imbalance_work_discharge"],
    "p8_imbalance_work_dynamic": s["p8-dynamic"]["imbalance_work_discharge"],
    "p2_rebalances": s["p2-dynamic"]["rebalances"],
    "p8_rebalances": s["p8-dynamic"]["rebalances"],
}
print(json.dumps(r, indent=1))
(out / "mpi_figures.json").write_text(json.dumps(r, indent=1) + "\n")
PY
python3 scripts/plot_ranks.py "$OUT/p2-static" "$OUT/p2-dynamic" --labels static,dynamic --out "$OUT/plots-p2"
python3 scripts/plot_ranks.py "$OUT/p8-static" "$OUT/p8-dynamic" --labels static,dynamic --out "$OUT/plots-p8"
