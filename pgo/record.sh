#!/usr/bin/env bash
# Records pgo/x86_64-unknown-linux-gnu.profdata, the profile that optimised x86_64 Linux builds of
# the workspace use (pgo/rustc-wrapper). Run it from anywhere on an x86_64 Linux machine after
# changing the tracer, and commit the profile with the change:
#
#   bash pgo/record.sh
#
# It builds `strahl` instrumented (`-Cprofile-generate`, in target/pgo-record, apart from the
# usual build), renders the training scenes below with it, and merges what they counted with the
# toolchain's own llvm-profdata (`rustup component add llvm-tools`), noting the compiler in
# pgo/recorded-with. The training renders cover every kind of primitive and effect the tracer has:
# the SPD scenes of pgo/scenes (spheres alone and overlapping, polygons, triangle meshes,
# cylinders and cones, reflection and refraction; made by SPD's own programs at small sizes), the
# FART scenes (CSG, boxes, planes, transparency; one with ambient occlusion) and the
# seed's room, with one and several samples per pixel. A function no render calls is compiled as
# without a profile (the profile is sparse), but a branch never taken in one they call is laid out
# as cold: hence renders of every kind.
#
# Every render has one worker, so the tracer's counts do not depend on timing and two recordings
# of the same code compile the same tracer. With two workers, which lines each traced (and so
# what its remembered shadow blockers held) and how many lines the end game traced twice
# depended on timing: two recordings of one commit compiled 18 of the core's 101 functions
# differently (docs/performance.md, thirty-first round), and a comparison of two profile-guided
# builds took that for the effect of a change.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd -P)"
cd "$root"
host="$(rustc -vV | sed -n 's/^host: //p')"
if [ "$host" != x86_64-unknown-linux-gnu ]; then
    echo "pgo/record.sh: the profile is recorded on x86_64 Linux; this toolchain's host is $host" >&2
    exit 1
fi
profdata="$(rustc --print sysroot)/lib/rustlib/$host/bin/llvm-profdata"
if [ ! -x "$profdata" ]; then
    echo "pgo/record.sh: $profdata is missing; install it with: rustup component add llvm-tools" >&2
    exit 1
fi
raw="$(mktemp -d)"
out="$(mktemp -d)"
trap 'rm -rf "$raw" "$out"' EXIT

# The wrapper must not add the old profile to the instrumented build.
STRAHL_PGO=off RUSTFLAGS="-Cprofile-generate=$raw" \
    cargo build --release -p strahl-host --target-dir target/pgo-record
strahl=target/pgo-record/release/strahl

render() {
    "$strahl" render "$@" -q -o "$out/image.png" >/dev/null
}
for scene in pgo/scenes/*.nff; do
    render "$scene" -w 160 -h 160 -m 1 -d 5 --workers 1
    render "$scene" -w 64 -h 64 -m 2 -d 5 --workers 1
done
for scene in scenes/fart/*.fart; do
    render "$scene" -w 120 -h 90 --workers 1
done
render scenes/fart/die.fart -w 64 -h 48 -a 2 --workers 1
render scenes/room/raytracer.cfg -w 160 -h 120 --reflections on --workers 1
render scenes/room/raytracer.cfg -w 160 -h 120 -m 3 --aa-threshold 0.1 --workers 1
"$strahl" bench --size 96 --runs 1 >/dev/null

"$profdata" merge --sparse -o pgo/x86_64-unknown-linux-gnu.profdata "$raw"
# The wrapper applies the profile only where the compiler's LLVM is at least this one.
rustc -vV | sed -n 's/^release: /rustc /p; s/^LLVM version: \([0-9]*\).*/llvm \1/p' >pgo/recorded-with
# ... and only to a core built for the processor level it was recorded with.
echo "cpu $(sh pgo/rustc-wrapper --cpu)" >>pgo/recorded-with
echo "pgo/record.sh: wrote pgo/x86_64-unknown-linux-gnu.profdata ($(wc -c <pgo/x86_64-unknown-linux-gnu.profdata) bytes)"
