#!/bin/bash
# Races Strahl's whole process against rs_pbrt's (pbrt-v3's Whitted integrator) on NFF scenes:
# both at 512x512, depth 5, one sample, two threads, alternating, medians of RUNS wall-clock
# times (reading, building and writing included). The scenes are converted by nff2pbrt.py,
# whose approximations (materials, cones) are listed there: compare times, not pictures.
#
#   bench/rs_pbrt/race.sh RUNS SCENE.nff...
#
# STRAHL names the strahl binary (default target/release/strahl), RS_PBRT rs_pbrt's
# (default: rs_pbrt on the PATH; `cargo install rs_pbrt --version 0.9.12 --locked`).
set -euo pipefail
runs=$1
shift
here=$(cd "$(dirname "$0")" && pwd)
strahl=${STRAHL:-target/release/strahl}
rs_pbrt=${RS_PBRT:-rs_pbrt}
command -v "$rs_pbrt" >/dev/null || {
    echo "race.sh: $rs_pbrt not found; cargo install rs_pbrt --version 0.9.12 --locked" >&2
    exit 1
}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
seconds() { # the wall-clock seconds of a command, which must succeed
    local t0 t1
    t0=$(date +%s.%N)
    "$@" >/dev/null 2>&1 || { echo "race.sh: failed: $*" >&2; exit 1; }
    t1=$(date +%s.%N)
    echo "$t1 - $t0" | bc
}
median() { tr ' ' '\n' <<<"$*" | grep . | sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
echo "| scene | rs_pbrt s | Strahl s | Strahl / rs_pbrt |"
echo "|---|---|---|---|"
for nff in "$@"; do
    name=$(basename "$nff" .nff)
    python3 "$here/nff2pbrt.py" "$nff" "$work/$name" 512 5
    r="" s=""
    for _ in $(seq "$runs"); do
        # rs_pbrt writes its image into the current folder: run it in the scratch folder.
        r="$r $(cd "$work" && seconds "$rs_pbrt" -i whitted -t 2 -s 1 -p "$work/$name.pbrt")"
        s="$s $(seconds "$strahl" render "$nff" -w 512 -h 512 -m 1 -d 5 --workers 2 -q -o "$work/$name.bmp")"
    done
    mr=$(median $r)
    ms=$(median $s)
    printf '| %s | %.3f | %.3f | %.2f |\n' "$name" "$mr" "$ms" "$(echo "$ms / $mr" | bc -l)"
done
