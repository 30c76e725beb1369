#!/usr/bin/env bash
# The paper's figures as a gallery: renders every run of scenes/paper/gallery.txt (written by
# scenes/generate_paper.py) with --separatrices into out/gallery/, writes the integrated radiance
# (fluence) or a camera's beauty image as NAME.radiance.png, times each run, and copies the
# pictures docs/gallery.md (and one in README.md) shows to docs/img/gallery/ (σ with the
# separatrices over it; the radiance of Figs. 5 and 7c).
#
#   scripts/gallery.sh                       # every run, one after the other
#   scripts/gallery.sh fig5_glass fig7c_courtyard   # only these
#
# Environment: THREADS (worker threads, default all cores), EXTRA (more ftpd3d arguments, e.g.
# "--seed 2"), NO_DOCS=1 (leave docs/img/gallery/ alone). The run times go to out/gallery/times.tsv.
set -euo pipefail
cd "$(dirname "$0")/.."

. scripts/target-dir.sh
cargo build --release --quiet --bin ftpd3d --example radiance_png
bin="$target/release/ftpd3d"
topng="$target/release/examples/radiance_png"

out=out/gallery
docs=docs/img/gallery
mkdir -p "$out"
[[ -n "${NO_DOCS:-}" ]] || mkdir -p "$docs"
times="$out/times.tsv"
[[ -f "$times" ]] || printf 'name\tfigure\twall_s\tcpu_s\tthreads\tload\n' > "$times"
threads=(); [[ -n "${THREADS:-}" ]] && threads=(--threads "$THREADS")

want=" $* "
only=$#
while IFS=$'\t' read -r name figure what args; do
    [[ -z "$name" || "$name" == \#* ]] && continue
    [[ $only -gt 0 && "$want" != *" $name "* ]] && continue
    echo "== Fig. $figure, $name: $what"
    read -ra argv <<< "$args"       # space-separated words, no quoting (tests/gallery.rs checks)
    echo "   ftpd3d $args --separatrices"
    # Wall-clock and CPU seconds (user + system) of the run, by bash's `time`; on a shared machine
    # the CPU seconds are the steadier figure.
    TIMEFORMAT='%R %U %S'
    # shellcheck disable=SC2086  # EXTRA is split into words on purpose
    { time "$bin" "${argv[@]}" ${EXTRA:-} "${threads[@]}" --separatrices --quiet \
        -o "$out/$name.exr" < /dev/null 2>&3; } 3>&2 2> "$out/$name.time"
    read -r wall user sys < "$out/$name.time"
    cpu=$(awk -v u="$user" -v s="$sys" 'BEGIN { printf "%.1f", u + s }')
    load=$(cut -d' ' -f1 /proc/loadavg)
    printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$name" "$figure" "$wall" "$cpu" "${THREADS:-$(nproc)}" \
        "$load" >> "$times"
    echo "   ${wall} s wall, ${cpu} s CPU (load average ${load})"
    if [[ " $args " == *" --camera "* || " $args " != *" --weight "* ]]; then
        "$topng" "$out/$name.exr" "$out/$name.radiance.png" < /dev/null > /dev/null
    fi
    if [[ -z "${NO_DOCS:-}" ]]; then
        # docs/gallery.md shows σ with the separatrices over it (NAME.png, σ alone, stays in out/),
        # as palette PNGs to keep the repository small.
        python3 scripts/png_palette.py "$out/$name.sep.png" "$docs/$name.sep.png"
        if [[ "$name" == fig5_* || "$name" == fig7c_* ]]; then
            python3 scripts/png_palette.py "$out/$name.radiance.png" "$docs/$name.radiance.png"
        fi
    fi
done < scenes/paper/gallery.txt
echo "times: $times"
