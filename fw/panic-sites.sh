#!/usr/bin/env bash
# Lists the functions of the full firmware image (all fusion methods, every entry point called
# with opaque sizes) that still call a panic entry point of `core`. Empty output = the image
# would pass `--features panic-check`. Needs `rustup component add llvm-tools`.
# Usage: fw/panic-sites.sh [--target riscv32imac-unknown-none-elf]
set -euo pipefail
cd "$(dirname "$0")"
target=thumbv7em-none-eabihf
if [[ "${1:-}" == "--target" ]]; then target="$2"; fi
cargo build --release --quiet --target "$target" --features exercise
objdump=$(find "$(rustc --print sysroot)" -name llvm-objdump -type f | head -1)
objdump=${objdump:-$(command -v llvm-objdump || true)}
if [[ -z "$objdump" ]]; then
  echo "llvm-objdump not found: rustup component add llvm-tools" >&2
  exit 2
fi
# Callers (besides the panic entry points themselves) of panic_fmt/panic/slice index failures/unwrap_failed etc.
"$objdump" -d --demangle --no-show-raw-insn "target/$target/release/fusion-fw" |
  awk '/^[0-9a-f]+ <.*>:$/ { fn = substr($0, index($0, "<") + 1); sub(/>:$/, "", fn); next }
       /<(core::panicking::|core::slice::index::slice_index_fail|core::option::unwrap_failed|core::result::unwrap_failed|core::slice::copy_from_slice_impl::len_mismatch_fail|core::str::slice_error_fail)/ {
         callee = substr($0, index($0, "<") + 1); sub(/>.*/, "", callee); sub(/\+0x[0-9a-f]+$/, "", callee)
         # Not the panic entry points themselves; functions of core such as sort and zip do count.
         if (fn !~ /^core::(panicking::|option::|result::|slice::index::|str::slice_error_fail|slice::copy_from_slice_impl)/) print fn " -> " callee
       }' | sed -E 's/::h[0-9a-f]{16}//g' | sort | uniq -c | sort -rn
