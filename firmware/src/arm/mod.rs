//! Everything that only exists on the bare-metal target (`target_os = "none"`): start-up code,
//! exception vectors, CPU set-up, semihosting, the console, the UART, Ethernet (GEM0 and
//! smoltcp), the panic handler, the end of the program ([`stop`]) and the defmt global logger.

pub mod console;
pub mod cpu;
pub mod gem;
pub mod net;
pub mod semihosting;
mod start;
pub mod uart;

#[cfg(feature = "defmt")]
pub mod logger;

use core::sync::atomic::{AtomicBool, Ordering};

use semihosting::{EXIT_EXCEPTION, EXIT_PANIC};

/// Ends the program with `code`: with a semihosting host (QEMU, a debugger), its exit with that
/// code; on a board, after a `RESET` line on the console, a software reset of the whole SoC
/// (SLCR `PSS_RST_CTRL`), so that a camera that met a bug boots again instead of hanging.
/// Under `run-qemu.sh --board` (`-no-reboot`) the reset ends QEMU.
pub fn stop(code: u8) -> ! {
    if semihosting::host_present() {
        semihosting::exit(code)
    }
    crate::hprintln!("RESET: stopped with code {}, resetting the SoC", code);
    console::flush();
    reset_soc()
}

/// A software reset of the processing system (UG585, "PS Reset": `SLCR_UNLOCK` with its key,
/// then `PSS_RST_CTRL.SOFT_RST`), as Linux's and RTEMS's Zynq ports do it.
fn reset_soc() -> ! {
    const SLCR_UNLOCK: usize = 0xF800_0008;
    const SLCR_UNLOCK_KEY: u32 = 0xDF0D;
    const PSS_RST_CTRL: usize = 0xF800_0200;
    loop {
        // SAFETY: the SLCR's unlock and reset registers (Device memory in `cpu::section_attrs`);
        // the write resets the SoC, nothing Rust owns survives it.
        unsafe {
            (SLCR_UNLOCK as *mut u32).write_volatile(SLCR_UNLOCK_KEY);
            (PSS_RST_CTRL as *mut u32).write_volatile(1);
        }
    }
}

/// Prints the panic message (`PANIC: panicked at file:line:col:\n<message>`) on the console
/// and stops with code 101 (QEMU's exit code; a reset on a board).
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    static PANICKING: AtomicBool = AtomicBool::new(false);
    if !PANICKING.swap(true, Ordering::Relaxed) {
        crate::hprintln!("PANIC: {}", info);
    }
    stop(EXIT_PANIC)
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
/// interrupted mode's status register. Reports on the console and stops with code 102.
/// (A semihosting SVC nobody answers does not come here: its vector returns -1.)
#[no_mangle]
extern "C" fn fsm_fw_exception(kind: u32, pc: u32, spsr: u32) -> ! {
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
    stop(EXIT_EXCEPTION)
}
