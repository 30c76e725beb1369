#!/usr/bin/env bash
# Time to the same error as the baseline estimator (8ae9f4f), per scene and weighting: builds this
# tree and (when no baseline binary is given) 8ae9f4f in a git worktree, then runs `cargo xtask
# efficiency` (developer tooling, xtask/), which computes an independent reference per scene with
# the baseline (another seed, 32x the largest level's samples) and prints a Markdown table: seconds
# each needs for the baseline's error at its largest level (RMSE of σ, 95th-percentile relative
# error), the ratio, the slopes of ln error against ln seconds, and the z variance of the standard
# errors.
#
#   scripts/efficiency.sh                      # a few minutes: 64² slices, 8..128 spp
#   scripts/efficiency.sh --long               # the published table: 128² slices, 16..512 spp
#                                              # (docs/performance.md#convergence)
#   FTPD3D_BASELINE=/path/to/ftpd3d scripts/efficiency.sh   # an existing baseline build
#   scripts/efficiency.sh -- --scene scenes/glass_sphere.obj --weight radiance   # other xtask flags
#
# Every run's EXR and efficiency.csv go to out/efficiency (or $FTPD3D_EFFICIENCY_DIR).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
base_rev=8ae9f4f
mode=short
extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    --long) mode=long ;;
    --) shift; extra=("$@"); break ;;
    *) echo "efficiency.sh: unknown argument $1 (use -- before the xtask's flags)" >&2; exit 2 ;;
  esac
  shift
done
. "$root/scripts/target-dir.sh"
CARGO_TARGET_DIR=$target cargo build --release --quiet
candidate=$target/release/ftpd3d
baseline=${FTPD3D_BASELINE:-}
if [ -z "$baseline" ]; then
  tree=$target/baseline-$base_rev/src
  baseline=$target/baseline-$base_rev/release/ftpd3d
  if [ ! -x "$baseline" ]; then
    if [ ! -d "$tree" ]; then
      git worktree add --detach "$tree" "$base_rev" >&2
    fi
    (cd "$tree" && CARGO_TARGET_DIR=$target/baseline-$base_rev cargo build --release --quiet)
  fi
fi
[ -x "$baseline" ] || { echo "efficiency.sh: no baseline binary at $baseline" >&2; exit 1; }
work=${FTPD3D_EFFICIENCY_DIR:-$root/out/efficiency}
if [ "$mode" = long ]; then
  sizes=(--res 128 --start-spp 16 --max-spp 512)
else
  sizes=(--res 64 --start-spp 8 --max-spp 128)
fi
scenes=()
has_scene=0
for a in "${extra[@]}"; do [ "$a" = --scene ] && has_scene=1; done
if [ $has_scene -eq 0 ]; then
  for s in cornell_mirror stair_wall glass_sphere; do scenes+=(--scene "scenes/$s.obj"); done
fi
CARGO_TARGET_DIR=$target cargo xtask efficiency --baseline "$baseline" --candidate "$candidate" \
  --work-dir "$work/$mode" --keep-references "${sizes[@]}" "${scenes[@]}" "${extra[@]}"
