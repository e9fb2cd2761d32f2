//! The firmware's memory map (first 128 MiB of Zynq DDR). Keep in sync with `link.x` and
//! `scripts/run-qemu.sh`.
//!
//! Input bytes are put into RAM by QEMU before the CPU starts:
//! `-device loader,file=<input>,addr=0x04000000,force-raw=on` for the bytes, and two 32-bit
//! words (`-device loader,addr=...,data=...,data-len=4`) for the descriptor `{magic, length}`
//! at [`INPUT_DESC_ADDR`]. `scripts/run-qemu.sh <elf> <input>` does both.

/// Start of the RAM region the image is linked into.
pub const RAM_BASE: usize = 0x0010_0000;
/// End (exclusive) of that region; the main stack ends here.
pub const RAM_END: usize = 0x03F0_0000;
/// Address of the input descriptor: `u32` magic [`INPUT_MAGIC`], then `u32` length in bytes.
pub const INPUT_DESC_ADDR: usize = 0x03FF_FFF0;
/// "FSMI" as a little-endian `u32`.
pub const INPUT_MAGIC: u32 = u32::from_le_bytes(*b"FSMI");
/// Where the input bytes start.
pub const INPUT_BASE: usize = 0x0400_0000;
/// Largest input that fits below the end of QEMU's default 128 MiB of DDR.
pub const INPUT_MAX_LEN: usize = 0x0400_0000;

/// Address of the plan descriptor: `u32` magic [`PLAN_MAGIC`], then `u32` length (80 for an FSM
/// plan, 32 or 96 for a baseline's), then the plan's canonical bytes (`MethodPlan::to_bytes`)
/// at [`PLAN_BYTES_ADDR`]. Written by `scripts/run-qemu.sh --plan <file>`.
pub const PLAN_DESC_ADDR: usize = 0x03FF_FF00;
/// Where the plan bytes start.
pub const PLAN_BYTES_ADDR: usize = PLAN_DESC_ADDR + 8;
/// "PLAN" as a little-endian `u32`.
pub const PLAN_MAGIC: u32 = u32::from_le_bytes(*b"PLAN");

/// The plan length from a descriptor, if valid: a length some method's plan has.
pub fn plan_len_from_descriptor(magic: u32, len: u32) -> Option<usize> {
    let lens = fsm_core::methods::wire::PLAN_LENGTHS;
    (magic == PLAN_MAGIC && lens.contains(&(len as usize))).then_some(len as usize)
}

/// The plan bytes that QEMU's loader placed in the mailbox, if a valid descriptor is present.
#[cfg(target_os = "none")]
pub fn plan() -> Option<&'static [u8]> {
    let desc = PLAN_DESC_ADDR as *const u32;
    // SAFETY: fixed addresses in the mailbox page outside the image (see link.x).
    let (magic, len) = unsafe { (desc.read_volatile(), desc.add(1).read_volatile()) };
    let len = plan_len_from_descriptor(magic, len)?;
    Some(unsafe { core::slice::from_raw_parts(PLAN_BYTES_ADDR as *const u8, len) })
}

/// Address of the self-test descriptor: `u32` magic [`SELFTEST_MAGIC`], then `u32` request
/// (see [`SelfTest`]). Written by `scripts/run-qemu.sh --selftest <name>` to check that every
/// failure path ends QEMU with the right exit code.
pub const SELFTEST_DESC_ADDR: usize = 0x03FF_FFE0;
/// "TEST" as a little-endian `u32`.
pub const SELFTEST_MAGIC: u32 = u32::from_le_bytes(*b"TEST");

/// Failure paths the firmware can be asked to take instead of its work.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SelfTest {
    /// `panic!` -> panic handler -> QEMU exit code 101.
    Panic,
    /// Load from the unmapped first MiB -> data abort -> exit code 102.
    DataAbort,
    /// `udf` -> undefined-instruction exception -> exit code 102.
    Undefined,
    /// Semihosting exit with this code (1..=255).
    Exit(u8),
}

impl SelfTest {
    /// Decode the request word: 1 panic, 2 data abort, 3 undefined, 0x100 + n exit(n).
    pub fn from_word(w: u32) -> Option<SelfTest> {
        match w {
            1 => Some(SelfTest::Panic),
            2 => Some(SelfTest::DataAbort),
            3 => Some(SelfTest::Undefined),
            0x101..=0x1FF => Some(SelfTest::Exit((w - 0x100) as u8)),
            _ => None,
        }
    }
}

/// The self-test request, if a valid descriptor is present.
#[cfg(target_os = "none")]
pub fn selftest() -> Option<SelfTest> {
    let d = SELFTEST_DESC_ADDR as *const u32;
    // SAFETY: fixed mailbox address in DDR outside the image (see link.x).
    let (magic, w) = unsafe { (d.read_volatile(), d.add(1).read_volatile()) };
    if magic == SELFTEST_MAGIC {
        SelfTest::from_word(w)
    } else {
        None
    }
}

/// Address of the UART descriptor: `u32` magic [`UART_MAGIC`], then `u32` the UART's index
/// (0: UART0 at 0xE000_0000, 1: UART1 at 0xE000_1000). Written by `scripts/run-qemu.sh
/// --serve-uart PORT`: the firmware then serves the protocol on that UART, session after
/// session, instead of looking at the other mailboxes, and makes no semihosting call.
pub const UART_DESC_ADDR: usize = 0x03FF_FFD8;
/// "UART" as a little-endian `u32`.
pub const UART_MAGIC: u32 = u32::from_le_bytes(*b"UART");

/// The UART index from a descriptor, if valid.
pub fn uart_from_descriptor(magic: u32, index: u32) -> Option<u8> {
    (magic == UART_MAGIC && index <= 1).then_some(index as u8)
}

/// The UART to serve on, if a valid descriptor is present.
#[cfg(target_os = "none")]
pub fn uart() -> Option<u8> {
    let d = UART_DESC_ADDR as *const u32;
    // SAFETY: fixed mailbox address in DDR outside the image (see link.x).
    let (magic, index) = unsafe { (d.read_volatile(), d.add(1).read_volatile()) };
    uart_from_descriptor(magic, index)
}

/// Where the Ethernet controller's DMA descriptor rings and buffers live (`arm/gem.rs`): the
/// start of the mailbox MiB, which the MMU maps Normal non-cacheable (`arm/cpu.rs`) because
/// the GEM's DMA does not see the CPU's data cache. Nothing else uses these 512 KiB (QEMU's
/// loader writes only the descriptors at the top of the MiB).
pub const GEM_DMA_BASE: usize = 0x03F0_0000;
/// Its length.
pub const GEM_DMA_LEN: usize = 0x0008_0000;
const _: () = assert!(
    GEM_DMA_BASE == RAM_END
        && GEM_DMA_BASE.is_multiple_of(0x10_0000)
        && GEM_DMA_BASE + GEM_DMA_LEN <= NET_DESC_ADDR
);

/// Address of the Ethernet descriptor, five `u32`s: magic [`NET_MAGIC`] ("NET "), the TCP port
/// (0: [`fsm_protocol::DEFAULT_TCP_PORT`]), the IPv4 address as `a << 24 | b << 16 | c << 8 | d`
/// (0: [`NetConfig::DEFAULT`]'s, with its prefix and gateway; `0xFFFF_FFFF`: ask a DHCP server),
/// the prefix length (0: 24), the gateway in the same form (0: none, or the default's with the
/// default address). Written by
/// `scripts/run-qemu.sh --serve-net PORT`: the firmware then serves the protocol over GEM0 and
/// TCP, connection after connection, and makes no semihosting call after its `SERVE NET` line.
pub const NET_DESC_ADDR: usize = 0x03FF_FFC0;
/// "NET " as a little-endian `u32`.
pub const NET_MAGIC: u32 = u32::from_le_bytes(*b"NET ");

/// Where and how the camera serves over Ethernet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NetConfig {
    /// TCP port of the protocol's listener.
    pub port: u16,
    /// Our IPv4 address.
    pub address: [u8; 4],
    /// The subnet's prefix length.
    pub prefix_len: u8,
    /// The default route, if any.
    pub gateway: Option<[u8; 4]>,
    /// Address, prefix and route come from a DHCP server (`arm::net`); the three fields above
    /// hold the lease once there is one (0.0.0.0/0 before).
    pub dhcp: bool,
}

impl NetConfig {
    /// QEMU user networking's guest address, 10.0.2.15/24 with the gateway 10.0.2.2 (QEMU's
    /// slirp; `hostfwd` connections arrive from it), on the protocol's port. A board on
    /// another network gets its address from the descriptor (or a build with other defaults).
    pub const DEFAULT: NetConfig = NetConfig {
        port: fsm_protocol::DEFAULT_TCP_PORT,
        address: [10, 0, 2, 15],
        prefix_len: 24,
        gateway: Some([10, 0, 2, 2]),
        dhcp: false,
    };

    /// Ask a DHCP server, on the protocol's port.
    pub const DHCP: NetConfig = NetConfig {
        port: fsm_protocol::DEFAULT_TCP_PORT,
        address: [0, 0, 0, 0],
        prefix_len: 0,
        gateway: None,
        dhcp: true,
    };
}

/// The configuration from a descriptor's five words, if the magic matches and the values are
/// valid (a port up to 65535, a prefix up to 32, an address that is no broadcast address, which
/// asks for DHCP instead).
pub fn net_from_descriptor(words: [u32; 5]) -> Option<NetConfig> {
    let [magic, port, address, prefix, gateway] = words;
    if magic != NET_MAGIC || port > 0xFFFF || prefix > 32 {
        return None;
    }
    let port = if port == 0 {
        NetConfig::DEFAULT.port
    } else {
        port as u16
    };
    if address == 0 {
        return Some(NetConfig {
            port,
            ..NetConfig::DEFAULT
        });
    }
    if address == u32::MAX {
        return Some(NetConfig {
            port,
            ..NetConfig::DHCP
        });
    }
    Some(NetConfig {
        port,
        address: address.to_be_bytes(),
        prefix_len: if prefix == 0 { 24 } else { prefix as u8 },
        gateway: (gateway != 0).then(|| gateway.to_be_bytes()),
        dhcp: false,
    })
}

/// The Ethernet configuration, if a valid descriptor is present.
#[cfg(target_os = "none")]
pub fn net() -> Option<NetConfig> {
    let d = NET_DESC_ADDR as *const u32;
    let mut words = [0u32; 5];
    for (i, w) in words.iter_mut().enumerate() {
        // SAFETY: fixed mailbox address in DDR outside the image (see link.x).
        *w = unsafe { d.add(i).read_volatile() };
    }
    net_from_descriptor(words)
}

const _: () = assert!(
    RAM_END <= PLAN_DESC_ADDR
        && PLAN_BYTES_ADDR + fsm_core::methods::wire::MAX_PLAN_LEN <= NET_DESC_ADDR
        && NET_DESC_ADDR + 20 <= UART_DESC_ADDR
        && UART_DESC_ADDR + 8 <= SELFTEST_DESC_ADDR
);
const _: () = assert!(
    RAM_END <= SELFTEST_DESC_ADDR && SELFTEST_DESC_ADDR + 8 <= crate::icount::ICOUNT_DESC_ADDR
);
// The regions must not overlap, and the input window must end with QEMU's default 128 MiB.
const _: () =
    assert!(RAM_BASE < RAM_END && RAM_END <= INPUT_DESC_ADDR && INPUT_DESC_ADDR + 8 <= INPUT_BASE);
const _: () = assert!(INPUT_BASE + INPUT_MAX_LEN == 0x0800_0000);

/// Validate a descriptor: the input length if the magic matches and the length fits.
pub fn input_len_from_descriptor(magic: u32, len: u32) -> Option<usize> {
    (magic == INPUT_MAGIC && (len as usize) <= INPUT_MAX_LEN).then_some(len as usize)
}

/// The input bytes that QEMU's loader placed in RAM, if a valid descriptor is present.
#[cfg(target_os = "none")]
pub fn input() -> Option<&'static [u8]> {
    let desc = INPUT_DESC_ADDR as *const u32;
    // SAFETY: fixed addresses in DDR outside the image (see link.x); read-only use.
    let (magic, len) = unsafe { (desc.read_volatile(), desc.add(1).read_volatile()) };
    let len = input_len_from_descriptor(magic, len)?;
    Some(unsafe { core::slice::from_raw_parts(INPUT_BASE as *const u8, len) })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn selftest_words() {
        assert_eq!(SELFTEST_MAGIC, 0x5453_4554);
        assert_eq!(SelfTest::from_word(1), Some(SelfTest::Panic));
        assert_eq!(SelfTest::from_word(2), Some(SelfTest::DataAbort));
        assert_eq!(SelfTest::from_word(3), Some(SelfTest::Undefined));
        assert_eq!(SelfTest::from_word(0x100 + 7), Some(SelfTest::Exit(7)));
        assert_eq!(SelfTest::from_word(0x100), None);
        assert_eq!(SelfTest::from_word(0), None);
    }

    #[test]
    fn uart_descriptor() {
        assert_eq!(UART_MAGIC, 0x5452_4155);
        assert_eq!(uart_from_descriptor(UART_MAGIC, 0), Some(0));
        assert_eq!(uart_from_descriptor(UART_MAGIC, 1), Some(1));
        assert_eq!(uart_from_descriptor(UART_MAGIC, 2), None);
        assert_eq!(uart_from_descriptor(PLAN_MAGIC, 1), None);
    }

    #[test]
    fn net_descriptor() {
        assert_eq!(NET_MAGIC, 0x2054_454E);
        assert_eq!(
            net_from_descriptor([NET_MAGIC, 0, 0, 0, 0]),
            Some(NetConfig::DEFAULT)
        );
        assert_eq!(NetConfig::DEFAULT.port, 7070);
        let c = net_from_descriptor([NET_MAGIC, 8080, 0, 0, 0]).unwrap();
        assert_eq!(
            (c.port, c.address, c.gateway),
            (8080, [10, 0, 2, 15], Some([10, 0, 2, 2]))
        );
        let c = net_from_descriptor([NET_MAGIC, 0, 0xC0A8_010A, 16, 0xC0A8_0101]).unwrap();
        assert_eq!(
            c,
            NetConfig {
                port: 7070,
                address: [192, 168, 1, 10],
                prefix_len: 16,
                gateway: Some([192, 168, 1, 1]),
                dhcp: false,
            }
        );
        let c = net_from_descriptor([NET_MAGIC, 0, 0xC0A8_010A, 0, 0]).unwrap();
        assert_eq!((c.prefix_len, c.gateway), (24, None));
        assert_eq!(net_from_descriptor([UART_MAGIC, 0, 0, 0, 0]), None);
        assert_eq!(net_from_descriptor([NET_MAGIC, 65536, 0, 0, 0]), None);
        assert_eq!(
            net_from_descriptor([NET_MAGIC, 0, 0xC0A8_010A, 33, 0]),
            None
        );
        let c = net_from_descriptor([NET_MAGIC, 7071, u32::MAX, 0, 0]).unwrap();
        assert_eq!(
            c,
            NetConfig {
                port: 7071,
                ..NetConfig::DHCP
            }
        );
        assert!(c.dhcp);
    }

    #[test]
    fn plan_descriptor() {
        assert_eq!(PLAN_MAGIC, 0x4E41_4C50);
        assert_eq!(plan_len_from_descriptor(PLAN_MAGIC, 80), Some(80));
        assert_eq!(plan_len_from_descriptor(PLAN_MAGIC, 32), Some(32));
        assert_eq!(plan_len_from_descriptor(PLAN_MAGIC, 96), Some(96));
        assert_eq!(plan_len_from_descriptor(PLAN_MAGIC, 64), None);
        assert_eq!(plan_len_from_descriptor(PLAN_MAGIC, 97), None);
        assert_eq!(plan_len_from_descriptor(INPUT_MAGIC, 80), None);
    }

    #[test]
    fn descriptor() {
        assert_eq!(INPUT_MAGIC, 0x494D_5346);
        assert_eq!(input_len_from_descriptor(INPUT_MAGIC, 16), Some(16));
        assert_eq!(input_len_from_descriptor(0, 16), None);
        assert_eq!(
            input_len_from_descriptor(INPUT_MAGIC, (INPUT_MAX_LEN + 1) as u32),
            None
        );
    }
}
