//! defmt global logger: rzCOBS-encoded defmt frames, written over semihosting to a host file
//! when a semihosting host answers (QEMU's `-semihosting`, a debugger), else on UART0.
//!
//! - Semihosting: the file (default `defmt.bin`, in QEMU's working directory; override at
//!   build time with the environment variable `FSM_DEFMT_FILE`) is created on the first log
//!   call.
//! - No host (a board booted on its own, `run-qemu.sh --board`): UART0 at 115,200 baud 8N1,
//!   the frames as bytes on the line. UART1 is the board's text console and GEM0 its link to
//!   the host, so UART0 carries nothing else; on the ZedBoard it is routed to pins by the
//!   board's design (its USB-UART is UART1). `run-qemu.sh --board --defmt FILE` writes QEMU's
//!   UART0 to FILE.
//!
//! Decode either on the host with the ELF that produced it:
//!
//! ```text
//! defmt-print -e target-arm/armv7a-none-eabihf/release/fsm-firmware < defmt.bin
//! ```
//!
//! Frames are buffered and written with one SYS_WRITE per frame (and whenever the buffer
//! fills). Timestamps are global-timer ticks since start-up (see src/icount.rs).
//! Which levels are compiled in is chosen by `DEFMT_LOG` at build time (defmt's default when
//! unset is `error` only; scripts/build-arm.sh sets `info`).

use core::arch::asm;
use core::cell::UnsafeCell;
use core::sync::atomic::{AtomicBool, Ordering};

use super::semihosting::{self, File, Mode};
use super::uart::{self, Port};

/// Where the frames go when no semihosting host answers.
pub const UART: Port = Port::Uart0;

const PATH: &str = match option_env!("FSM_DEFMT_FILE") {
    Some(p) => p,
    None => "defmt.bin",
};

// Timestamp: MPCore global timer ticks (10 ns of QEMU virtual time each; under
// `run-qemu.sh --icount` (shift 4) that is 0.625 instructions per tick).
defmt::timestamp!("{=u64}", super::cpu::global_timer_ticks());

/// Where encoded bytes go: a buffer flushed to the host file, or to [`UART`].
struct Sink {
    file: Option<File>,
    failed: bool,
    buf: [u8; 256],
    len: usize,
    /// CPSR.I before `acquire` masked IRQs.
    irq_was_masked: bool,
}

/// Interior-mutable static, only touched between acquire() and release(), which hold TAKEN
/// with IRQs masked (single core: CPU 1 is parked by `_start`).
struct Cell<T>(UnsafeCell<T>);
unsafe impl<T> Sync for Cell<T> {}

static TAKEN: AtomicBool = AtomicBool::new(false);
static ENCODER: Cell<defmt::Encoder> = Cell(UnsafeCell::new(defmt::Encoder::new()));
static SINK: Cell<Sink> = Cell(UnsafeCell::new(Sink {
    file: None,
    failed: false,
    buf: [0; 256],
    len: 0,
    irq_was_masked: false,
}));

impl Sink {
    fn flush(&mut self) {
        if self.len == 0 {
            return;
        }
        if !semihosting::host_present() {
            uart::console_write(UART, &self.buf[..self.len]);
            self.len = 0;
            return;
        }
        if self.file.is_none() && !self.failed {
            match File::open(PATH, Mode::Write) {
                Ok(f) => self.file = Some(f),
                Err(_) => self.failed = true,
            }
        }
        if let Some(f) = self.file.as_mut() {
            let _ = f.write_all(&self.buf[..self.len]);
        }
        self.len = 0;
    }

    fn push(&mut self, bytes: &[u8]) {
        for &b in bytes {
            if self.len == self.buf.len() {
                self.flush();
            }
            self.buf[self.len] = b;
            self.len += 1;
        }
    }
}

/// # Safety
/// Only between acquire() and release() (or from them).
unsafe fn sink() -> &'static mut Sink {
    &mut *SINK.0.get()
}

/// # Safety
/// Only between acquire() and release() (or from them).
unsafe fn encoder() -> &'static mut defmt::Encoder {
    &mut *ENCODER.0.get()
}

#[defmt::global_logger]
struct SemihostingLogger;

unsafe impl defmt::Logger for SemihostingLogger {
    fn acquire() {
        let cpsr: u32;
        unsafe {
            asm!("mrs {}, cpsr", "cpsid i", out(reg) cpsr, options(nomem, nostack, preserves_flags));
        }
        if TAKEN.swap(true, Ordering::Acquire) {
            // Re-entered (a log call from inside a log call): defmt requires a panic here.
            panic!("defmt logger taken reentrantly");
        }
        unsafe {
            sink().irq_was_masked = cpsr & (1 << 7) != 0;
            encoder().start_frame(|b| sink().push(b));
        }
    }

    unsafe fn flush() {
        sink().flush();
    }

    unsafe fn release() {
        encoder().end_frame(|b| sink().push(b));
        sink().flush();
        let unmask = !sink().irq_was_masked;
        TAKEN.store(false, Ordering::Release);
        if unmask {
            asm!("cpsie i", options(nomem, nostack, preserves_flags));
        }
    }

    unsafe fn write(bytes: &[u8]) {
        encoder().write(bytes, |b| sink().push(b));
    }
}
