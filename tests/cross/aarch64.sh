#!/usr/bin/env bash
# An aarch64 worker renders byte-identical pixels to the x86_64 master's own workers.
#
# Builds `strahl` for aarch64-unknown-linux-gnu (Debian's gcc-aarch64-linux-gnu links it), runs
# it as a TCP worker under qemu-aarch64 (Debian's qemu-user), and renders each scene three
# ways: local workers only, the aarch64 worker alone, and the aarch64 worker beside a local
# one. The three images must be identical to the byte. Any failure exits non-zero with what
# differed; nothing is skipped.
#
# Usage: tests/cross/aarch64.sh            (from anywhere; needs the packages above installed)
set -euo pipefail
cd "$(dirname "$0")/../.."

target=aarch64-unknown-linux-gnu
for tool in aarch64-linux-gnu-gcc qemu-aarch64; do
    command -v "$tool" >/dev/null || {
        echo "cross test: $tool not found (apt-get install gcc-aarch64-linux-gnu qemu-user)" >&2
        exit 1
    }
done

cargo build --release -q -p strahl-host
# The `cross` profile: release code without LTO, quicker to build (Cargo.toml).
cargo build --profile cross -q -p strahl-host --target "$target"
host_bin=target/release/strahl
arm_bin=target/$target/cross/strahl

work=$(mktemp -d)
worker_pid=
cleanup() {
    [ -n "$worker_pid" ] && kill "$worker_pid" 2>/dev/null || true
    rm -rf "$work"
}
trap cleanup EXIT

# The worker serves one master after another; it prints its address on stderr.
QEMU_LD_PREFIX=/usr/aarch64-linux-gnu qemu-aarch64 "$arm_bin" worker \
    --listen 127.0.0.1:0 --name aarch64-qemu 2>"$work/worker.err" &
worker_pid=$!
addr=
for _ in $(seq 1 300); do
    addr=$(sed -n 's/.*: listening on //p' "$work/worker.err" | head -n 1)
    [ -n "$addr" ] && break
    kill -0 "$worker_pid" 2>/dev/null || break
    sleep 0.1
done
if [ -z "$addr" ]; then
    echo "cross test: the aarch64 worker printed no address:" >&2
    cat "$work/worker.err" >&2
    exit 1
fi
# The worker must really be the emulated aarch64 binary.
grep -q "aarch64" "/proc/$worker_pid/cmdline" || {
    echo "cross test: the worker is not running under qemu-aarch64" >&2
    exit 1
}

spd=../shared/spd
scenes=(scenes/fart/glass.fart scenes/fart/die.fart scenes/fart/ring.fart scenes/room/raytracer.cfg)
[ -f "$spd/teapot_6.nff" ] && scenes+=("$spd/teapot_6.nff")
[ -f "$spd/balls_3.nff" ] && scenes+=("$spd/balls_3.nff")
checked=0
for scene in "${scenes[@]}"; do
    name=$(basename "$scene" | tr . _)
    size=(-w 96 -h 72)
    "$host_bin" render "$scene" "${size[@]}" -q --workers 2 -o "$work/$name-local.bmp"
    "$host_bin" render "$scene" "${size[@]}" -q --worker "$addr" -o "$work/$name-arm.bmp" \
        --stats-json "$work/$name-arm.json"
    "$host_bin" render "$scene" "${size[@]}" -q --worker "$addr" --workers 1 \
        -o "$work/$name-mixed.bmp"
    grep -q '"name": "aarch64-qemu"' "$work/$name-arm.json" || {
        echo "cross test: $scene was not rendered by the aarch64 worker" >&2
        cat "$work/$name-arm.json" >&2
        exit 1
    }
    for way in arm mixed; do
        cmp "$work/$name-local.bmp" "$work/$name-$way.bmp" || {
            echo "cross test: $scene: the $way image differs from the x86_64 one" >&2
            exit 1
        }
    done
    checked=$((checked + 1))
done
echo "cross test: $checked scenes byte-identical from an aarch64 worker, alone and mixed"
