//! The firmware's console: where `hprintln!` and the panic and exception reports go.
//!
//! - A semihosting host answers (QEMU's `-semihosting`, or a debugger such as OpenOCD with
//!   `arm semihosting enable`): its console, as every QEMU run of the scripts has it.
//! - Nobody answers (a board booted from U-Boot or an SD card, `run-qemu.sh --board`): UART1
//!   at 115,200 baud 8N1, the ZedBoard's USB-UART (QEMU's second `-serial`), with CR LF line
//!   ends for a terminal.
//!
//! The choice is [`semihosting::host_present`]'s, made once at the first line.

use core::fmt;

use super::semihosting;
use super::uart::{self, Port};

/// The UART the console uses when no semihosting host answers.
pub const UART: Port = Port::Uart1;

/// Writes `bytes` to the console.
pub fn write_bytes(bytes: &[u8]) {
    if semihosting::host_present() {
        semihosting::write_bytes(bytes);
        return;
    }
    // A terminal wants CR LF: send each line's text, then CR LF for its LF.
    let mut rest = bytes;
    while let Some(i) = rest.iter().position(|&b| b == b'\n') {
        uart::console_write(UART, &rest[..i]);
        uart::console_write(UART, b"\r\n");
        rest = &rest[i + 1..];
    }
    uart::console_write(UART, rest);
}

/// Writes `s` to the console.
pub fn write_str(s: &str) {
    write_bytes(s.as_bytes());
}

/// Waits until what was written has left the console (before a reset drops it).
pub fn flush() {
    if !semihosting::host_present() {
        uart::console_flush(UART);
    }
}

/// The console as a `core::fmt::Write` sink.
pub struct Console;

impl fmt::Write for Console {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        write_bytes(s.as_bytes());
        Ok(())
    }
}

/// `print!` to the console.
#[macro_export]
macro_rules! hprint {
    ($($arg:tt)*) => {{
        let _ = core::fmt::Write::write_fmt(&mut $crate::arm::console::Console, format_args!($($arg)*));
    }};
}

/// `println!` to the console.
#[macro_export]
macro_rules! hprintln {
    () => { $crate::arm::console::write_str("\n") };
    ($($arg:tt)*) => {{
        let _ = core::fmt::Write::write_fmt(&mut $crate::arm::console::Console, format_args!($($arg)*));
        $crate::arm::console::write_str("\n");
    }};
}
