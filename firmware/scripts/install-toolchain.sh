#!/usr/bin/env bash
# Install what the bare-metal (armv7a-none-eabihf) firmware build and its QEMU runs need on a
# fresh Debian machine: Debian's Rust (rustc/cargo 1.9x with the std source, for -Zbuild-std),
# qemu-system-arm (machine xilinx-zynq-a9) and u-boot-tools (mkimage, for the boot script of
# scripts/image-arm.sh).  Idempotent: packages that are already
# installed are left alone and `apt-get update` runs only when something is missing.
# Safe to call from CI (non-interactive, no prompts).  Must run as root (or with sudo).
#
# Usage: scripts/install-toolchain.sh [--with-defmt-print]
#   --with-defmt-print  also `cargo install` the host-side defmt decoder (defmt-print 1.2.0,
#                       from crates.io, built with the machine's rustup cargo: a few minutes)
#                       unless a defmt-print is already on PATH.
set -euo pipefail

WITH_DEFMT_PRINT=0
for a in "$@"; do
    case "$a" in
        --with-defmt-print) WITH_DEFMT_PRINT=1 ;;
        *) echo "usage: $0 [--with-defmt-print]" >&2; exit 2 ;;
    esac
done

PKGS=(rustc-web cargo-web rust-web-src qemu-system-arm u-boot-tools)

missing=()
for p in "${PKGS[@]}"; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q '^install ok installed$'; then
        missing+=("$p")
    fi
done

if [ "${#missing[@]}" -eq 0 ]; then
    echo "install-toolchain: all present (${PKGS[*]})"
else
    echo "install-toolchain: installing ${missing[*]}"
    SUDO=""
    if [ "$(id -u)" -ne 0 ]; then
        SUDO="sudo"
    fi
    export DEBIAN_FRONTEND=noninteractive
    $SUDO apt-get update -qq
    $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# Sanity checks: fail loudly here rather than deep inside a build.
for f in /usr/bin/rustc /usr/bin/cargo /usr/bin/qemu-system-arm /usr/bin/mkimage; do
    [ -x "$f" ] || { echo "install-toolchain: $f missing after install" >&2; exit 1; }
done
[ -d /usr/lib/rustlib/src/rust/library/core ] \
    || { echo "install-toolchain: rust-web-src did not provide /usr/lib/rustlib/src/rust/library/core" >&2; exit 1; }
echo "install-toolchain: $(/usr/bin/rustc --version); $(/usr/bin/cargo --version); $(/usr/bin/qemu-system-arm --version | head -n1)"

if [ "$WITH_DEFMT_PRINT" = 1 ]; then
    if command -v defmt-print >/dev/null; then
        echo "install-toolchain: $(defmt-print --version | head -n1) present"
    else
        # rustup's cargo (not Debian's /usr/bin/cargo): the host tool needs no build-std.
        CARGO_BIN="${CARGO_HOME:-$HOME/.cargo}/bin/cargo"
        [ -x "$CARGO_BIN" ] || CARGO_BIN=cargo
        "$CARGO_BIN" install --locked defmt-print@1.2.0
    fi
fi
