#!/usr/bin/env bash
# Outputs of a fixed set of fixed-seed runs, as a digest of every channel, header attribute and
# file (examples/output_digest.rs; wall-clock times left out). A refactor must leave the digest
# unchanged, to the bit:
#
#   scripts/same-outputs.sh [BIN]          # runs BIN (default TARGET/release/ftpd3d); digest in TARGET/same-outputs/digest.txt
#   scripts/same-outputs.sh --check [BIN]  # the same, then compares it with tests/data/same-outputs.digest
#
# TARGET is cargo's target directory (scripts/target-dir.sh: ./target, or CARGO_TARGET_DIR); a
# relative BIN is read from the repository root. Outputs record the paths of their scene and of
# merged inputs, so the runs start in TARGET/same-outputs.cwd/, where `scenes` and `target` are
# links to the repository's scenes and to TARGET: every run names its files `scenes/...` and
# `target/same-outputs/...` wherever the target directory is.
#
# The runs cover the slice with each weighting (radiance, unweighted; importance on a camera
# image, the only domain that has it), an arbitrary plane, a glTF scene and the textured outdoor
# courtyard (sun, sky, environment map, cut-outs), a volume, the flatland kernel, a target-error run
# (adaptive passes), separatrices of a slice, a flatland slice and a volume, merges of seeds and
# tiles, and a resumed run. Each takes well under a second on two cores.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
. scripts/target-dir.sh
check=0
if [ "${1:-}" = "--check" ]; then
  check=1
  shift
fi
bin=${1:-$target/release/ftpd3d}
[ -x "$bin" ] || { echo "same-outputs: no binary at $bin (cargo build --release)" >&2; exit 2; }
case $bin in /*) ;; *) bin=$root/$bin ;; esac
mkdir -p "$target/same-outputs" "$target/same-outputs.cwd"
rm -f "$target/same-outputs"/*
cd "$target/same-outputs.cwd"
ln -sfn "$root/scenes" scenes
ln -sfn "$target" target
out=target/same-outputs
s=scenes
o=$out
run() { "$bin" "$@" --quiet; }

# Slices: radiance (the default) and unweighted, an arbitrary plane, a glTF scene.
run --scene "$s/cornell_mirror.obj" --slice z=0 --res 24 --spp 16 --seed 3 -o "$o/slice_radiance.exr"
run --scene "$s/stair_wall.obj" --slice z=0 --res 24 --spp 16 --seed 5 --weight unweighted -o "$o/slice_unweighted.exr"
run --scene "$s/glass_sphere.obj" --plane "origin=0,0.5,0 normal=1,0,1" --res 20 --spp 8 --seed 2 -o "$o/plane.exr"
run --scene "$s/cornell_point.gltf" --slice z=0 --res 20 --spp 8 --seed 4 -o "$o/gltf.exr"
run --scene "$s/courtyard/courtyard.toml" --slice y=1 --res 20 --spp 8 --seed 6 -o "$o/courtyard.exr"
run --scene "$s/cornell_mirror.obj" --slice z=0 --res 24 --spp 16 --seed 3 --threads 1 -o "$o/threads1.exr"
# Importance: a camera image.
run --scene "$s/cornell_mirror.obj" --eye 0,1,3.5 --target 0,1,0 --size 24,16 --spp 8 --seed 7 -o "$o/camera.exr"
# A volume, flatland, and a run that stops at a target error (adaptive passes).
run --scene "$s/cornell_mirror.obj" --volume 8 --spp 8 --seed 1 -o "$o/volume.vti"
run --scene "$s/flat_mirrors.obj" --slice z=0 --flatland --res 24 --spp 16 --seed 8 -o "$o/flatland.exr"
run --scene "$s/stair_wall.obj" --slice z=0 --res 16 --target-error 0.3 --pass-spp 4 --seed 9 --weight unweighted -o "$o/target.exr"
# Separatrices of a slice, a flatland slice and a volume.
run separatrices "$o/slice_radiance.exr" -o "$o/sep_slice.exr"
run separatrices "$o/flatland.exr" -o "$o/sep_flatland.exr"
run separatrices "$o/volume.vti" -o "$o/sep_volume.vti"
# Merges: two seeds of a slice; two tiles of a volume.
run --scene "$s/cornell_mirror.obj" --slice z=0 --res 24 --spp 16 --seed 4 -o "$o/seed4.exr"
run merge "$o/slice_radiance.exr" "$o/seed4.exr" -o "$o/merged_seeds.exr"
run --scene "$s/cornell_mirror.obj" --volume 8 --spp 8 --seed 1 --tile 0/2 -o "$o/tile0.vti"
run --scene "$s/cornell_mirror.obj" --volume 8 --spp 8 --seed 1 --tile 1/2 -o "$o/tile1.vti"
run merge "$o/tile0.vti" "$o/tile1.vti" -o "$o/merged_tiles.vti"
# Resume: 8 spp, then resumed to 16 (must equal the 16-spp run of the same seed).
run --scene "$s/stair_wall.obj" --slice z=0 --res 24 --spp 8 --pass-spp 2 --seed 5 --weight unweighted -o "$o/resumed.exr"
run --scene "$s/stair_wall.obj" --slice z=0 --res 24 --spp 16 --pass-spp 2 --seed 5 --weight unweighted --resume "$o/resumed.exr"

cd "$root"
out=$target/same-outputs
digest=$(cargo run --quiet --release --example output_digest -- "$out")
# One thread and all threads: the same field.
if ! diff <(echo "$digest" | grep '^slice_radiance.exr ' | cut -d' ' -f2-) \
          <(echo "$digest" | grep '^threads1.exr ' | cut -d' ' -f2-) >/dev/null; then
  echo "same-outputs: --threads 1 and the default thread count give different fields" >&2
  exit 1
fi
if [ $check = 1 ]; then
  if diff <(echo "$digest") tests/data/same-outputs.digest; then
    echo "same-outputs: every channel, attribute and file as recorded"
  else
    echo "same-outputs: outputs differ from tests/data/same-outputs.digest (lines above)" >&2
    exit 1
  fi
else
  echo "$digest" > "$out/digest.txt"
  echo "same-outputs: $(echo "$digest" | wc -l) lines in $out/digest.txt"
fi
