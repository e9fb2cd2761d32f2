//! Everything that only exists on the bare-metal target (`target_os = "none"`): start-up code,
//! exception vectors, CPU set-up, semihosting, the UART, Ethernet (GEM0 and smoltcp), the panic
//! handler and the defmt global logger.

pub mod cpu;
pub mod gem;
pub mod net;
pub mod semihosting;
mod start;
pub mod uart;

#[cfg(feature = "defmt")]
pub mod logger;

use core::sync::atomic::{AtomicBool, Ordering};

use semihosting::{exit, EXIT_EXCEPTION, EXIT_PANIC};

/// Prints the panic message (`PANIC: panicked at file:line:col:\n<message>`) on the host
/// console and terminates QEMU with exit code 101.
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    static PANICKING: AtomicBool = AtomicBool::new(false);
    if !PANICKING.swap(true, Ordering::Relaxed) {
        crate::hprintln!("PANIC: {}", info);
    }
    exit(EXIT_PANIC)
}

const EXCEPTION_NAMES: [&str; 8] = [
    "reset",
    "undefined instruction",
    "supervisor call",
    "prefetch abort",
    "data abort",
    "reserved vector",
    "IRQ",
    "FIQ",
];

/// Every vector but reset ends up here (src/arm/start.rs), on its own small stack, with
/// `kind` = vector index, `pc` = address of the faulting instruction, `spsr` = the
/// interrupted mode's status register. Reports and exits with code 102.
#[no_mangle]
extern "C" fn fsm_fw_exception(kind: u32, pc: u32, spsr: u32) -> ! {
    if kind == 2 {
        // An SVC that reached the vector: if it is the semihosting SVC, no semihosting host is
        // attached and there is no way to report anything. Park.
        let insn = unsafe { (pc as *const u32).read_volatile() };
        if insn & 0x0F00_0000 == 0x0F00_0000 && insn & 0x00FF_FFFF == 0x12_3456 {
            loop {
                unsafe { core::arch::asm!("wfi", options(nomem, nostack, preserves_flags)) };
            }
        }
    }
    let (dfsr, dfar, ifsr, ifar) = cpu::fault_registers();
    let name = EXCEPTION_NAMES.get(kind as usize).copied().unwrap_or("?");
    crate::hprintln!(
        "EXCEPTION: {} at pc={:#010x} spsr={:#010x} dfsr={:#x} dfar={:#010x} ifsr={:#x} ifar={:#010x}",
        name,
        pc,
        spsr,
        dfsr,
        dfar,
        ifsr,
        ifar
    );
    exit(EXIT_EXCEPTION)
}
