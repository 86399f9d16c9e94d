#!/usr/bin/env bash
# Install everything talus needs on Debian bookworm (run as root), then build it.
set -euo pipefail
cd "$(dirname "$0")/.."
pkgs=(libopenmpi-dev openmpi-bin libhdf5-dev libclang-dev pkg-config liggghts yade lammps time)
missing=()
for p in "${pkgs[@]}"; do
  dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "install.sh: installing Debian packages: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq "${missing[@]}" >/dev/null
fi
pip=(python3 -m pip install -q --disable-pip-version-check --root-user-action=ignore)
"${pip[@]}" -r requirements.txt
t=$SECONDS
cargo build --release --quiet
echo "install.sh: cargo build took $((SECONDS - t)) s"
t=$SECONDS
# the Python module (python/: pyo3, built by maturin through pip; serial, no MPI)
"${pip[@]}" ./python
echo "install.sh: Python module took $((SECONDS - t)) s"
echo "install.sh: done ($(./target/release/talus --version); Python module talus $(python3 -c 'import talus; print(talus.__version__)'))"
