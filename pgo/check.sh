#!/usr/bin/env bash
# CI's check of the profile-guided build (.ci/run, after the tests): the release binary, built
# with the committed profile, renders every training scene, the FART scenes and the seed's room
# to the same bytes as the test build, which is built without it; and the profile is current:
# where this is the compiler that recorded it (pgo/recorded-with), a function whose code changed
# since (rustc warns "function control flow change detected") fails the check, as it would lose
# its optimisation silently. Re-record with `bash pgo/record.sh`. Last, a core built for
# x86-64-v3 must refuse an emulated older processor with a message, not `Illegal instruction`.
#
# Usage: pgo/check.sh                   builds the release binary, then checks it
#        pgo/check.sh --build-only LOG  builds it only, its output in LOG (.ci/run runs this in
#                                       the background, beside the tests)
#        pgo/check.sh --built LOG       checks the binary that `--build-only LOG` built
set -euo pipefail
cd "$(dirname "$0")/.."
case "$(uname -s)-$(uname -m)" in
Linux-x86_64) ;;
*)
    echo "pgo/check.sh: the profile applies to x86_64 Linux only; nothing to check here"
    exit 0
    ;;
esac
mode="${1:-}"
case "$mode" in
"") ;;
--build-only | --built)
    [ $# = 2 ] || { echo "pgo/check.sh: $mode needs one argument, the build's log" >&2; exit 2; }
    ;;
*)
    echo "pgo/check.sh: unknown argument $mode (usage: pgo/check.sh [--build-only|--built LOG])" >&2
    exit 2
    ;;
esac
# The warnings come only from a compile. Cleaning the core's release build alone forces one of it
# and of every crate above it; touching a source would also make the test build (`cargo test`'s)
# recompile them, which took 187 s on 2 cores.
if [ "$mode" = --build-only ]; then
    cargo clean --release -p strahl-core >"$2" 2>&1
    # The shell becomes the build, so that .ci/run stops the build when it stops this.
    exec cargo build --release -p strahl-host >>"$2" 2>&1
fi
log="$(mktemp)"
out="$(mktemp -d)"
trap 'rm -rf "$log" "$out"' EXIT
if [ "$mode" = --built ]; then
    cp "$2" "$log"
    cat "$log"
else
    cargo clean --release -p strahl-core
    cargo build --release -p strahl-host 2>&1 | tee "$log"
fi
if grep -q "control flow change detected" "$log"; then
    if grep -qx "rustc $(rustc -vV | sed -n 's/^release: //p')" pgo/recorded-with; then
        echo "pgo/check.sh: the profile is stale (functions above changed since it was recorded);" \
            "run: bash pgo/record.sh" >&2
        exit 1
    fi
    echo "pgo/check.sh: another compiler than pgo/recorded-with's; its hash warnings are not checked"
fi
# The binary `cargo test --workspace` built (a no-op after the tests; other feature sets rebuild).
cargo test --workspace --no-run -q
scenes=(pgo/scenes/*.nff scenes/fart/*.fart scenes/room/raytracer.cfg)
for scene in "${scenes[@]}"; do
    for build in release debug; do
        target/$build/strahl render "$scene" -w 96 -h 72 -m 2 -d 5 --workers 2 -q \
            --reflections on -o "$out/$build.png"
    done
    if ! cmp -s "$out/release.png" "$out/debug.png"; then
        echo "pgo/check.sh: $scene: the release build's image differs from the test build's" >&2
        exit 1
    fi
done
echo "pgo/check.sh: ${#scenes[@]} scenes byte-identical from the profile-guided release build"
# A release core built for x86-64-v3 refuses, with the fix, a processor without its extensions
# (an emulated Nehalem: SSE4.2, no AVX), instead of stopping at `Illegal instruction`.
if [ "$(sh pgo/rustc-wrapper --cpu)" = x86-64-v3 ]; then
    if ! command -v qemu-x86_64 >/dev/null; then
        echo "pgo/check.sh: qemu-x86_64 is missing; install it with: apt-get install qemu-user" >&2
        exit 1
    fi
    set +e
    qemu-x86_64 -cpu Nehalem target/release/strahl render scenes/fart/die.fart -w 8 -h 8 \
        --workers 1 -q -o "$out/old-cpu.png" 2>"$log"
    rc=$?
    set -e
    if [ "$rc" != 1 ] || ! grep -q "lacks avx, avx2, bmi1, bmi2, f16c, fma, lzcnt, movbe; build it" "$log" ||
        [ -e "$out/old-cpu.png" ]; then
        echo "pgo/check.sh: on an emulated Nehalem the release build exited $rc, wanted 1 and:" \
            "this processor lacks ...; build it ...; it wrote:" >&2
        cat "$log" >&2
        exit 1
    fi
    echo "pgo/check.sh: on an emulated Nehalem the x86-64-v3 build refuses to trace: $(cat "$log")"
fi
