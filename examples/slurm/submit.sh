#!/bin/bash
# Queues a split run and its merge: the array job, then the merge with afterok on the whole array.
#
#   examples/slurm/submit.sh tiles    # stripes of one grid (ftpd3d-array.sbatch)
#   examples/slurm/submit.sh seeds    # whole grids with different seeds (ftpd3d-seeds.sbatch)
#
# Run it in the directory that should receive part_*.exr and all.exr. Settings travel in the
# environment (sbatch exports it): FTPD3D, SCENE, SLICE, RES, SPP, SEED, PARTS, OUT, e.g.
#   SCENE=$PWD/scenes/cornell_mirror.obj RES=2048 SPP=4096 examples/slurm/submit.sh tiles
# With another PARTS, the array size follows it (--array=0-$((PARTS-1)) on the command line
# overrides the script's #SBATCH line).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
mode=${1:-tiles}
case "$mode" in
    tiles) script=ftpd3d-array.sbatch ;;
    seeds) script=ftpd3d-seeds.sbatch ;;
    *) echo "usage: $0 [tiles|seeds]" >&2; exit 2 ;;
esac
export PARTS=${PARTS:-16}
jobid=$(sbatch --parsable --export=ALL --array="0-$((PARTS - 1))" "$here/$script")
jobid=${jobid%%;*}                  # "id;cluster" on federated clusters
echo "array job $jobid: $PARTS tasks ($mode)"
sbatch --parsable --export=ALL --dependency="afterok:$jobid" "$here/ftpd3d-merge.sbatch"
