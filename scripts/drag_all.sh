#!/usr/bin/env bash
# Every drag case of the paper's Tables 1 and 2 (plus e0, the ellipse code at
# aspect ratio 1), two at a time (each case's beds one at a time), then the figures and the table.
# usage: bash scripts/drag_all.sh [OUT_DIR]   (default out/drag)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/drag}
cargo build --release --quiet
ids=(c1 e0 e1 e2 e3 c2 d1 c11 c12 c21 c22 d11 d12 e11 e12)
mkdir -p "$out"
printf '%s\n' "${ids[@]}" | xargs -P 2 -I{} sh -c "./target/release/talus drag cases/drag/{}.toml --threads 1 --out $out/{} > $out/{}.log 2>&1 || { echo 'drag case {} failed:'; cat $out/{}.log; exit 255; }"
python3 scripts/plot_drag.py $(printf "$out/%s " "${ids[@]}") --out "$out"
