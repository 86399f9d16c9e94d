#!/bin/sh
# H1-small in LIGGGHTS 3.8, from talus's own initial particles.
#
#   liggghts_cases/run_H1.sh OUTDIR [more liggghts arguments, e.g. -var fill_time 0.66]
#
# Writes OUTDIR/cloud.csv (talus cloud), OUTDIR/cloud.data (LIGGGHTS data file),
# OUTDIR/probes.csv (the time series), OUTDIR/fill_end.csv (fill-end wall forces)
# and OUTDIR/log.liggghts. Run from anywhere;
# it works in the repository root. Every set-up number is a -var of H1.in (see its top).
set -eu
cd "$(dirname "$0")/.."
out=${1:?usage: $0 OUTDIR [liggghts -var ...]}
shift
mkdir -p "$out"
./target/release/talus cloud cases/H1-small.toml --out "$out/cloud.csv"
python3 liggghts_cases/csv_to_data.py "$out/cloud.csv" "$out/cloud.data"
exec liggghts -in liggghts_cases/H1.in -log "$out/log.liggghts" \
    -var cloud "$out/cloud.data" -var out "$out/probes.csv" \
    -var out_fill_end "$out/fill_end.csv" "$@"
