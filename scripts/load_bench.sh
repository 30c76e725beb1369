#!/bin/sh
# The loading benchmark on the 10 M-triangle scene of docs/performance.md#loading-10-m-triangles
# (generated, not shipped):
# writes it with heavy_scene.py into a temporary directory (about 1.2 GB; DIR to choose another
# place), loads it once with the load_bench example under /usr/bin/time -v, prints the example's
# figures and the process's CPU seconds and peak memory, and deletes the scene again.
#
#     scripts/load_bench.sh [SPHERES_PER_SIDE] [DIR]
#
# SPHERES_PER_SIDE is 20 (10.2 M triangles, with vn, vt and 300 materials); 8 gives 655 k
# triangles in 68 MB for a quick run. RUNS=N loads the scene N times (one process each, default 1):
# on a shared machine the CPU seconds (user + system) vary less than the wall time, and the
# example's estimate for two free cores (serial CPU + the rest / 2) does not depend on the load.
set -eu
n=${1:-20}
root=$(cd "$(dirname "$0")/.." && pwd)
if [ -n "${2:-}" ]; then
    dir=$2
    mkdir -p "$dir"
    trap 'rm -f "$dir/heavy_$n.obj" "$dir/heavy_$n.mtl" "$dir/time.txt"' EXIT
else
    dir=$(mktemp -d)
    trap 'rm -rf "$dir"' EXIT
fi
python3 "$root/scripts/heavy_scene.py" "$dir/heavy_$n.obj" "$n" 3 --attributes --materials 300
cd "$root"
. scripts/target-dir.sh
cargo build --release --example load_bench
for _ in $(seq "${RUNS:-1}"); do
    /usr/bin/time -v "$target/release/examples/load_bench" "$dir/heavy_$n.obj" \
        2>"$dir/time.txt"
    grep -E 'User time|System time|Elapsed|Maximum resident' "$dir/time.txt"
done
