#!/usr/bin/env bash
# One idempotent set-up: installs the Debian packages varmesh needs (only those missing), then configures
# and builds the Release tree in build/release. Usage: scripts/setup.sh [--asan] [--bench] [--no-build]
#   --asan      also configure and build the Debug + ASan/UBSan tree in build/asan
#   --bench     also install the peer libraries the benchmarks compare against (meshoptimizer, OpenMesh, CGAL)
#   --no-build  install packages only
set -euo pipefail
cd "$(dirname "$0")/.."

build_asan=0
build=1
bench=0
for a in "$@"; do
  case "$a" in
    --asan) build_asan=1 ;;
    --bench) bench=1 ;;
    --no-build) build=0 ;;
    *) echo "setup: unknown option $a" >&2; exit 2 ;;
  esac
done
packages=(cmake g++ make libeigen3-dev libglm-dev libosd-dev libgtest-dev libgmock-dev libbenchmark-dev
          libpng-dev libcli11-dev zlib1g-dev)
[ $bench -eq 1 ] && packages+=(libmeshoptimizer-dev libopenmesh-dev libcgal-dev)
# Sample models: `varmesh compare` takes the cow and the bunny from this package's data.tar.gz when
# ../shared/data is absent. Installed without its recommends (a Qt development stack).
packages_no_recommends=(libcgal-demo)
missing_in() {
  local p
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || echo "$p"
  done
}
mapfile -t missing < <(missing_in "${packages[@]}")
mapfile -t missing_nr < <(missing_in "${packages_no_recommends[@]}")
if [ ${#missing[@]} -gt 0 ] || [ ${#missing_nr[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]} ${missing_nr[*]}" >&2
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  [ ${#missing[@]} -eq 0 ] || DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}" >/dev/null
  [ ${#missing_nr[@]} -eq 0 ] ||
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing_nr[@]}" >/dev/null
fi

[ $build -eq 1 ] || exit 0

jobs=$(nproc)
werror=OFF
[ "${CI:-}" = "true" ] && werror=ON
cmake -S . -B build/release -DCMAKE_BUILD_TYPE=Release -DVARMESH_WERROR=$werror >/dev/null
cmake --build build/release -j"$jobs"
if [ $build_asan -eq 1 ]; then
  cmake -S . -B build/asan -DCMAKE_BUILD_TYPE=Debug -DVARMESH_SANITIZE=ON -DVARMESH_BUILD_BENCH=OFF -DVARMESH_BUILD_SOAK=ON \
        -DVARMESH_WERROR=$werror >/dev/null
  cmake --build build/asan -j"$jobs"
fi
