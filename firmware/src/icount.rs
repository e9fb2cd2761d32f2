//! Exact instruction counts under QEMU's `-icount`.
//!
//! QEMU's cortex-a9 has no PMU, but the MPCore global timer follows QEMU's virtual clock, and
//! with `-icount shift=S` that clock advances by exactly 2^S ns per executed instruction. The
//! global timer ticks once per 10 ns, so with S >= 4 a tick count pins down the instruction
//! count exactly (see [`instructions_from_gtimer_ticks`]).
//!
//! `scripts/run-qemu.sh --icount` tells the firmware which shift it used by writing a
//! descriptor `{ magic "ICNT", shift }` at [`ICOUNT_DESC_ADDR`] with `-device loader,data=...`.

/// Address of the icount descriptor: `u32` magic [`ICOUNT_MAGIC`], then `u32` shift.
pub const ICOUNT_DESC_ADDR: usize = 0x03FF_FFE8;
/// "ICNT" as a little-endian `u32`.
pub const ICOUNT_MAGIC: u32 = u32::from_le_bytes(*b"ICNT");
/// Shift used by scripts/run-qemu.sh --icount: the smallest with exact counts.
pub const EXACT_SHIFT: u32 = 4;
/// Nanoseconds of QEMU virtual time per global timer tick (QEMU's a9gtimer, prescaler 0).
pub const NS_PER_TICK: u64 = 10;

// The descriptor lies in the mailbox page between RAM and the input descriptor.
const _: () = assert!(ICOUNT_DESC_ADDR >= crate::layout::RAM_END);
const _: () = assert!(ICOUNT_DESC_ADDR + 8 <= crate::layout::INPUT_DESC_ADDR);

/// The shift from a descriptor, if valid.
pub fn shift_from_descriptor(magic: u32, shift: u32) -> Option<u32> {
    (magic == ICOUNT_MAGIC && shift <= 10).then_some(shift)
}

/// Instructions executed since the global timer started from 0, given a reading `ticks`,
/// under `-icount shift=S`: the smallest n with n·2^S >= 10·ticks, i.e. ceil(10·ticks / 2^S).
/// Exact for S >= 4 (the interval [10·t, 10·t + 10) of elapsed ns holds exactly one multiple
/// of 2^S); for S < 4 a lower bound within 10/2^S instructions.
pub fn instructions_from_gtimer_ticks(ticks: u64, shift: u32) -> u64 {
    let ns = ticks * NS_PER_TICK;
    let step = 1u64 << shift;
    ns.div_ceil(step)
}

/// The shift that QEMU was started with, if scripts/run-qemu.sh --icount said so.
#[cfg(target_os = "none")]
pub fn shift() -> Option<u32> {
    let d = ICOUNT_DESC_ADDR as *const u32;
    // SAFETY: fixed mailbox address in DDR outside the image (see link.x).
    let (magic, shift) = unsafe { (d.read_volatile(), d.add(1).read_volatile()) };
    shift_from_descriptor(magic, shift)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Simulate QEMU: after n instructions at shift S the counter reads floor(n·2^S / 10).
    fn qemu_ticks(n: u64, shift: u32) -> u64 {
        (n << shift) / NS_PER_TICK
    }

    #[test]
    fn exact_for_shift_4_and_up() {
        for shift in 4..=8 {
            for n in 0..5000u64 {
                assert_eq!(
                    instructions_from_gtimer_ticks(qemu_ticks(n, shift), shift),
                    n,
                    "n={n} S={shift}"
                );
            }
        }
    }

    #[test]
    fn bounded_below_shift_4() {
        for shift in 0..4 {
            for n in 0..5000u64 {
                let est = instructions_from_gtimer_ticks(qemu_ticks(n, shift), shift);
                assert!(
                    est <= n && n - est < (NS_PER_TICK >> shift) + 1,
                    "n={n} S={shift} est={est}"
                );
            }
        }
    }

    #[test]
    fn descriptor() {
        assert_eq!(ICOUNT_MAGIC, 0x544E_4349);
        assert_eq!(shift_from_descriptor(ICOUNT_MAGIC, 4), Some(4));
        assert_eq!(shift_from_descriptor(0, 4), None);
    }
}
