//! The Zynq-7000's UART (Cadence UART; Xilinx UG585, appendix B, "UART Controller"), polled:
//! the camera's link to the host until there is an Ethernet stack.
//!
//! Two controllers: UART0 at 0xE000_0000 and UART1 at 0xE000_1000. QEMU's `xilinx-zynq-a9`
//! gives its first `-serial` to UART0 and its second to UART1; the ZedBoard's USB-UART bridge
//! is wired to UART1 (MIO 48/49). The MMU maps both as Device memory (`cpu::section_attrs`).
//!
//! No interrupts: [`Uart::new`] masks them all, and the driver polls the status register. The
//! line is 8N1 at [`BAUD`] from a [`REF_CLK_HZ`] reference clock. QEMU's model passes bytes at
//! the host's pace whatever the divisors; on a board they set the line's speed.
//!
//! As the device loop's [`Link`]: a read waits for ever for the first byte of a request (a
//! UART cannot tell a quiet host from an absent one), and at most the frame time-out for the
//! rest of a frame begun; the time-out ends the session (`Device::serve` returns), which drops
//! the half frame, so that a host that was cut off mid-frame does not spoil the next one's
//! first request. A UART never reports "closed". Line errors (overrun, framing, parity) are
//! not looked at: the frame's CRC rejects what they damage.

use core::sync::atomic::{AtomicBool, Ordering};

use super::cpu::global_timer_ticks;
use crate::device::{Link, Waiting};

/// Register offsets (UG585 table B.33).
mod reg {
    /// Control: resets and enables of the RX and TX paths.
    pub const CR: usize = 0x00;
    /// Mode: character length, parity, stop bits, reference clock prescaler.
    pub const MR: usize = 0x04;
    /// Interrupt disable (write 1s).
    pub const IDR: usize = 0x0C;
    /// Interrupt status (write 1s to clear).
    pub const ISR: usize = 0x14;
    /// Baud-rate generator: CD.
    pub const BAUDGEN: usize = 0x18;
    /// Receiver time-out (0: off).
    pub const RXTOUT: usize = 0x1C;
    /// Receiver FIFO trigger level.
    pub const RXWM: usize = 0x20;
    /// Channel status.
    pub const SR: usize = 0x2C;
    /// TX and RX FIFO.
    pub const FIFO: usize = 0x30;
    /// Baud-rate divider: BDIV.
    pub const BAUD_DIV: usize = 0x34;
}

/// Control-register bits.
mod cr {
    pub const RXRST: u32 = 1 << 0;
    pub const TXRST: u32 = 1 << 1;
    pub const RX_EN: u32 = 1 << 2;
    pub const RX_DIS: u32 = 1 << 3;
    pub const TX_EN: u32 = 1 << 4;
    pub const TX_DIS: u32 = 1 << 5;
    /// Stop transmitter break (the reset value has it set too).
    pub const STOPBRK: u32 = 1 << 8;
}

/// Status-register bits.
mod sr {
    pub const RXEMPTY: u32 = 1 << 1;
    pub const TXEMPTY: u32 = 1 << 3;
    pub const TXFULL: u32 = 1 << 4;
}

/// Mode register for 8N1 in normal mode from the undivided reference clock: CLKS = 0,
/// CHRL = 0b00 (8 bits), PAR = 0b100 (none), NBSTOP = 0b00 (1), CHMODE = 0b00 (normal).
const MR_8N1: u32 = 0b100 << 3;

/// Every interrupt source (IDR bits 0..=12).
const ALL_INTERRUPTS: u32 = 0x1FFF;

/// The line speed.
pub const BAUD: u32 = 115_200;

/// The UART reference clock (`UART_REF_CLK`) assumed: 100 MHz, what Xilinx's first-stage boot
/// loader sets up from the 1 GHz IO PLL (`UART_CLK_CTRL` divisor 10). Some board designs use
/// 50 MHz: the divisors below give 115,207 baud from either (CD 124 or 62, BDIV 6).
pub const REF_CLK_HZ: u32 = 100_000_000;

/// The baud-rate divisors: baud = ref_clk / (CD · (BDIV + 1)), CD in 1..=65535, BDIV in
/// 4..=255 (UG585, "Baud Rate Generator"). The pair closest to `baud`, the smallest BDIV
/// among equals, as Xilinx's own driver (`XUartPs_SetBaudRate`) chooses.
pub const fn divisors(ref_clk_hz: u32, baud: u32) -> (u16, u8) {
    let mut best = (0u16, 0u8);
    let mut best_error = u64::MAX;
    let mut bdiv = 4u32;
    while bdiv <= 255 {
        let per_cd = baud as u64 * (bdiv as u64 + 1);
        let cd = (ref_clk_hz as u64 + per_cd / 2) / per_cd;
        if cd >= 1 && cd <= 65535 {
            let actual = ref_clk_hz as u64 / (cd * (bdiv as u64 + 1));
            let error = actual.abs_diff(baud as u64);
            if error < best_error {
                best = (cd as u16, bdiv as u8);
                best_error = error;
            }
        }
        bdiv += 1;
    }
    best
}

/// The line speed the divisors give.
pub const fn baud_of(ref_clk_hz: u32, (cd, bdiv): (u16, u8)) -> u32 {
    ref_clk_hz / (cd as u32 * (bdiv as u32 + 1))
}

// The divisors give 115,200 baud within 0.1% from 100 MHz and from 50 MHz (Xilinx's own
// table: CD 124 / 62, BDIV 6).
const _: () = {
    let (cd, bdiv) = divisors(100_000_000, BAUD);
    assert!(cd == 124 && bdiv == 6);
    let (cd, bdiv) = divisors(50_000_000, BAUD);
    assert!(cd == 62 && bdiv == 6);
    let actual = baud_of(REF_CLK_HZ, divisors(REF_CLK_HZ, BAUD));
    assert!(actual.abs_diff(BAUD) * 1000 < BAUD);
};

/// One of the two UART controllers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Port {
    /// 0xE000_0000 (QEMU's first `-serial`).
    Uart0,
    /// 0xE000_1000 (QEMU's second `-serial`; the ZedBoard's USB-UART).
    Uart1,
}

impl Port {
    /// The controller with this index (0 or 1).
    pub fn from_index(index: u8) -> Option<Port> {
        match index {
            0 => Some(Port::Uart0),
            1 => Some(Port::Uart1),
            _ => None,
        }
    }

    const fn base(self) -> usize {
        match self {
            Port::Uart0 => 0xE000_0000,
            Port::Uart1 => 0xE000_1000,
        }
    }
}

/// A register block, only ever built from a [`Port`]: the one place that touches it.
#[derive(Clone, Copy)]
struct Registers {
    base: usize,
}

impl Registers {
    fn read(self, offset: usize) -> u32 {
        // SAFETY: `base` is a UART controller's register block (from `Port::base`) and
        // `offset` one of `reg`'s, all inside the block and 4-byte aligned; the MMU maps it as
        // Device memory (`cpu::section_attrs`). Reads have no side effect on memory Rust owns
        // (reading FIFO pops a received byte: the caller wants that).
        unsafe { ((self.base + offset) as *const u32).read_volatile() }
    }

    fn write(self, offset: usize, value: u32) {
        // SAFETY: as in `read`; writes reach the UART alone, no memory Rust owns.
        unsafe { ((self.base + offset) as *mut u32).write_volatile(value) }
    }
}

/// Why a read gave up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UartError {
    /// No byte for the frame time-out inside a frame: the host stopped mid-request.
    FrameTimeout,
}

/// A polled UART, 8N1 at [`BAUD`].
pub struct Uart {
    regs: Registers,
    /// Global-timer ticks of silence inside a frame after which a read gives up.
    frame_timeout_ticks: u64,
}

impl Uart {
    /// Resets and configures `port` (8N1, [`BAUD`] from [`REF_CLK_HZ`], no interrupts, RX and
    /// TX enabled), following UG585's start-up sequence. A read inside a frame gives up after
    /// `frame_timeout_ticks` of the global timer without a byte.
    ///
    /// The UART's pins (MIO) and reference clock (SLCR `UART_CLK_CTRL`) are the boot loader's
    /// business, as on every Zynq; QEMU needs neither.
    pub fn new(port: Port, frame_timeout_ticks: u64) -> Uart {
        let regs = Registers { base: port.base() };
        configure(regs);
        Uart {
            regs,
            frame_timeout_ticks,
        }
    }

    fn status(&self) -> u32 {
        self.regs.read(reg::SR)
    }

    /// Moves what the RX FIFO holds into `buf`; returns how many bytes.
    fn drain(&mut self, buf: &mut [u8]) -> usize {
        let mut n = 0;
        while n < buf.len() && self.status() & sr::RXEMPTY == 0 {
            buf[n] = self.regs.read(reg::FIFO) as u8;
            n += 1;
        }
        n
    }

    /// Whether everything written has left the TX FIFO.
    pub fn sent(&self) -> bool {
        self.status() & sr::TXEMPTY != 0
    }
}

/// UG585's start-up sequence: 8N1, [`BAUD`] from [`REF_CLK_HZ`], no interrupts, both FIFOs
/// emptied, RX and TX enabled.
fn configure(regs: Registers) {
    let (cd, bdiv) = divisors(REF_CLK_HZ, BAUD);
    regs.write(reg::IDR, ALL_INTERRUPTS);
    // Stop both paths while the line is set up.
    regs.write(reg::CR, cr::RX_DIS | cr::TX_DIS | cr::STOPBRK);
    regs.write(reg::MR, MR_8N1);
    regs.write(reg::BAUDGEN, cd as u32);
    regs.write(reg::BAUD_DIV, bdiv as u32);
    // Empty both FIFOs of whatever the boot left; the bits clear themselves when done.
    regs.write(
        reg::CR,
        cr::RXRST | cr::TXRST | cr::RX_DIS | cr::TX_DIS | cr::STOPBRK,
    );
    let mut spins = 0u32;
    while regs.read(reg::CR) & (cr::RXRST | cr::TXRST) != 0 && spins < 1_000_000 {
        spins += 1;
    }
    regs.write(reg::RXTOUT, 0);
    regs.write(reg::RXWM, 1);
    regs.write(reg::ISR, ALL_INTERRUPTS);
    regs.write(reg::CR, cr::RX_EN | cr::TX_EN | cr::STOPBRK);
}

/// Queues `bytes` for sending as the TX FIFO has room; the line always drains it (no flow
/// control), so this never fails.
fn transmit(regs: Registers, bytes: &[u8]) {
    for &b in bytes {
        while regs.read(reg::SR) & sr::TXFULL != 0 {}
        regs.write(reg::FIFO, b as u32);
    }
}

/// The board console (src/arm/console.rs): `bytes` sent on `port`, which is configured as
/// [`Uart::new`] does on the first call. Transmit only: a port that serves the protocol is
/// never the console.
pub fn console_write(port: Port, bytes: &[u8]) {
    static CONFIGURED: [AtomicBool; 2] = [AtomicBool::new(false), AtomicBool::new(false)];
    let regs = Registers { base: port.base() };
    if !CONFIGURED[port as usize].swap(true, Ordering::Relaxed) {
        configure(regs);
    }
    transmit(regs, bytes);
}

/// Waits until every byte [`console_write`] queued on `port` has left the TX FIFO (before a
/// reset, which would drop them), for at most about a second at [`BAUD`] on a board.
pub fn console_flush(port: Port) {
    let regs = Registers { base: port.base() };
    let mut spins = 0u32;
    while regs.read(reg::SR) & sr::TXEMPTY == 0 && spins < 100_000_000 {
        spins += 1;
    }
}

impl Link for Uart {
    type Error = UartError;

    /// Waits for at least one byte and takes what the FIFO holds; never returns 0 (a UART
    /// does not close). Inside a frame it gives up after the frame time-out of silence.
    fn read(&mut self, buf: &mut [u8], waiting: Waiting) -> Result<usize, UartError> {
        if buf.is_empty() {
            return Ok(0);
        }
        let start = global_timer_ticks();
        loop {
            let n = self.drain(buf);
            if n > 0 {
                return Ok(n);
            }
            if waiting == Waiting::RestOfFrame
                && global_timer_ticks().wrapping_sub(start) > self.frame_timeout_ticks
            {
                return Err(UartError::FrameTimeout);
            }
        }
    }

    /// Fills the TX FIFO as it has room; the line always drains it (no flow control), so
    /// this never fails.
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), UartError> {
        transmit(self.regs, bytes);
        Ok(())
    }
}
