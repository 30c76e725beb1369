#!/usr/bin/env bash
# Issue 25's steering figures for this tree (docs/performance.md#what-accuracy-costs-in-time):
# 1. `cargo xtask equal-time`: RMSE² of σ at equal time (--time 10s, rounds interleaved) against
#    8ae9f4f, Cornell box and stair wall, radiance and unweighted, 48², against cached independent
#    references (equal-time/ in cargo's target directory, scripts/target-dir.sh);
# 2. `cargo xtask first-command`: the README's first command as written, its wall time and the 95th
#    percentile of its relative error (reported, and actual against a cached reference in
#    first-command/ of the target directory);
# 3. `ftpd3d bench --slice z=0 --res 128 --spp 32` on the Cornell box and the stair wall: kernel rays/s over raw
#    Embree rays/s on the same rays (issue 25 asks for at least 0.6), this tree's release build.
# The baseline binary is $FTPD3D_BASELINE, or 8ae9f4f built once in a git worktree under the
# target directory (as scripts/efficiency.sh does; a release build of 8ae9f4f takes about 8 min
# on two idle cores).
#
#   scripts/steering.sh                         # all three, about 13 min on two idle cores
#   scripts/steering.sh --equal-time-only -- --scene scenes/cornell_mirror.obj --weight radiance
#   scripts/steering.sh --bench-only
#   FTPD3D_BASELINE=/path/to/ftpd3d-8ae9f4f scripts/steering.sh
#
# Flags after `--` go to `cargo xtask equal-time` (e.g. --rounds 6, --candidate LABEL=BIN).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
base_rev=8ae9f4f
equal=1
first=1
bench=1
extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    --equal-time-only) first=0; bench=0 ;;
    --first-command-only) equal=0; bench=0 ;;
    --bench-only) equal=0; first=0 ;;
    --) shift; extra=("$@"); break ;;
    *) echo "steering.sh: unknown argument $1 (use -- before the xtask's flags)" >&2; exit 2 ;;
  esac
  shift
done
. "$root/scripts/target-dir.sh"
if [ $equal -eq 1 ]; then
  baseline=${FTPD3D_BASELINE:-}
  if [ -z "$baseline" ]; then
    tree=$target/baseline-$base_rev/src
    baseline=$target/baseline-$base_rev/release/ftpd3d
    if [ ! -x "$baseline" ]; then
      [ -d "$tree" ] || git worktree add --detach "$tree" "$base_rev" >&2
      (cd "$tree" && CARGO_TARGET_DIR=$target/baseline-$base_rev cargo build --release --quiet --bin ftpd3d)
    fi
  fi
  [ -x "$baseline" ] || { echo "steering.sh: no baseline binary at $baseline" >&2; exit 1; }
  CARGO_TARGET_DIR=$target cargo xtask equal-time --baseline "$baseline" "${extra[@]}"
fi
if [ $first -eq 1 ]; then
  CARGO_TARGET_DIR=$target cargo xtask first-command
fi
if [ $bench -eq 1 ]; then
  CARGO_TARGET_DIR=$target cargo build --release --quiet --bin ftpd3d
  for s in cornell_mirror stair_wall; do
    echo "ftpd3d bench --res 128 --spp 32 --slice z=0 --scene scenes/$s.obj (load $(cut -d' ' -f1 /proc/loadavg))"
    "$target/release/ftpd3d" bench --res 128 --spp 32 --slice z=0 --scene "scenes/$s.obj"
  done
fi
