#!/usr/bin/env bash
# Builds the C interface and its example for the host and for a Cortex-M7, and checks that both
# give the bytes of the `fusion` CLI on the committed pair, for every method and variant, whole
# frame and strips. Also: the Rust tests (header freshness included), clippy, and the link-time
# proof that no panic path is reachable from any exported function on the Cortex-M7.
#
#   fusion-ffi/check.sh [PATH/TO/fusion]      (default: target/release/fusion of the workspace)
#
# Needs: cc, arm-none-eabi-gcc with newlib (Debian: gcc-arm-none-eabi libnewlib-arm-none-eabi),
# qemu-system-arm, the Rust target thumbv7em-none-eabihf.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
fusion="$(realpath "${1:-$here/../target/release/fusion}")"
cd "$here"
out="target/c"
mkdir -p "$out"

echo "-- fusion-ffi: format, clippy, tests (header freshness included)"
cargo fmt -- --check
cargo clippy --release --all-targets -- -D warnings
cargo test --release

echo "-- fusion-ffi: host static library and the C example"
cargo build --release
cc -std=c11 -O2 -Wall -Wextra -Werror -Iinclude examples/fuse.c target/release/libfusion_ffi.a \
  -Wl,--gc-sections -o "$out/fuse"

echo "-- fusion-ffi: Cortex-M7 static library (panic-check: the link fails if a panic is reachable)"
m7=(-mcpu=cortex-m7 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16)
m7_link() { # $1: static library, $2: output ELF, rest: extra flags
  local lib="$1" elf="$2"
  shift 2
  arm-none-eabi-gcc "${m7[@]}" -O2 -std=c11 -Wall -Wextra -Werror -Iinclude -ffunction-sections -fdata-sections \
    -nostartfiles --specs=rdimon.specs -T examples/cortex-m7/mps2-an500.ld \
    examples/fuse.c examples/cortex-m7/startup.c "$lib" -Wl,--gc-sections -Wl,--no-warn-execstack "$@" -o "$elf"
}
# (`cargo rustc --crate-type staticlib`: the bare-metal target has no shared library.)
cargo rustc --release --target thumbv7em-none-eabihf --crate-type staticlib --features panic-check
# Every function of the header kept in the image (-u), not only the example's.
keep=()
for f in $(grep -oE '\bfusion_[a-z0-9_]+\(' include/fusion.h | tr -d '(' | sort -u); do keep+=("-Wl,-u,$f"); done
m7_link target/thumbv7em-none-eabihf/release/libfusion_ffi.a "$out/panic-check.elf" "${keep[@]}"
echo "no panic path reachable from ${#keep[@]} exported functions (Cortex-M7 link)"
cargo rustc --release --target thumbv7em-none-eabihf --crate-type staticlib
m7_link target/thumbv7em-none-eabihf/release/libfusion_ffi.a "$out/fuse-m7.elf"

echo "-- fusion-ffi: the C example against the fusion CLI (host and Cortex-M7 under QEMU)"
data="examples/data"
run_m7() { # the example's arguments, as semihosting arguments; QEMU runs in $data
  local args="arg=fuse"
  for a in "$@"; do args="$args,arg=$a"; done
  (cd "$data" && timeout 300 qemu-system-arm -machine mps2-an500 -cpu cortex-m7 -nographic \
    -semihosting-config "enable=on,target=native,$args" -kernel "$here/$out/fuse-m7.elf")
}
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
n=0
for m in adf tsifsd ifevip adaptive; do
  for v in flight classic; do
    "$fusion" fuse --method "$m" --variant "$v" "$data/vis_256.pgm" "$data/tir_128.pgm" "$tmp/cli.pgm" 2>/dev/null
    for s in "" strips; do
      "$out/fuse" "$data/vis_256.pgm" "$data/tir_128.pgm" "$tmp/host.pgm" "$m" "$v" $s >/dev/null
      cmp "$tmp/host.pgm" "$tmp/cli.pgm"
      run_m7 vis_256.pgm tir_128.pgm "$tmp/m7.pgm" "$m" "$v" $s >/dev/null
      cmp "$tmp/m7.pgm" "$tmp/cli.pgm"
      n=$((n + 2))
    done
  done
done
echo "$n C runs (host and Cortex-M7, whole frame and strips) byte-identical to fusion fuse"

# Errors: one line and a failure status, on both.
if "$out/fuse" "$data/missing.pgm" "$data/tir_128.pgm" "$tmp/x.pgm" adf 2>"$tmp/err"; then exit 1; fi
grep -q "cannot open" "$tmp/err"
if run_m7 vis_256.pgm tir_128.pgm "$tmp/x.pgm" fft 2>/dev/null >"$tmp/err"; then exit 1; fi
test ! -e "$tmp/x.pgm"
echo "errors: refused with status 1/2 and nothing written (host and Cortex-M7)"
