#!/bin/bash
# Queues a split run and its merge: the array job, then the merge, which starts when every task
# has ended (afterany) and names any part that is missing.
#
#   examples/slurm/submit.sh tiles [SBATCH OPTIONS...]   # stripes of one grid (ftpd3d-array.sbatch)
#   examples/slurm/submit.sh seeds [SBATCH OPTIONS...]   # whole grids, other seeds (ftpd3d-seeds.sbatch)
#
# Run it in the directory that should receive part_*.exr and all.exr. Settings travel in the
# environment (sbatch exports it): FTPD3D, SCENE, SLICE, RES, SPP, SEED, PARTS, OUT, and for Slurm
# CPUS (--cpus-per-task of each task; the cluster's default otherwise) and PARTITION. Options after
# the mode go to both sbatch calls as they are (e.g. --account=proj --qos=short). E.g.
#   SCENE=scenes/cornell_mirror.obj RES=2048 SPP=4096 CPUS=16 examples/slurm/submit.sh tiles -p gpu
# A relative SCENE or FTPD3D is made absolute here, so that the jobs find it from their working
# directory. With another PARTS, the array size follows it (--array=0-$((PARTS-1)) on the command
# line overrides the script's #SBATCH line).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
mode=${1:-tiles}
shift || true
case "$mode" in
    tiles) script=ftpd3d-array.sbatch ;;
    seeds) script=ftpd3d-seeds.sbatch ;;
    *) echo "usage: $0 [tiles|seeds] [sbatch options...]" >&2; exit 2 ;;
esac
export PARTS=${PARTS:-16}
export SCENE=${SCENE:-$here/../../scenes/cornell_mirror.obj}
case "$SCENE" in /*) ;; *) SCENE="$PWD/$SCENE" ;; esac
if [ ! -f "$SCENE" ]; then
    echo "SCENE=$SCENE: no such scene file" >&2
    exit 2
fi
if [ -n "${FTPD3D:-}" ] && [[ "$FTPD3D" == */* ]] && [[ "$FTPD3D" != /* ]]; then
    export FTPD3D="$PWD/$FTPD3D"
fi
export ARRAY_SCRIPT="$here/$script"
opts=(--export=ALL)
if [ -n "${CPUS:-}" ]; then
    opts+=(--cpus-per-task="$CPUS")
fi
if [ -n "${PARTITION:-}" ]; then
    opts+=(--partition="$PARTITION")
fi
opts+=("$@")
jobid=$(sbatch --parsable "${opts[@]}" --array="0-$((PARTS - 1))" "$here/$script")
jobid=${jobid%%;*}                  # "id;cluster" on federated clusters
echo "array job $jobid: $PARTS tasks ($mode)"
sbatch --parsable --export=ALL ${PARTITION:+--partition="$PARTITION"} "$@" \
    --dependency="afterany:$jobid" "$here/ftpd3d-merge.sbatch"
