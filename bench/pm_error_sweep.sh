#!/bin/bash
# How well the node error of a vertex hierarchy holds: for each mesh, `varmesh pm build` (default options),
# then `pm query --error E --measure` for E = k x the bounding-box diagonal over a range of k, and the worst
# ratio (max distance from the input's vertices to the result) / E, with the triangle counts.
# Usage: bench/pm_error_sweep.sh [VARMESH [DATA_MESHES_FOLDER]]
set -euo pipefail
V=${1:-build/release/apps/varmesh}
D=${2:-../shared/data/meshes}
[ -d "$D" ] || { echo "no data folder $D (see ../shared/data/MANIFEST.md)"; exit 0; }
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
for m in decimated-knight_502v.off cow_cgal_2904v.off mech-holes-shark_5246v.off elephant-with-holes_2798v.off \
         bunny_libigl_3485v.off fandisk_6475v.obj armadillo_cgal_26002v.off; do
  [ -f "$D/$m" ] || { echo "$m: missing, skipped"; continue; }
  "$V" pm build "$D/$m" -o "$W/h.vmh" --quiet > /dev/null
  diag=$("$V" info "$W/h.vmh" | grep -o "diagonal [0-9.e+-]*" | head -1 | cut -d' ' -f2)
  worst=0; at=0; counts=""
  for k in 0.0005 0.001 0.002 0.003 0.005 0.007 0.01 0.015 0.02; do
    E=$(awk -v k="$k" -v d="$diag" 'BEGIN { printf "%.9g", k * d }')
    out=$("$V" pm query "$W/h.vmh" --error "$E" -o "$W/q.obj" --measure)
    max=$(echo "$out" | grep -o "max [0-9.e+-]*" | head -1 | cut -d' ' -f2)
    counts="$counts $(echo "$out" | grep -oE "[0-9]+ triangles?" | head -1 | cut -d' ' -f1)"
    ratio=$(awk -v m="$max" -v e="$E" 'BEGIN { printf "%.2f", m / e }')
    if awk -v r="$ratio" -v w="$worst" 'BEGIN { exit !(r > w) }'; then worst=$ratio; at=$k; fi
  done
  echo "$m: worst max/E $worst (at E = $at x diagonal); triangles at each E:$counts"
done
