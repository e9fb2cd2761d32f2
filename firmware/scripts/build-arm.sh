#!/usr/bin/env bash
# Build the bare-metal firmware ELF for the Zynq-7000's Cortex-A9 (armv7a-none-eabihf) with
# Debian's Rust toolchain (/usr/bin/cargo + /usr/bin/rustc 1.96 + rust-web-src, rebuilding
# `core` with -Zbuild-std) and rustup's rust-lld as the linker, then print its section sizes.
#
# Usage: scripts/build-arm.sh [--debug] [--defmt] [extra cargo build args...]
#   --debug   dev profile instead of release
#   --defmt   enable the `defmt` feature (defmt frames over semihosting to defmt.bin)
# Environment:
#   FW_TARGET_DIR  cargo target dir (default: <firmware>/target, git-ignored, separate from the
#                  host build's so the two cargos never wait on each other's lock)
#   RUST_LLD       linker to use (default: rust-lld found under ~/.rustup)
#   FW_RUSTFLAGS   extra rustc flags for the target
#   DEFMT_LOG      defmt level filter compiled in (default: info)
# Prints the ELF path as the last line: `FW_ELF=<path>`.
# Run scripts/install-toolchain.sh first on a fresh machine.
set -euo pipefail

FW_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
TARGET=armv7a-none-eabihf
PROFILE=release
FEATURES=()
EXTRA=()
while [ $# -gt 0 ]; do
    case "$1" in
        --debug) PROFILE=dev ;;
        --defmt) FEATURES+=(--features defmt) ;;
        *) EXTRA+=("$1") ;;
    esac
    shift
done

for f in /usr/bin/cargo /usr/bin/rustc; do
    [ -x "$f" ] || { echo "build-arm: $f missing: run $FW_DIR/scripts/install-toolchain.sh" >&2; exit 1; }
done
[ -d /usr/lib/rustlib/src/rust/library/core ] \
    || { echo "build-arm: Debian rust-web-src missing: run $FW_DIR/scripts/install-toolchain.sh" >&2; exit 1; }

# rust-lld: rustup ships it per toolchain; Debian's rustc does not.
find_lld() {
    if [ -n "${RUST_LLD:-}" ]; then
        echo "$RUST_LLD"
        return 0
    fi
    local home="${RUSTUP_HOME:-$HOME/.rustup}" c
    for c in "$home"/toolchains/stable-*/lib/rustlib/*/bin/rust-lld \
             "$home"/toolchains/*/lib/rustlib/*/bin/rust-lld; do
        if [ -x "$c" ]; then
            echo "$c"
            return 0
        fi
    done
    return 1
}
LLD="$(find_lld)" || { echo "build-arm: no rust-lld under ${RUSTUP_HOME:-$HOME/.rustup}/toolchains (set RUST_LLD)" >&2; exit 1; }

TARGET_DIR="${FW_TARGET_DIR:-$FW_DIR/target}"

# Debian's toolchain first; never rustup's proxies (they have no rust-src for -Zbuild-std).
export PATH="/usr/bin:$PATH"
export RUSTC=/usr/bin/rustc
unset RUSTC_WRAPPER RUSTC_WORKSPACE_WRAPPER RUSTUP_TOOLCHAIN RUSTFLAGS CARGO_ENCODED_RUSTFLAGS CARGO_BUILD_TARGET
export RUSTC_BOOTSTRAP=1
export CARGO_TARGET_ARMV7A_NONE_EABIHF_LINKER="$LLD"
# The linker script (link.x, + defmt.x with --defmt) is added by firmware/build.rs.
# +neon: the Cortex-A9's Advanced SIMD unit (start.rs enables it with the VFP); the decoder
# runs 4 pixels per NEON register (fsm_core::decoder::DEFAULT_LANES).
export CARGO_TARGET_ARMV7A_NONE_EABIHF_RUSTFLAGS="-C target-cpu=cortex-a9 -C target-feature=+neon ${FW_RUSTFLAGS:-}"
# Firmware-only profile tweaks (the workspace's [profile.release] stays as it is for the host).
export CARGO_PROFILE_RELEASE_LTO="${CARGO_PROFILE_RELEASE_LTO:-fat}"
export DEFMT_LOG="${DEFMT_LOG:-info}"

echo "build-arm: $(/usr/bin/cargo --version); $(/usr/bin/rustc --version); linker $LLD"
start=$(date +%s.%N)
/usr/bin/cargo build --manifest-path "$FW_DIR/Cargo.toml" -p fsm-firmware --bin fsm-firmware --profile "$PROFILE" \
    --target "$TARGET" -Zbuild-std=core --target-dir "$TARGET_DIR" \
    ${FEATURES[@]+"${FEATURES[@]}"} ${EXTRA[@]+"${EXTRA[@]}"}
end=$(date +%s.%N)

case "$PROFILE" in dev) dir=debug ;; *) dir="$PROFILE" ;; esac
ELF="$TARGET_DIR/$TARGET/$dir/fsm-firmware"
[ -f "$ELF" ] || { echo "build-arm: $ELF not produced" >&2; exit 1; }
# Cargo leaves an up-to-date ELF untouched even when a source it ignores for this target (e.g.
# a host-only dependency in Cargo.toml) is newer; the ELF is now current with every source,
# which is what tests/suite/qemu_crosscheck.rs checks by modification time.
touch "$ELF"

# Section sizes, `size`-style (Berkeley: text = allocated read-only incl. .rodata/.ARM.exidx,
# data = allocated writable with contents, bss = allocated without contents, which here also
# holds the MMU table and the stacks), from readelf so no extra package is needed.
LC_ALL=C readelf -S -W "$ELF" | awk -v elf="$ELF" -v secs="$(awk "BEGIN{printf \"%.1f\", $end-$start}")" '
    # mawk has no strtonum()
    function hex(h,    i, v) { v = 0; h = tolower(h); for (i = 1; i <= length(h); i++) v = v * 16 + index("0123456789abcdef", substr(h, i, 1)) - 1; return v }
    # Lines look like: [ 1] .text PROGBITS 00100000 010000 00a1b4 00 AX 0 0 32
    /^ *\[ *[0-9]+\]/ {
        sub(/^ *\[ *[0-9]+\] */, "");
        name = $1; type = $2; size = hex($5); flags = $7;
        if (flags !~ /A/ || size == 0) next;
        if (type == "NOBITS") bss += size;
        else if (flags ~ /W/) data += size;
        else text += size;
        line[n++] = sprintf("  %-14s %-9s %8d  %s", name, type, size, flags);
    }
    END {
        printf "build-arm: built in %ss\n", secs;
        printf "%10s %10s %10s %10s %10s  %s\n", "text", "data", "bss", "dec", "hex", "filename";
        printf "%10d %10d %10d %10d %10x  %s\n", text, data, bss, text + data + bss, text + data + bss, elf;
        print "allocated sections (name, type, bytes, flags):";
        for (i = 0; i < n; i++) print line[i];
    }'
echo "FW_ELF=$ELF"
