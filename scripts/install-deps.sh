#!/usr/bin/env bash
# Installs the Debian 12 packages hazmap needs. A no-op when they are all present.
#   scripts/install-deps.sh          build + test dependencies
#   scripts/install-deps.sh --peers  also PCL and Open3D (benchmarks only)
#   scripts/install-deps.sh --fuzz   also clang and its libFuzzer runtime (`make fuzz` only)
set -euo pipefail
packages=(
  build-essential cmake pkg-config ninja-build
  libeigen3-dev libtbb-dev libceres-dev libsuitesparse-dev libnanoflann-dev
  libcli11-dev libyaml-cpp-dev libfmt-dev libspdlog-dev libstb-dev libembree-dev
  nlohmann-json3-dev libgtest-dev libgmock-dev libbenchmark-dev robin-map-dev
  pcl-tools
  libsqlite3-dev libzstd-dev liblz4-dev libbz2-dev zlib1g-dev
  libpcap-dev libcivetweb-dev
  libgstreamer1.0-dev libgstreamer-plugins-base1.0-dev gstreamer1.0-plugins-base gstreamer1.0-plugins-good
  libcairo2-dev fonts-dejavu-core libjs-three chromium
  python3-dev python3-pybind11 python3-pytest python3-numpy python3-dask python3-distributed
)
if [[ "${1:-}" == "--peers" ]]; then
  packages+=(libpcl-dev libopen3d-dev)
elif [[ "${1:-}" == "--fuzz" ]]; then
  packages+=(clang libclang-rt-14-dev)
fi
missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [[ ${#missing[@]} -eq 0 ]]; then
  exit 0
fi
echo "install-deps: installing ${missing[*]}"
SUDO=""
if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
