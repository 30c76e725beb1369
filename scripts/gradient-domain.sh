#!/usr/bin/env bash
# Issue 34's steering figures (docs/performance.md#gradient-domain): at equal time (10 s, 2 threads,
# 48², seed 1, rounds interleaved) the field's and the gradient view's squared error (Sobel of
# `ftpd`) of `--gradient-domain` against a baseline build, on the Cornell box (radiance, z = 0) and
# the flatland stair wall (radiance), each against a 160 s gradient-domain run of seed 2.
#
#   scripts/gradient-domain.sh BASELINE_BIN [OLDER_BIN]     # about 9 min on two cores
#
# Writes its EXRs to gradient-domain/ in cargo's target directory (scripts/target-dir.sh).
set -euo pipefail
base=${1:?usage: scripts/gradient-domain.sh BASELINE_BIN [OLDER_BIN]}
older=${2:-}
. "$(dirname "$0")/gradient-domain-setup.sh" gradient-domain
common="--res 48 --threads 2 --uniform --no-png --quiet"
for s in cornell flat_stair; do
  [ -f "$out/ref_$s.exr" ] || "$gd" ${scene[$s]} $common --seed 2 --time 160 --gradient-domain -o "$out/ref_$s.exr"
done
for round in 1 2; do
  for s in cornell flat_stair; do
    echo "round $round, $s, load $(cut -d' ' -f1 /proc/loadavg)"
    "$gd" ${scene[$s]} $common --seed 1 --time 10 --gradient-domain -o "$out/gd_${s}_$round.exr"
    "$base" ${scene[$s]} $common --seed 1 --time 10 -o "$out/base_${s}_$round.exr"
    if [ -n "$older" ]; then
      "$older" ${scene[$s]} --res 48 --threads 2 --seed 1 --time 10 -o "$out/older_${s}_$round.exr" >/dev/null 2>&1
    fi
  done
done
for s in cornell flat_stair; do
  python3 scripts/field-error.py "$out/ref_$s.exr" "$out"/*_"${s}"_[12].exr
done
