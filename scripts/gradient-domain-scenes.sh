#!/usr/bin/env bash
# Issue 34's per-scene figures (docs/performance.md#gradient-domain): on every shipped scene (slice
# z = 0, the tool's default weighting, flatland for flat_*; the courtyard through its sidecar), the
# squared error of σ and of its gradient view at equal time (5 s, 2 threads, 48², seed 1) of
# `--gradient-domain` and of up to two baseline builds' plain runs, against an 80 s
# gradient-domain run of seed 2 (16 times the samples, as in scripts/gradient-domain.sh). Scenes
# without lights run unweighted.
#
#   scripts/gradient-domain-scenes.sh BASELINE_BIN [OLDER_BIN]     # about 25 min on two cores
#
# Writes its EXRs to gradient-domain-scenes/ in cargo's target directory (scripts/target-dir.sh).
set -euo pipefail
base=${1:?usage: scripts/gradient-domain-scenes.sh BASELINE_BIN [OLDER_BIN]}
older=${2:-}
. "$(dirname "$0")/gradient-domain-setup.sh" gradient-domain-scenes
common="--res 48 --threads 2 --uniform --no-png --quiet"
for path in scenes/*.obj scenes/*.gltf scenes/courtyard/courtyard.toml; do
  name=$(basename "${path%.*}")
  args=(--scene "$path" --slice z=0)
  case "$name" in flat_*) args+=(--flatland) ;; esac
  if ! "$gd" "${args[@]}" --res 4 --spp 1 --no-png --quiet -o "$out/probe.exr" >/dev/null 2>&1; then
    args+=(--weight unweighted)
  fi
  [ -f "$out/ref_$name.exr" ] || "$gd" "${args[@]}" $common --seed 2 --time 80 --gradient-domain -o "$out/ref_$name.exr"
  "$gd" "${args[@]}" $common --seed 1 --time 5 --gradient-domain -o "$out/gd_$name.exr"
  "$base" "${args[@]}" $common --seed 1 --time 5 -o "$out/base_$name.exr"
  runs=("$out/gd_$name.exr" "$out/base_$name.exr")
  if [ -n "$older" ] && "$older" "${args[@]}" --res 48 --threads 2 --seed 1 --time 5 -o "$out/older_$name.exr" >/dev/null 2>&1; then
    runs+=("$out/older_$name.exr")
  fi
  echo "== $name (load $(cut -d' ' -f1 /proc/loadavg))"
  python3 scripts/field-error.py "$out/ref_$name.exr" "${runs[@]}"
done
