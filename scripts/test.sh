#!/usr/bin/env bash
# Runs every test: set-up (packages + both builds), the Release suite, the ASan+UBSan suite, a minute of the
# pm soak (tests/pm/pm_soak.cpp) under the sanitizers, and the find_package(varmesh) consumer project built
# against an installed copy (with README's C++ examples).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh --asan
jobs=$(nproc)

echo "== Release tests =="
ctest --test-dir build/release --output-on-failure -j"$jobs"

echo "== ASan + UBSan tests =="
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build/asan --output-on-failure -j"$jobs"

echo "== pm soak (a minute of random walks and queries against the dual-piece oracle, sanitizers on) =="
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  build/asan/tests/pm_soak --fixtures --seconds 60 --case-seconds 0.3 | grep -B1 -E "FAIL|^TOTAL"

echo "== Installed package consumer =="
rm -rf build/install build/consumer
cmake --install build/release --prefix build/install >/dev/null
mkdir -p build/consumer
scripts/readme_snippets.sh README.md build/consumer/readme_snippets.cpp
cmake -S examples/consumer -B build/consumer -DCMAKE_PREFIX_PATH="$PWD/build/install" \
  -DVARMESH_SNIPPETS="$PWD/build/consumer/readme_snippets.cpp" >/dev/null
cmake --build build/consumer -j"$jobs" >/dev/null
build/consumer/consumer
