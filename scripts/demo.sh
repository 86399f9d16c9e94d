#!/usr/bin/env bash
# The main job: H1-small hopper fill and discharge, a printed summary and a plot.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/H1-small}
./target/release/talus run cases/H1-small.toml --out "$out"
python3 scripts/plot_hopper.py "$out"
