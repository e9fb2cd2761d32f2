//! Cortex-A9 set-up done from Rust: cycle counter, MMU identity map, L1 caches.
//!
//! Called once by `_start` (src/arm/start.rs) through `fsm_fw_init`, after .bss/.data are in
//! place and before `fw_main`.
//!
//! The MMU matters for real silicon: with the MMU off every data access is Strongly-ordered and
//! uncached (an FFT would run many times slower, and LDREX/STREX are not guaranteed to work).
//! QEMU does not model caches, so there the map only has to be correct, not fast.

use core::arch::asm;

/// Enable the PMU cycle counter (PMCCNTR) and reset it.
///
/// On real silicon this counts CPU clock cycles. QEMU (7.2, and up to at least 10.x) does not
/// implement the PMU for its cortex-a9 model (no ARM_FEATURE_PMU): PMCCNTR reads 0 there, so
/// use [`global_timer_ticks`] under QEMU.
pub fn enable_cycle_counter() {
    unsafe {
        // PMCR: E (enable all counters) | C (reset cycle counter); D = 0 (count every cycle).
        asm!("mcr p15, 0, {}, c9, c12, 0", in(reg) 0b101u32, options(nostack, preserves_flags));
        // PMCNTENSET: bit 31 = cycle counter.
        asm!("mcr p15, 0, {}, c9, c12, 1", in(reg) 1u32 << 31, options(nostack, preserves_flags));
        asm!("isb", options(nostack, preserves_flags));
    }
}

/// Read the 32-bit PMU cycle counter (wraps after 2^32 cycles; 0 under QEMU).
#[inline(always)]
pub fn cycles() -> u32 {
    let c: u32;
    // No `nomem`: the read must stay where it is relative to the code being measured.
    unsafe { asm!("mrc p15, 0, {}, c9, c13, 0", out(reg) c, options(nostack, preserves_flags)) };
    c
}

/// Cortex-A9 MPCore global timer (64-bit, PERIPHCLK), at PERIPHBASE + 0x200.
/// PERIPHBASE is 0xF8F0_0000 on every Zynq-7000.
const GTIMER: usize = 0xF8F0_0200;
const GT_COUNTER_LO: usize = GTIMER;
const GT_COUNTER_HI: usize = GTIMER + 0x04;
const GT_CONTROL: usize = GTIMER + 0x08;

/// Nanoseconds of QEMU virtual time per global-timer tick (prescaler 0): QEMU's a9gtimer
/// advances one tick per 10 ns of QEMU_CLOCK_VIRTUAL. (On real silicon PERIPHCLK = CPU/2.)
pub const QEMU_NS_PER_GTIMER_TICK: u64 = 10;

/// Stop, zero and restart the global timer (prescaler 0, no comparator, no interrupt).
/// Afterwards [`global_timer_ticks`] counts from 0 at the moment of this call.
pub fn start_global_timer() {
    unsafe {
        (GT_CONTROL as *mut u32).write_volatile(0);
        (GT_COUNTER_LO as *mut u32).write_volatile(0);
        (GT_COUNTER_HI as *mut u32).write_volatile(0);
        (GT_CONTROL as *mut u32).write_volatile(1);
    }
}

/// Read the 64-bit global timer counter.
///
/// Under QEMU the count follows the virtual clock; with `-icount shift=S` every instruction
/// advances that clock by exactly 2^S ns, so the count is a deterministic function of the
/// number of instructions executed since [`start_global_timer`]: see
/// [`instructions_since_start`].
#[inline(always)]
pub fn global_timer_ticks() -> u64 {
    loop {
        unsafe {
            let hi = (GT_COUNTER_HI as *const u32).read_volatile();
            let lo = (GT_COUNTER_LO as *const u32).read_volatile();
            if (GT_COUNTER_HI as *const u32).read_volatile() == hi {
                return ((hi as u64) << 32) | lo as u64;
            }
        }
    }
}

/// Instructions executed between [`start_global_timer`] and the read that returned `ticks`,
/// under QEMU with `-icount shift=S`.
///
/// QEMU's counter is floor(elapsed_ns / 10) and elapsed_ns = instructions * 2^S, so the
/// instruction count lies in [10·ticks/2^S, 10·(ticks+1)/2^S). For S >= 4 that interval is
/// narrower than 1 and holds exactly one integer: the result is exact. For S < 4 it is the
/// lower bound, with an uncertainty of 10/2^S instructions.
pub fn instructions_since_start(ticks: u64, icount_shift: u32) -> u64 {
    crate::icount::instructions_from_gtimer_ticks(ticks, icount_shift)
}

/// Section descriptors for the short-descriptor (ARMv7 VMSA) level-1 table, 1 MiB each.
const SECTION: u32 = 0b10;
const AP_RW: u32 = 0b11 << 10; // AP[1:0] = 11, AP[2] = 0: read/write at every privilege level
const XN: u32 = 1 << 4;
/// Normal memory, outer and inner write-back write-allocate (TEX=001, C=1, B=1), non-shareable
/// (with ACTLR.SMP = 0 a Cortex-A9 would treat shareable Normal memory as uncached).
const NORMAL_WB: u32 = (0b001 << 12) | (1 << 3) | (1 << 2);
/// Normal memory, outer and inner non-cacheable (TEX=001, C=0, B=0), non-shareable: memory the
/// Ethernet controller's DMA shares with the CPU (`arm/gem.rs`), which does not snoop the caches.
const NORMAL_NC: u32 = 0b001 << 12;
/// Translation fault (descriptor type 0b00): unmapped. Marker value, see `table_entry`.
const FAULT: u32 = u32::MAX;
/// Shareable Device memory (TEX=000, C=0, B=1), never executable.
const DEVICE: u32 = (1 << 2) | XN;

// The level-1 translation table: 16 KiB in `.ttb` (link.x), after .bss, 16 KiB aligned.
extern "C" {
    static mut _ttb: [u32; 4096];
}

// The uncached section is the one that holds the GEM's DMA area.
const _: () = assert!(crate::layout::GEM_DMA_BASE >> 20 == 0x03F);

/// Attributes for the 1 MiB section starting at `index << 20` (Zynq-7000 memory map).
pub const fn section_attrs(index: u32) -> u32 {
    match index {
        // Null-pointer guard: the first MiB of DDR is not used by the image (link.x starts at
        // 1 MiB), so any access there faults (data abort / prefetch abort -> exit code 102).
        0x000 => FAULT,
        // The mailbox MiB: QEMU's loader descriptors at its top, the GEM's DMA rings and buffers
        // at its start (`layout::GEM_DMA_BASE`): uncached, so that CPU and DMA agree.
        0x03F => NORMAL_NC,
        // DDR (up to 1 GiB).
        0x001..=0x3FF => NORMAL_WB,
        // On-chip memory mapped high (0xFFFC_0000..): the last MiB.
        0xFFF => NORMAL_WB,
        // PL AXI ports, IOP/APB peripherals, SLCR, PS system registers, QSPI, CPU private.
        _ => DEVICE,
    }
}

/// The level-1 descriptor for section `index`.
pub const fn table_entry(index: u32) -> u32 {
    match section_attrs(index) {
        FAULT => 0,
        attrs => (index << 20) | attrs | AP_RW | SECTION,
    }
}

/// Invalidate the whole L1 data cache by set/way (its content is UNKNOWN after reset).
fn invalidate_l1_dcache() {
    unsafe {
        // CSSELR = 0: level 1, data/unified cache.
        asm!("mcr p15, 2, {}, c0, c0, 0", "isb", in(reg) 0u32, options(nostack, preserves_flags));
        let ccsidr: u32;
        asm!("mrc p15, 1, {}, c0, c0, 0", out(reg) ccsidr, options(nomem, nostack, preserves_flags));
        let line_shift = (ccsidr & 7) + 4;
        let ways = ((ccsidr >> 3) & 0x3FF) + 1;
        let sets = ((ccsidr >> 13) & 0x7FFF) + 1;
        let way_shift = if ways > 1 {
            (ways - 1).leading_zeros()
        } else {
            0
        };
        for way in 0..ways {
            for set in 0..sets {
                let sw = (way.checked_shl(way_shift).unwrap_or(0)) | (set << line_shift);
                // DCISW: invalidate data cache line by set/way.
                asm!("mcr p15, 0, {}, c7, c6, 2", in(reg) sw, options(nostack, preserves_flags));
            }
        }
        asm!("dsb", options(nostack, preserves_flags));
    }
}

/// Build the identity map and enable MMU, branch prediction, L1 I- and D-cache.
/// The L2 cache controller (PL310 at 0xF8F0_2000) is left off.
pub fn enable_mmu_and_caches() {
    unsafe {
        let table = core::ptr::addr_of_mut!(_ttb) as *mut u32;
        for i in 0..4096u32 {
            table.add(i as usize).write_volatile(table_entry(i));
        }
        invalidate_l1_dcache();
        asm!(
            "dsb",
            // Invalidate I-cache, branch predictor, TLB.
            "mcr p15, 0, {zero}, c7, c5, 0",
            "mcr p15, 0, {zero}, c7, c5, 6",
            "mcr p15, 0, {zero}, c8, c7, 0",
            // TTBCR = 0: TTBR0 translates the whole 4 GiB.
            "mcr p15, 0, {zero}, c2, c0, 2",
            // TTBR0 = table; table walks non-cacheable (the table was written with caches off).
            "mcr p15, 0, {ttb}, c2, c0, 0",
            // DACR: every domain "client" (access checked against AP bits).
            "mcr p15, 0, {dacr}, c3, c0, 0",
            "dsb",
            "isb",
            zero = in(reg) 0u32,
            ttb = in(reg) table as u32,
            dacr = in(reg) 0x5555_5555u32,
            options(nostack, preserves_flags)
        );
        let mut sctlr: u32;
        asm!("mrc p15, 0, {}, c1, c0, 0", out(reg) sctlr, options(nomem, nostack, preserves_flags));
        sctlr |= 1 << 0; // M: MMU
        sctlr &= !(1 << 1); // A: no alignment faults on Normal memory
        sctlr |= 1 << 2; // C: data cache
        sctlr |= 1 << 11; // Z: branch prediction
        sctlr |= 1 << 12; // I: instruction cache
        asm!("mcr p15, 0, {}, c1, c0, 0", "dsb", "isb", in(reg) sctlr, options(nostack, preserves_flags));
    }
}

/// Called by `_start` before `fw_main`.
#[no_mangle]
extern "C" fn fsm_fw_init() {
    enable_mmu_and_caches();
    enable_cycle_counter();
    start_global_timer();
}

/// Fault status/address registers, for the exception report.
pub fn fault_registers() -> (u32, u32, u32, u32) {
    let (dfsr, dfar, ifsr, ifar): (u32, u32, u32, u32);
    unsafe {
        asm!("mrc p15, 0, {}, c5, c0, 0", out(reg) dfsr, options(nomem, nostack, preserves_flags));
        asm!("mrc p15, 0, {}, c6, c0, 0", out(reg) dfar, options(nomem, nostack, preserves_flags));
        asm!("mrc p15, 0, {}, c5, c0, 1", out(reg) ifsr, options(nomem, nostack, preserves_flags));
        asm!("mrc p15, 0, {}, c6, c0, 2", out(reg) ifar, options(nomem, nostack, preserves_flags));
    }
    (dfsr, dfar, ifsr, ifar)
}
