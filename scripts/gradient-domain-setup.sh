# Sourced by the gradient-domain measurement scripts (scripts/gradient-domain.sh,
# scripts/gradient-domain-scenes.sh, scripts/separatrix-lines.sh) after their own arguments are
# checked: the repository root as working directory, cargo's target directory
# (scripts/target-dir.sh), a release build of the current tree as $gd, $out = TARGET/$1 created,
# and issue 34's two steering scenes in $scene (the Cornell box and the flatland stair wall, both
# radiance-weighted, z = 0).
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
. "$root/scripts/target-dir.sh"
cargo build --release --quiet --bin ftpd3d
gd=$target/release/ftpd3d
out=$target/${1:?gradient-domain-setup.sh: name the output directory}
mkdir -p "$out"
declare -A scene=(
  [cornell]="--scene scenes/cornell_mirror.obj --slice z=0 --weight radiance"
  [flat_stair]="--scene scenes/flat_stair_wall.obj --slice z=0 --flatland --weight radiance"
)
