#!/usr/bin/env bash
# The terrain comparison of BENCHMARKS.md: varmesh's 4-8 hierarchy and mapbox/martini on the same heights
# and thresholds, back to back on this machine. Needs node + npm (martini is installed from the npm registry
# into build/bench_node on first use). usage: bench/compare_terrain.sh
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh >/dev/null
out=build/bench_terrain
mkdir -p "$out" build/bench_node
echo "== varmesh (build/release/bench/varmesh_terrain_bench) =="
build/release/bench/varmesh_terrain_bench "$out" ../shared/data
if ! command -v node >/dev/null; then echo "node not found: martini comparison skipped"; exit 0; fi
if [ ! -d build/bench_node/node_modules/@mapbox/martini ]; then
  (cd build/bench_node && echo '{"name":"bench","private":true,"type":"module"}' > package.json &&
   npm install --silent @mapbox/martini@0.2.0 >/dev/null)
fi
echo "== mapbox/martini 0.2.0 (node $(node --version)) =="
cp bench/martini_compare.mjs build/bench_node/
(cd build/bench_node && node martini_compare.mjs "../../$out/manifest.json")
