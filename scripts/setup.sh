#!/usr/bin/env bash
# Installs the Debian packages voxcut needs to build and test. Idempotent: when everything is
# present it only checks (about a second) and installs nothing.
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  libeigen3-dev libtbb-dev libcli11-dev nlohmann-json3-dev libspdlog-dev libassimp-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  # label volumes: zlib (NRRD, MetaImage, gzip) and nifticlib (NIfTI); the AAL atlas and
  # nibabel for the orientation tests
  zlib1g-dev libnifti2-dev mricron-data python3-nibabel
  # the Python module (python/): pybind11, numpy, pytest; Dask for sweeps, matplotlib for
  # their figure; venv, pip, setuptools and build for the offline install and the wheel
  pybind11-dev python3-pybind11 python3-dev python3-numpy python3-pytest python3-dask
  python3-distributed python3-matplotlib python3-venv python3-pip python3-setuptools
  python3-wheel python3-build
  # bench_fem: CHOLMOD, the direct solver our block Cholesky is compared with
  libsuitesparse-dev
  # voxcut-view: window, OpenGL 3.3, Dear ImGui (with its GLFW and OpenGL 3 backends), PNG;
  # its tests run under Xvfb with Mesa's software renderer
  libglfw3-dev libgl-dev libimgui-dev libstb-dev xvfb xauth libgl1-mesa-dri
  # the fuzz preset: clang and its sanitizer + libFuzzer runtimes (only recommended by clang)
  clang libfuzzer-14-dev libclang-rt-14-dev
  # the figures of `voxcut bench complex` (scripts/plot_complex.py)
  python3-matplotlib
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if ((${#missing[@]} == 0)); then
  echo "setup: all ${#packages[@]} packages present"
  exit 0
fi

echo "setup: installing ${missing[*]}"
SUDO=""
if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
if ! $SUDO apt-get install -y --no-install-recommends "${missing[@]}"; then
  $SUDO apt-get update
  $SUDO apt-get install -y --no-install-recommends "${missing[@]}"
fi
