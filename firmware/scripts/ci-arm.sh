#!/usr/bin/env bash
# End-to-end check of the bare-metal firmware: install what is missing, build the ARM ELF,
# run it under QEMU and check what it computed, the exit codes of every failure path, the
# determinism of the instruction count, and (if defmt-print is installed) defmt logging.
# Non-interactive; meant to be called from .ci/run. Ends with the line `N passed, M failed`
# and exits non-zero if anything failed.
#
# Environment: FW_SKIP_INSTALL=1 to skip scripts/install-toolchain.sh;
#              FW_WITH_DEFMT_PRINT=1 to also install defmt-print if missing (a few minutes);
#              FW_SKIP_DEFMT=1 to skip the defmt build and decode (skipped anyway, with a
#              note, when defmt-print is not installed).
set -euo pipefail

FW_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
S="$FW_DIR/scripts"
HOST_CARGO="$(command -v cargo || true)"   # rustup's cargo, for the host build (before PATH games)

if [ "${FW_SKIP_INSTALL:-0}" != 1 ]; then
    if [ "${FW_WITH_DEFMT_PRINT:-0}" = 1 ]; then
        "$S/install-toolchain.sh" --with-defmt-print
    else
        "$S/install-toolchain.sh"
    fi
fi

WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
pass=0
fail=0
ok() { pass=$((pass + 1)); echo "ok   - $*"; }
bad() { fail=$((fail + 1)); echo "FAIL - $*"; }

build_log="$WORK/build.log"
if ! "$S/build-arm.sh" >"$build_log" 2>&1; then
    cat "$build_log"
    bad "build-arm.sh"
    echo "$pass passed, $fail failed"
    exit 1
fi
grep -A20 '^ *text' "$build_log" || true
ELF="$(sed -n 's/^FW_ELF=//p' "$build_log" | tail -n1)"
cp "$ELF" "$WORK/fsm-firmware.elf"
ELF="$WORK/fsm-firmware.elf"
ok "build-arm.sh -> $(basename "$ELF")"

cd "$WORK"

# 1. Demo without input: exit 0, and the RESULT line equals the host build's.
set +e
"$S/run-qemu.sh" "$ELF" >run1.txt 2>&1
rc=$?
set -e
cat run1.txt
[ "$rc" = 0 ] && ok "demo exits 0" || bad "demo exit code $rc"
if [ -n "$HOST_CARGO" ]; then
    host_line="$("$HOST_CARGO" run -q --manifest-path "$FW_DIR/Cargo.toml" -p fsm-firmware 2>/dev/null | grep '^RESULT' || true)"
    fw_line="$(grep '^RESULT' run1.txt || true)"
    if [ -n "$host_line" ] && [ "$host_line" = "$fw_line" ]; then
        ok "RESULT line identical on host (x86_64) and firmware (Cortex-A9)"
    else
        bad "RESULT lines differ: host '$host_line' vs firmware '$fw_line'"
    fi
fi
grep -q '^INPUT none' run1.txt && ok "no input descriptor -> INPUT none" || bad "INPUT none line missing"

# 2. Input placed in RAM by QEMU's loader; output file written/read through semihosting.
python3 -c 'import os, sys; sys.stdout.buffer.write(bytes((i * 7 + 3) % 251 for i in range(123457)))' >input.bin
want_crc="$(python3 -c 'import zlib; print("%08x" % zlib.crc32(open("input.bin", "rb").read()))')"
rm -f fw-out.bin
set +e
"$S/run-qemu.sh" "$ELF" input.bin >run2.txt 2>&1
rc=$?
set -e
cat run2.txt
[ "$rc" = 0 ] && ok "demo with input exits 0" || bad "demo with input: exit code $rc"
grep -q "^INPUT len=123457 crc32=$want_crc " run2.txt && ok "input bytes seen by firmware (crc32 $want_crc)" \
    || bad "INPUT line does not show len=123457 crc32=$want_crc"
if python3 - "$want_crc" <<'EOF'
import struct, sys
b = open("fw-out.bin", "rb").read()
magic, ver, peak_bin, mag, phase, in_len, in_crc, insns = struct.unpack("<4sIIffIII", b)
assert len(b) == 32 and magic == b"FSMO" and ver == 1, (len(b), magic, ver)
assert peak_bin == 37 and abs(mag - 1536.0) < 0.01 and abs(phase - 0.5) < 1e-3, (peak_bin, mag, phase)
assert in_len == 123457 and in_crc == int(sys.argv[1], 16), (in_len, hex(in_crc))
assert insns == 0, insns  # not under --icount
EOF
then ok "fw-out.bin record (semihosting SYS_OPEN/SYS_WRITE/SYS_CLOSE) decodes"; else bad "fw-out.bin record"; fi

# 3. Instruction counts: deterministic, and the same for two shifts that are both exact.
count() {
    ICOUNT_SHIFT="$1" "$S/run-qemu.sh" --icount "$ELF" input.bin 2>/dev/null \
        | sed -n 's/^ICOUNT shift=[0-9]* rfft_1024 instructions=\([0-9]*\) .*/\1/p'
}
a="$(count 4)"; b="$(count 4)"; c="$(count 6)"
echo "rfft_1024 instructions: shift4=$a shift4=$b shift6=$c"
if [ -n "$a" ] && [ "$a" = "$b" ] && [ "$a" = "$c" ] && [ "$a" -gt 10000 ]; then
    ok "instruction count deterministic: rfft_1024 = $a instructions"
else
    bad "instruction counts differ or missing: '$a' '$b' '$c'"
fi

# 4. Failure paths end QEMU with the right exit code.
for t in panic:101 abort:102 undef:102 exit:7:7; do
    name="${t%:*}"
    want="${t##*:}"
    set +e
    "$S/run-qemu.sh" --timeout 30 --selftest "$name" "$ELF" >st.txt 2>&1
    rc=$?
    set -e
    if [ "$rc" = "$want" ]; then
        ok "selftest $name -> exit $rc ($(grep -E '^(PANIC|EXCEPTION)' st.txt | head -n1 | cut -c1-60))"
    else
        cat st.txt
        bad "selftest $name: exit $rc, want $want"
    fi
done

# 5. defmt frames over semihosting, decoded on the host.
if [ "${FW_SKIP_DEFMT:-0}" = 1 ]; then
    echo "skip - defmt (FW_SKIP_DEFMT=1)"
elif ! command -v defmt-print >/dev/null; then
    echo "skip - defmt (defmt-print not installed: cargo install defmt-print)"
else
    if "$S/build-arm.sh" --defmt >build-defmt.log 2>&1; then
        DELF="$(sed -n 's/^FW_ELF=//p' build-defmt.log | tail -n1)"
        cp "$DELF" defmt.elf
        rm -f defmt.bin
        set +e
        "$S/run-qemu.sh" --icount defmt.elf input.bin >run-defmt.txt 2>&1
        rc=$?
        set -e
        defmt-print -e defmt.elf <defmt.bin >defmt.txt 2>&1 || true
        cat defmt.txt
        if [ "$rc" = 0 ] && grep -q 'INFO  rfft_1024: peak bin 37 mag 1536' defmt.txt \
            && grep -q "crc32 0x$want_crc" defmt.txt && grep -q 'INFO  done' defmt.txt; then
            ok "defmt log written over semihosting and decoded by $(defmt-print --version | head -n1)"
        else
            bad "defmt log (run exit $rc)"
        fi
    else
        cat build-defmt.log
        bad "build-arm.sh --defmt"
    fi
fi

echo "$pass passed, $fail failed"
[ "$fail" = 0 ]
