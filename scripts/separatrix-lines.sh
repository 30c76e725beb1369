#!/usr/bin/env bash
# Issue 34's separatrix figures (docs/performance.md#gradient-domain): at equal time (10 s,
# 2 threads, 96², seed $SEED, default 1) the separatrix lines of `--gradient-domain` and of a baseline build's
# plain run against those of a 160 s gradient-domain run of seed 2, on the flatland stair wall and
# the Cornell box (radiance): how many reference lines each finds, how many lines it draws that
# the reference has not (scripts/separatrix-lines.py).
#
#   [SEED=N] scripts/separatrix-lines.sh BASELINE_BIN     # about 7 min on two cores
#
# Writes its EXRs to separatrix-lines/ in cargo's target directory (scripts/target-dir.sh).
set -euo pipefail
base=${1:?usage: [SEED=N] scripts/separatrix-lines.sh BASELINE_BIN}
seed=${SEED:-1}
[ "$seed" != 2 ] || { echo "separatrix-lines.sh: seed 2 is the reference's" >&2; exit 2; }
. "$(dirname "$0")/gradient-domain-setup.sh" separatrix-lines
common="--res 96 --threads 2 --uniform --no-png --quiet --separatrices"
for s in flat_stair cornell; do
  [ -f "$out/ref_$s.exr" ] || "$gd" ${scene[$s]} $common --seed 2 --time 160 --gradient-domain -o "$out/ref_$s.exr"
  "$gd" ${scene[$s]} $common --seed "$seed" --time 10 --gradient-domain -o "$out/gd${seed}_$s.exr"
  "$base" ${scene[$s]} $common --seed "$seed" --time 10 -o "$out/base${seed}_$s.exr"
  python3 scripts/separatrix-lines.py "$out/ref_$s.exr" "$out/gd${seed}_$s.exr" "$out/base${seed}_$s.exr"
done
