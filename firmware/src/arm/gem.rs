//! The Zynq-7000's Gigabit Ethernet MAC GEM0 (Cadence GEM; Xilinx UG585 chapter 16, "Gigabit
//! Ethernet Controller", registers in appendix B, "Gigabit Ethernet Controller (GEM)"),
//! polled: the camera's Ethernet link, under smoltcp ([`super::net`]).
//!
//! GEM0's registers are at 0xE000_B000 (Device memory, `cpu::section_attrs`). QEMU's
//! `xilinx-zynq-a9` puts its `cadence_gem` model there and connects it to a `-nic`; the ZedBoard
//! wires GEM0 through RGMII to a Marvell 88E1518 PHY at MDIO address 0.
//!
//! - **No interrupts** (every source masked): the driver looks at the descriptor rings when
//!   smoltcp polls it, as `uart.rs` looks at the UART's status register.
//! - **DMA rings and buffers** (UG585 16.3.5/16.3.6, "Receive/Transmit Buffer Queue"): 32 RX and
//!   16 TX descriptors of two words, one 1,536-byte buffer each (a whole 1,518-byte frame fits one
//!   buffer, so a frame never spans descriptors), at the fixed address `layout::GEM_DMA_BASE`.
//!   That MiB is mapped **Normal, non-cacheable** (`cpu::section_attrs`): the GEM's DMA does not
//!   snoop the Cortex-A9's L1 data cache (the ACP is not used), so with cached rings the CPU
//!   could read a stale descriptor or leave a frame in the cache where the MAC never sees it.
//!   Non-cacheable memory trades a slower copy per frame (smoltcp copies every frame once) for
//!   the absence of clean/invalidate-by-address bookkeeping on every descriptor; barriers
//!   (`dmb`/`dsb`) still order the CPU's accesses against the descriptor hand-over and the
//!   register write that starts transmission.
//! - **Network configuration** (UG585 16.3.2, `net_cfg`): full duplex, the PHY's speed, the FCS
//!   stripped on receive and appended on transmit, broadcast accepted (ARP), our unicast
//!   address in specific-address register 1, receive buffer offset 0 (smoltcp copies the frame
//!   anyway, so aligning the IP header buys nothing), MDC = cpu_1x / 64 (1.7 MHz at 111 MHz,
//!   under the 2.5 MHz IEEE 802.3 allows).
//! - **MDIO / PHY** (UG585 16.3.4, `phy_maint`, clause 22): the PHY's identifier is read at the
//!   preferred address, else at the first address that answers; its link is awaited for a
//!   bounded time; for a Marvell PHY (OUI 0x005043, ID1 0x0141, e.g. the 88E1518 or QEMU's model
//!   of an 88E1116R, `0x0141_0CC2`) the resolved speed and duplex come from its copper status
//!   register 17. What a board needs beyond this (the GEM's TX clock in the SLCR for the
//!   negotiated speed, the MIO/RGMII pins, a MAC address of its own) is the boot loader's and
//!   the README's business.
//!
//! What QEMU's model needs (hw/net/cadence_gem.c): the receiver caches the descriptor it will
//! fill next and re-reads it only after a frame or when `net_ctrl` is written with RX enabled,
//! so once every RX descriptor was full it would stop for good; the driver therefore writes
//! `net_ctrl` again when it returns a descriptor while `rx_status.buffer_not_avail` is set.
//! Every `net_ctrl` write keeps TX enabled (clearing it rewinds the TX queue pointer), and the
//! specific address is active only once its top half is written (bottom half first).

use core::sync::atomic::{AtomicBool, Ordering};

use smoltcp::phy::{self, DeviceCapabilities, Medium};
use smoltcp::time::Instant;

use super::cpu::global_timer_ticks;
use crate::layout::{GEM_DMA_BASE, GEM_DMA_LEN};

/// GEM0's register block.
pub const GEM0_BASE: usize = 0xE000_B000;

/// Register offsets (UG585 appendix B, GEM).
mod reg {
    /// `net_ctrl`: enables of RX, TX and the management port, start of transmission.
    pub const NET_CTRL: usize = 0x00;
    /// `net_cfg`: speed, duplex, address filters, FCS, MDC divider.
    pub const NET_CFG: usize = 0x04;
    /// `net_status`: PHY management idle.
    pub const NET_STATUS: usize = 0x08;
    /// `dma_cfg`: receive buffer size, packet buffer sizes, burst length, endianness.
    pub const DMA_CFG: usize = 0x10;
    /// `tx_status` (write 1s to clear).
    pub const TX_STATUS: usize = 0x14;
    /// `rx_qbar`: receive descriptor list base.
    pub const RX_QBAR: usize = 0x18;
    /// `tx_qbar`: transmit descriptor list base.
    pub const TX_QBAR: usize = 0x1C;
    /// `rx_status` (write 1s to clear).
    pub const RX_STATUS: usize = 0x20;
    /// `intr_status` (write 1s to clear).
    pub const INTR_STATUS: usize = 0x24;
    /// `intr_dis`: mask interrupt sources (write 1s).
    pub const INTR_DIS: usize = 0x2C;
    /// `phy_maint`: one MDIO operation.
    pub const PHY_MAINT: usize = 0x34;
    /// `spec_addr1_bot`: first four bytes of our MAC address.
    pub const SPEC_ADDR1_BOT: usize = 0x88;
    /// `spec_addr1_top`: its last two bytes; writing it activates the match.
    pub const SPEC_ADDR1_TOP: usize = 0x8C;
    /// `frames_tx`: frames transmitted without error.
    pub const FRAMES_TX: usize = 0x108;
    /// `frames_rx`: frames received without error.
    pub const FRAMES_RX: usize = 0x158;
}

/// `net_ctrl` bits.
mod ctrl {
    pub const RX_EN: u32 = 1 << 2;
    pub const TX_EN: u32 = 1 << 3;
    pub const MGMT_PORT_EN: u32 = 1 << 4;
    pub const CLEAR_STAT_REGS: u32 = 1 << 5;
    pub const START_TX: u32 = 1 << 9;
}

/// `net_cfg` bits.
mod cfg {
    pub const SPEED_100: u32 = 1 << 0;
    pub const FULL_DUPLEX: u32 = 1 << 1;
    pub const RX_1536_BYTE_FRAMES: u32 = 1 << 8;
    pub const GIGE_EN: u32 = 1 << 10;
    /// Receive buffer offset, bits 15:14 (0 here).
    pub const RX_BUF_OFFSET_SHIFT: u32 = 14;
    pub const FCS_REMOVE: u32 = 1 << 17;
    /// MDC clock divider, bits 20:18: 0b100 = cpu_1x / 64.
    pub const MDC_CLK_DIV_64: u32 = 0b100 << 18;
}

/// `dma_cfg` fields.
mod dma {
    /// AHB bursts of up to 16 beats (INCR16).
    pub const BURST_INCR16: u32 = 0x10;
    /// Use the full 8 KiB receive packet buffer.
    pub const RX_PKTBUF_FULL: u32 = 0b11 << 8;
    /// Use the full 4 KiB transmit packet buffer.
    pub const TX_PKTBUF_FULL: u32 = 1 << 10;
    /// Receive buffer size in units of 64 bytes, bits 23:16.
    pub const RX_BUF_SIZE_SHIFT: u32 = 16;
}

/// `net_status`: the PHY management logic is idle.
const NET_STATUS_PHY_MGMT_IDLE: u32 = 1 << 2;
/// `rx_status`: a used descriptor was met (no buffer to receive into).
const RX_STATUS_BUFFER_NOT_AVAIL: u32 = 1 << 0;
/// Every `rx_status` flag.
const RX_STATUS_ALL: u32 = 0x0F;
/// Every `tx_status` flag.
const TX_STATUS_ALL: u32 = 0x1FF;
/// Every interrupt source (`intr_dis` bits 0..=25).
const ALL_INTERRUPTS: u32 = 0x03FF_FFFF;

/// Receive descriptor, word 0: buffer address (bits 31:2), wrap (bit 1), ownership (bit 0: 1 =
/// the GEM has filled it, software owns it).
const RX_W0_OWNED_BY_SW: u32 = 1 << 0;
const RX_W0_WRAP: u32 = 1 << 1;
/// Receive descriptor, word 1: frame length (bits 12:0), start and end of frame.
const RX_W1_LENGTH: u32 = 0x1FFF;
const RX_W1_SOF: u32 = 1 << 14;
const RX_W1_EOF: u32 = 1 << 15;
/// Transmit descriptor, word 1: length (bits 13:0), last buffer of the frame, wrap, used (1 =
/// software owns it: not to be sent, or sent).
const TX_W1_LENGTH: u32 = 0x3FFF;
const TX_W1_LAST: u32 = 1 << 15;
const TX_W1_WRAP: u32 = 1 << 30;
const TX_W1_USED: u32 = 1 << 31;

/// Receive descriptors.
pub const RX_COUNT: usize = 32;
/// Transmit descriptors.
pub const TX_COUNT: usize = 16;
/// One buffer per descriptor, a multiple of 64 (the `dma_cfg` unit) that holds a whole frame
/// (1,518 bytes, or 1,522 with a VLAN tag).
pub const BUFFER_LEN: usize = 1536;
/// The largest frame handed to smoltcp or sent: IP MTU 1,500 plus the 14-byte Ethernet header
/// (smoltcp's `max_transmission_unit` for Ethernet; the GEM adds the FCS).
pub const MAX_FRAME: usize = 1514;

// The DMA area: descriptor lists first (8-byte aligned), then the buffers (64-byte aligned).
const RX_DESCS: usize = GEM_DMA_BASE;
const TX_DESCS: usize = GEM_DMA_BASE + 8 * RX_COUNT;
const RX_BUFFERS: usize = GEM_DMA_BASE + 0x1000;
const TX_BUFFERS: usize = RX_BUFFERS + RX_COUNT * BUFFER_LEN;
const _: () = assert!(TX_DESCS + 8 * TX_COUNT <= RX_BUFFERS);
const _: () = assert!(TX_BUFFERS + TX_COUNT * BUFFER_LEN <= GEM_DMA_BASE + GEM_DMA_LEN);
const _: () = assert!(BUFFER_LEN % 64 == 0 && BUFFER_LEN >= 1522 && RX_BUFFERS % 64 == 0);

/// Only one [`Gem`] may own the rings.
static TAKEN: AtomicBool = AtomicBool::new(false);

/// A register block, only ever built for [`GEM0_BASE`].
#[derive(Clone, Copy)]
struct Registers {
    base: usize,
}

impl Registers {
    fn read(self, offset: usize) -> u32 {
        // SAFETY: `base` is GEM0's register block and `offset` one of `reg`'s, inside it and
        // 4-byte aligned; the MMU maps it as Device memory. Reads touch no memory Rust owns.
        unsafe { ((self.base + offset) as *const u32).read_volatile() }
    }

    fn write(self, offset: usize, value: u32) {
        // SAFETY: as in `read`; writes reach the GEM alone (it then reads and writes the DMA
        // area, which no Rust reference covers while the GEM owns a descriptor).
        unsafe { ((self.base + offset) as *mut u32).write_volatile(value) }
    }
}

/// Word `word` (0 or 1) of descriptor `index` of the list at `list`.
fn desc_word(list: usize, index: usize, word: usize) -> *mut u32 {
    (list + 8 * index + 4 * word) as *mut u32
}

fn read_word(p: *mut u32) -> u32 {
    // SAFETY: `p` is a descriptor word inside the DMA area (`desc_word`), which only this
    // driver and the GEM use.
    unsafe { p.read_volatile() }
}

fn write_word(p: *mut u32, v: u32) {
    // SAFETY: as in `read_word`.
    unsafe { p.write_volatile(v) }
}

/// Orders the CPU's memory accesses (the descriptor hand-over).
#[inline(always)]
fn dmb() {
    // SAFETY: a barrier only.
    unsafe { core::arch::asm!("dmb", options(nostack, preserves_flags)) };
}

/// Waits until the CPU's writes have reached memory (before the GEM is told to look).
#[inline(always)]
fn dsb() {
    // SAFETY: a barrier only.
    unsafe { core::arch::asm!("dsb", options(nostack, preserves_flags)) };
}

/// The link speed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Speed {
    /// 10 Mb/s.
    Mb10,
    /// 100 Mb/s.
    Mb100,
    /// 1000 Mb/s.
    Mb1000,
}

impl Speed {
    /// In Mb/s.
    pub fn mbps(self) -> u32 {
        match self {
            Speed::Mb10 => 10,
            Speed::Mb100 => 100,
            Speed::Mb1000 => 1000,
        }
    }
}

/// The PHY found on the MDIO bus.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Phy {
    /// Its MDIO address.
    pub address: u8,
    /// Registers 2 and 3: OUI, model, revision.
    pub id: u32,
}

impl Phy {
    /// A Marvell PHY (OUI 0x005043: ID1 0x0141).
    pub fn is_marvell(&self) -> bool {
        self.id >> 16 == 0x0141
    }
}

/// What the PHY reported.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LinkState {
    /// Link up when last looked at.
    pub up: bool,
    /// The speed the MAC was configured for.
    pub speed: Speed,
    /// Full duplex.
    pub full_duplex: bool,
    /// Global-timer ticks spent waiting for the link.
    pub waited_ticks: u64,
}

/// Why an MDIO operation failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MdioError {
    /// The management logic stayed busy.
    Busy,
}

/// Clause-22 PHY registers.
mod mii {
    pub const BMCR: u8 = 0;
    pub const BMSR: u8 = 1;
    pub const ID1: u8 = 2;
    pub const ID2: u8 = 3;
    /// Marvell: page select.
    pub const MARVELL_PAGE: u8 = 22;
    /// Marvell, page 0: copper specific status.
    pub const MARVELL_COPPER_STATUS: u8 = 17;
    pub const BMCR_ANEG_ENABLE: u16 = 1 << 12;
    pub const BMCR_ANEG_RESTART: u16 = 1 << 9;
    pub const BMSR_LINK: u16 = 1 << 2;
    /// Copper status: speed and duplex resolved, duplex, speed (bits 15:14).
    pub const CS_RESOLVED: u16 = 1 << 11;
    pub const CS_FULL_DUPLEX: u16 = 1 << 13;
}

/// Settings for [`Gem::new`].
#[derive(Clone, Copy, Debug)]
pub struct GemConfig {
    /// Our MAC address.
    pub mac: [u8; 6],
    /// The MDIO address tried first (the ZedBoard's PHY is at 0).
    pub phy_address: u8,
    /// How long to wait for the PHY's link, in global-timer ticks.
    pub link_timeout_ticks: u64,
}

/// Counters since [`Gem::new`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GemStats {
    /// Frames handed to smoltcp.
    pub rx_frames: u32,
    /// Frames (or fragments) dropped: spread over several buffers, or longer than a buffer.
    pub rx_dropped: u32,
    /// Frames queued for transmission.
    pub tx_frames: u32,
}

/// The receive ring: the next descriptor to look at.
struct RxRing {
    regs: Registers,
    net_ctrl: u32,
    next: usize,
    stats_frames: u32,
    stats_dropped: u32,
}

impl RxRing {
    /// The length of the frame in the next descriptor, if one is there; drops what cannot be
    /// handed over (a frame spread over several buffers: not sent by a peer that respects the
    /// MTU).
    fn ready(&mut self) -> Option<usize> {
        loop {
            if read_word(desc_word(RX_DESCS, self.next, 0)) & RX_W0_OWNED_BY_SW == 0 {
                return None;
            }
            dmb();
            let status = read_word(desc_word(RX_DESCS, self.next, 1));
            let len = (status & RX_W1_LENGTH) as usize;
            if status & (RX_W1_SOF | RX_W1_EOF) == RX_W1_SOF | RX_W1_EOF && len <= BUFFER_LEN {
                return Some(len);
            }
            self.stats_dropped += 1;
            self.release();
        }
    }

    /// The buffer of the next descriptor.
    fn buffer(&self, len: usize) -> &[u8] {
        // SAFETY: the descriptor is owned by software (`ready`), so the GEM does not write
        // this buffer until `release`; it lies inside the DMA area, which nothing else uses.
        unsafe {
            core::slice::from_raw_parts((RX_BUFFERS + self.next * BUFFER_LEN) as *const u8, len)
        }
    }

    /// Gives the next descriptor back to the GEM and moves on.
    fn release(&mut self) {
        let i = self.next;
        let wrap = if i == RX_COUNT - 1 { RX_W0_WRAP } else { 0 };
        // Reads of the buffer are done before the GEM may write it again.
        dmb();
        write_word(desc_word(RX_DESCS, i, 1), 0);
        write_word(
            desc_word(RX_DESCS, i, 0),
            (RX_BUFFERS + i * BUFFER_LEN) as u32 | wrap,
        );
        self.next = (i + 1) % RX_COUNT;
        dsb();
        if self.regs.read(reg::RX_STATUS) & RX_STATUS_BUFFER_NOT_AVAIL != 0 {
            // The receiver met a full ring. Silicon re-reads the descriptor on the next frame;
            // QEMU's model only when net_ctrl is written with RX enabled.
            self.regs.write(reg::RX_STATUS, RX_STATUS_BUFFER_NOT_AVAIL);
            self.regs.write(reg::NET_CTRL, self.net_ctrl);
        }
    }
}

/// The transmit ring: the next descriptor to fill.
struct TxRing {
    regs: Registers,
    net_ctrl: u32,
    next: usize,
    stats_frames: u32,
}

impl TxRing {
    /// Whether the next descriptor is free (sent, or never used).
    fn free(&self) -> bool {
        read_word(desc_word(TX_DESCS, self.next, 1)) & TX_W1_USED != 0
    }

    /// Lets `f` write a frame of `len` bytes into the next buffer and sends it.
    fn send<R>(&mut self, len: usize, f: impl FnOnce(&mut [u8]) -> R) -> R {
        let i = self.next;
        let len = len.min(MAX_FRAME);
        // SAFETY: the descriptor is owned by software (`free`, checked before the token was
        // made, and only this ring hands descriptors to the GEM), so the GEM does not read
        // the buffer until the word below hands it over; it lies inside the DMA area.
        let buffer = unsafe {
            core::slice::from_raw_parts_mut((TX_BUFFERS + i * BUFFER_LEN) as *mut u8, len)
        };
        let r = f(buffer);
        let wrap = if i == TX_COUNT - 1 { TX_W1_WRAP } else { 0 };
        // The frame is in memory before the descriptor says so, and both before the GEM looks.
        dmb();
        write_word(
            desc_word(TX_DESCS, i, 1),
            (len as u32 & TX_W1_LENGTH) | TX_W1_LAST | wrap,
        );
        dsb();
        self.next = (i + 1) % TX_COUNT;
        self.stats_frames += 1;
        self.regs
            .write(reg::NET_CTRL, self.net_ctrl | ctrl::START_TX);
        r
    }
}

/// GEM0, initialised, with its PHY looked at: smoltcp's [`phy::Device`].
pub struct Gem {
    regs: Registers,
    rx: RxRing,
    tx: TxRing,
    phy: Option<Phy>,
    link: LinkState,
}

impl Gem {
    /// Resets and configures GEM0 (UG585 16.3.1 to 16.3.6): interrupts masked, both rings set
    /// up, our MAC address, the management port enabled; finds the PHY, waits up to
    /// `config.link_timeout_ticks` for its link, sets speed and duplex from it; then enables
    /// RX and TX. Returns `None` if GEM0 is already taken.
    ///
    /// GEM0's clocks, MIO pins and reset are the boot loader's business (the FSBL sets them up
    /// for the board's RGMII PHY); QEMU needs none of them.
    pub fn new(config: GemConfig) -> Option<Gem> {
        if TAKEN.swap(true, Ordering::AcqRel) {
            return None;
        }
        let regs = Registers { base: GEM0_BASE };
        // 16.3.1: stop everything, clear statistics and status, mask every interrupt.
        regs.write(reg::NET_CTRL, 0);
        regs.write(reg::NET_CTRL, ctrl::CLEAR_STAT_REGS);
        regs.write(reg::TX_STATUS, TX_STATUS_ALL);
        regs.write(reg::RX_STATUS, RX_STATUS_ALL);
        regs.write(reg::INTR_DIS, ALL_INTERRUPTS);
        let _ = regs.read(reg::INTR_STATUS);
        regs.write(reg::INTR_STATUS, ALL_INTERRUPTS);
        regs.write(reg::RX_QBAR, 0);
        regs.write(reg::TX_QBAR, 0);

        // 16.3.2: 100 Mb/s full duplex until the PHY says otherwise, FCS stripped, broadcast
        // accepted, no hash filters, receive buffer offset 0, MDC = cpu_1x / 64.
        let net_cfg_base = cfg::FULL_DUPLEX
            | cfg::RX_1536_BYTE_FRAMES
            | cfg::FCS_REMOVE
            | cfg::MDC_CLK_DIV_64
            | (0 << cfg::RX_BUF_OFFSET_SHIFT);
        regs.write(reg::NET_CFG, net_cfg_base | cfg::SPEED_100);
        // Our address: bottom half first, the top half activates the match.
        let m = config.mac;
        regs.write(
            reg::SPEC_ADDR1_BOT,
            u32::from_le_bytes([m[0], m[1], m[2], m[3]]),
        );
        regs.write(reg::SPEC_ADDR1_TOP, u32::from_le_bytes([m[4], m[5], 0, 0]));

        // 16.3.5/16.3.6: the rings. RX descriptors belong to the GEM (ownership bit clear),
        // TX descriptors to software (used bit set); the last of each wraps.
        for i in 0..RX_COUNT {
            let wrap = if i == RX_COUNT - 1 { RX_W0_WRAP } else { 0 };
            write_word(desc_word(RX_DESCS, i, 1), 0);
            write_word(
                desc_word(RX_DESCS, i, 0),
                (RX_BUFFERS + i * BUFFER_LEN) as u32 | wrap,
            );
        }
        for i in 0..TX_COUNT {
            let wrap = if i == TX_COUNT - 1 { TX_W1_WRAP } else { 0 };
            write_word(
                desc_word(TX_DESCS, i, 0),
                (TX_BUFFERS + i * BUFFER_LEN) as u32,
            );
            write_word(desc_word(TX_DESCS, i, 1), TX_W1_USED | wrap);
        }
        dsb();
        // Little-endian descriptors and data (endian-swap bits 6 and 7 clear), buffers of
        // BUFFER_LEN, full packet buffers, no checksum offload (smoltcp computes checksums).
        regs.write(
            reg::DMA_CFG,
            dma::BURST_INCR16
                | dma::RX_PKTBUF_FULL
                | dma::TX_PKTBUF_FULL
                | ((BUFFER_LEN / 64) as u32) << dma::RX_BUF_SIZE_SHIFT,
        );
        regs.write(reg::RX_QBAR, RX_DESCS as u32);
        regs.write(reg::TX_QBAR, TX_DESCS as u32);

        // 16.3.4: the PHY, through the management port.
        regs.write(reg::NET_CTRL, ctrl::MGMT_PORT_EN);
        let mut gem = Gem {
            regs,
            rx: RxRing {
                regs,
                net_ctrl: 0,
                next: 0,
                stats_frames: 0,
                stats_dropped: 0,
            },
            tx: TxRing {
                regs,
                net_ctrl: 0,
                next: 0,
                stats_frames: 0,
            },
            phy: None,
            link: LinkState {
                up: false,
                speed: Speed::Mb100,
                full_duplex: true,
                waited_ticks: 0,
            },
        };
        gem.phy = gem.find_phy(config.phy_address);
        if let Some(phy) = gem.phy {
            gem.link = gem.wait_for_link(phy, config.link_timeout_ticks);
        }
        let speed_bits = match gem.link.speed {
            Speed::Mb10 => 0,
            Speed::Mb100 => cfg::SPEED_100,
            Speed::Mb1000 => cfg::GIGE_EN,
        };
        let duplex = if gem.link.full_duplex {
            0
        } else {
            // Clear FULL_DUPLEX below.
            cfg::FULL_DUPLEX
        };
        regs.write(reg::NET_CFG, (net_cfg_base & !duplex) | speed_bits);

        // Go: every later net_ctrl write keeps these bits.
        let net_ctrl = ctrl::MGMT_PORT_EN | ctrl::RX_EN | ctrl::TX_EN;
        gem.rx.net_ctrl = net_ctrl;
        gem.tx.net_ctrl = net_ctrl;
        regs.write(reg::NET_CTRL, net_ctrl);
        Some(gem)
    }

    /// The PHY found on the MDIO bus, if any.
    pub fn phy(&self) -> Option<Phy> {
        self.phy
    }

    /// The link as the PHY reported it at start-up.
    pub fn link(&self) -> LinkState {
        self.link
    }

    /// Counters: frames in and out, as the driver and as the GEM counted them
    /// (`frames_rx`, `frames_tx`).
    pub fn stats(&self) -> (GemStats, u32, u32) {
        (
            GemStats {
                rx_frames: self.rx.stats_frames,
                rx_dropped: self.rx.stats_dropped,
                tx_frames: self.tx.stats_frames,
            },
            self.regs.read(reg::FRAMES_RX),
            self.regs.read(reg::FRAMES_TX),
        )
    }

    /// Waits (bounded: 1 ms of a 333 MHz timer, 10 ms of QEMU's) for the management logic.
    fn mdio_idle(&self) -> Result<(), MdioError> {
        let start = global_timer_ticks();
        while self.regs.read(reg::NET_STATUS) & NET_STATUS_PHY_MGMT_IDLE == 0 {
            if global_timer_ticks().wrapping_sub(start) > 1_000_000 {
                return Err(MdioError::Busy);
            }
        }
        Ok(())
    }

    /// One clause-22 operation (UG585 B, `phy_maint`): bits 31:30 = 01, 29:28 the operation
    /// (10 read, 01 write), 27:23 the PHY, 22:18 the register, 17:16 = 10, 15:0 the data.
    fn mdio(&self, write: bool, phy: u8, register: u8, data: u16) -> Result<u16, MdioError> {
        self.mdio_idle()?;
        let op = if write { 0b01 } else { 0b10 };
        self.regs.write(
            reg::PHY_MAINT,
            (0b01 << 30)
                | (op << 28)
                | ((phy as u32 & 0x1F) << 23)
                | ((register as u32 & 0x1F) << 18)
                | (0b10 << 16)
                | data as u32,
        );
        self.mdio_idle()?;
        Ok(self.regs.read(reg::PHY_MAINT) as u16)
    }

    /// Reads PHY register `register` at address `phy`.
    pub fn mdio_read(&self, phy: u8, register: u8) -> Result<u16, MdioError> {
        self.mdio(false, phy, register, 0)
    }

    /// Writes PHY register `register` at address `phy`.
    pub fn mdio_write(&self, phy: u8, register: u8, value: u16) -> Result<(), MdioError> {
        self.mdio(true, phy, register, value).map(|_| ())
    }

    /// The PHY's identifier at `address`, if one answers there (an empty address reads as
    /// all ones: the bus's pull-up).
    fn phy_id(&self, address: u8) -> Option<u32> {
        let id1 = self.mdio_read(address, mii::ID1).ok()?;
        let id2 = self.mdio_read(address, mii::ID2).ok()?;
        let id = (id1 as u32) << 16 | id2 as u32;
        (id1 != 0xFFFF && id != 0).then_some(id)
    }

    /// The PHY at `preferred`, else at the first address that answers.
    fn find_phy(&self, preferred: u8) -> Option<Phy> {
        core::iter::once(preferred)
            .chain((0..32).filter(|&a| a != preferred))
            .find_map(|address| self.phy_id(address).map(|id| Phy { address, id }))
    }

    /// Makes sure auto-negotiation is on, waits up to `timeout_ticks` for the link, and
    /// reads the speed and duplex it resolved (Marvell: copper status; others: assumed
    /// 100 Mb/s full duplex).
    fn wait_for_link(&self, phy: Phy, timeout_ticks: u64) -> LinkState {
        let a = phy.address;
        let mut state = self.link;
        if let Ok(bmcr) = self.mdio_read(a, mii::BMCR) {
            if bmcr & mii::BMCR_ANEG_ENABLE == 0 {
                let _ = self.mdio_write(
                    a,
                    mii::BMCR,
                    bmcr | mii::BMCR_ANEG_ENABLE | mii::BMCR_ANEG_RESTART,
                );
            }
        }
        let start = global_timer_ticks();
        loop {
            // The link bit latches low: the second read is the present state.
            let _ = self.mdio_read(a, mii::BMSR);
            if let Ok(bmsr) = self.mdio_read(a, mii::BMSR) {
                if bmsr & mii::BMSR_LINK != 0 {
                    state.up = true;
                    break;
                }
            }
            if global_timer_ticks().wrapping_sub(start) > timeout_ticks {
                break;
            }
        }
        state.waited_ticks = global_timer_ticks().wrapping_sub(start);
        if state.up && phy.is_marvell() {
            let _ = self.mdio_write(a, mii::MARVELL_PAGE, 0);
            if let Ok(cs) = self.mdio_read(a, mii::MARVELL_COPPER_STATUS) {
                if cs & mii::CS_RESOLVED != 0 {
                    state.full_duplex = cs & mii::CS_FULL_DUPLEX != 0;
                    state.speed = match cs >> 14 {
                        0b10 => Speed::Mb1000,
                        0b01 => Speed::Mb100,
                        _ => Speed::Mb10,
                    };
                }
            }
        }
        state
    }
}

/// A received frame: its descriptor goes back to the GEM once smoltcp has read it.
pub struct GemRxToken<'a> {
    ring: &'a mut RxRing,
    len: usize,
}

impl phy::RxToken for GemRxToken<'_> {
    fn consume<R, F>(self, f: F) -> R
    where
        F: FnOnce(&[u8]) -> R,
    {
        let r = f(self.ring.buffer(self.len));
        self.ring.stats_frames += 1;
        self.ring.release();
        r
    }
}

/// A free transmit descriptor.
pub struct GemTxToken<'a> {
    ring: &'a mut TxRing,
}

impl phy::TxToken for GemTxToken<'_> {
    fn consume<R, F>(self, len: usize, f: F) -> R
    where
        F: FnOnce(&mut [u8]) -> R,
    {
        self.ring.send(len, f)
    }
}

impl phy::Device for Gem {
    type RxToken<'a> = GemRxToken<'a>;
    type TxToken<'a> = GemTxToken<'a>;

    fn receive(&mut self, _timestamp: Instant) -> Option<(GemRxToken<'_>, GemTxToken<'_>)> {
        // A frame is taken only when an answer could be sent (a free TX descriptor: the GEM
        // sends in microseconds, QEMU's model at once).
        if !self.tx.free() {
            return None;
        }
        let len = self.rx.ready()?;
        Some((
            GemRxToken {
                ring: &mut self.rx,
                len,
            },
            GemTxToken { ring: &mut self.tx },
        ))
    }

    fn transmit(&mut self, _timestamp: Instant) -> Option<GemTxToken<'_>> {
        if self.tx.free() {
            Some(GemTxToken { ring: &mut self.tx })
        } else {
            None
        }
    }

    fn capabilities(&self) -> DeviceCapabilities {
        let mut caps = DeviceCapabilities::default();
        caps.medium = Medium::Ethernet;
        caps.max_transmission_unit = MAX_FRAME;
        caps.max_burst_size = Some(TX_COUNT);
        caps
    }
}
