#!/usr/bin/env bash
# Install granflow's build and run dependencies from Debian 12 packages (run as root).
# Idempotent: when everything is already installed it only checks and returns.
set -euo pipefail
pkgs=(
  cmake g++ make                       # toolchain
  trilinos-all-dev libptscotch-dev     # Trilinos 13.2 (its CMake targets need the full set)
  libhdf5-openmpi-dev hdf5-tools       # HDF5, the OpenMPI flavour that Trilinos links
  libeigen3-dev nlohmann-json3-dev libgtest-dev
  libopenblas0-serial                  # BLAS/LAPACK behind Debian's alternatives in place of the
                                       # reference one: Belos' orthogonalisation is dgemm (7 % of
                                       # a 2D run); serial, the MPI ranks own the cores
  python3-matplotlib python3-h5py      # plotting scripts in scripts/
)
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#pkgs[@]} packages present"
  exit 0
fi
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -q
apt-get install -y -q "${missing[@]}"
