//! The firmware image (bare metal) / the camera emulator and cross-check tools (host).
//!
//! Bare metal: `_start` (src/arm/start.rs) calls `fw_main`. When no semihosting host answers
//! (a board without a debugger, `run-qemu.sh --board`), it is a camera on its own: console on
//! UART1, the protocol over Ethernet, a reset on a panic (`board`). Otherwise it looks at the
//! input QEMU's loader placed in RAM (scripts/run-qemu.sh):
//! - a row dump (with the plan in its mailbox: `run-qemu.sh --plan PLAN ELF DUMP`): decode
//!   every row and write the candidate file `fw-candidates.bin`; under `--icount` also print
//!   exact instruction counts (`BENCH ...`);
//! - anything else is a recorded stream of request frames (a host session): serve it with the
//!   protocol device loop and write every response frame to `fw-link.bin`;
//! - no input: print the limits and exit 0;
//! - a UART descriptor (`run-qemu.sh --serve-uart PORT`): print `SERVE UART<n> ...` once the
//!   UART receives, then serve the protocol on it, session after session, for ever, without
//!   another semihosting call (see `serve_uart`);
//! - an Ethernet descriptor (`run-qemu.sh --serve-net PORT`): bring up GEM0 and TCP/IP, print
//!   `SERVE NET <address>:<port> ...` once listening, then serve the protocol over TCP,
//!   connection after connection, for ever, without another semihosting call (`serve_net`).
//!
//! Output files are written under a `.part` name and renamed when whole.
//!
//! Host: `fsm-firmware <command>`, see `usage()`.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod fw {
    use core::fmt;
    use core::ptr::addr_of_mut;

    use fsm_core::{Method, MethodPlan};
    use fsm_firmware::arm::cpu::global_timer_ticks;
    use fsm_firmware::arm::cpu::QEMU_NS_PER_GTIMER_TICK;
    use fsm_firmware::arm::gem::{Gem, GemConfig};
    use fsm_firmware::arm::net::{Net, NetTimeouts};
    use fsm_firmware::arm::semihosting::{self, File, Mode};
    use fsm_firmware::arm::stop;
    use fsm_firmware::arm::uart::{Port, Uart, BAUD};
    use fsm_firmware::batch::{self, BatchMemory, Sink};
    use fsm_firmware::device::{Device, Replay};
    use fsm_firmware::layout::{self, SelfTest};
    use fsm_firmware::limits::{self, Pixel};
    use fsm_firmware::memory::Storage;
    use fsm_firmware::scan::{NoProbe, Probe, RowBuffers};
    use fsm_firmware::{hprintln, icount};

    /// Candidate file written in QEMU's working directory.
    const OUT_PATH: &str = "fw-candidates.bin";
    /// Its name while being written.
    const PART_PATH: &str = "fw-candidates.bin.part";
    /// Exit code for input the firmware refuses (bad plan, bad dump).
    const EXIT_BAD_INPUT: u8 = 3;

    /// Every buffer of the camera, in .bss.
    static mut STORAGE: Storage = Storage::new();

    /// Silence inside a frame after which a UART session ends (the half frame is dropped):
    /// 2 s of the global timer at QEMU's rate. On a Zynq at 667 MHz the timer runs at 333 MHz
    /// (CPU/2), which makes it 0.6 s there, still thousands of byte times at 115,200 baud.
    const UART_FRAME_TIMEOUT_TICKS: u64 = 2_000_000_000 / QEMU_NS_PER_GTIMER_TICK;

    /// Serves the protocol on a UART for ever: a session ends when a frame stops half way
    /// (the time-out), and the next begins with the plan still loaded. Nothing here calls
    /// semihosting, so that a board without a debugger can run it; only a panic or a CPU
    /// exception would (and then parks the CPU: `arm::fsm_fw_exception`).
    fn serve_uart(mut uart: Uart, storage: &'static mut Storage) -> ! {
        let mut device = Device::new(storage.memory());
        loop {
            // A UART never closes: `serve` returns on a frame time-out only.
            let _ = device.serve(&mut uart);
        }
    }

    /// GEM0's MAC address: locally administered (bit 1 of the first byte set), unicast, "FSM" in
    /// its middle. A board on a shared network needs one of its own (ZedBoard: from its
    /// EEPROM or a Xilinx-assigned range); QEMU's slirp takes any.
    const MAC: [u8; 6] = [0x02, 0x46, 0x53, 0x4D, 0x00, 0x01];
    /// The PHY's MDIO address tried first: the ZedBoard's 88E1518 strap (QEMU's model answers
    /// at its own address, found by the scan).
    const PHY_ADDRESS: u8 = 0;
    /// How long start-up waits for the PHY's link: 5 s at QEMU's timer rate (1.5 s on a board:
    /// an 88E1518's auto-negotiation takes about 3 s after its reset, but the FSBL started it
    /// long before; a link that comes later still works, only its speed is not read again).
    const LINK_TIMEOUT_TICKS: u64 = 5_000_000_000 / QEMU_NS_PER_GTIMER_TICK;
    /// Silence inside a frame (or a host that takes no answer bytes) after which a TCP session
    /// ends: 5 s, the emulator's default `--frame-timeout`.
    const NET_FRAME_TIMEOUT_TICKS: u64 = 5_000_000_000 / QEMU_NS_PER_GTIMER_TICK;
    /// Silence between frames after which a TCP session ends: 120 s, the emulator's default
    /// `--idle-timeout` (a UART waits for ever; a TCP host that vanished without a word would
    /// otherwise hold the camera's only connection).
    const NET_IDLE_TIMEOUT_TICKS: u64 = 120_000_000_000 / QEMU_NS_PER_GTIMER_TICK;

    /// Silence between frames after which a TCP session ends when another host is waiting:
    /// 1 s, the emulator's default `--hand-over`.
    const NET_HAND_OVER_TICKS: u64 = 1_000_000_000 / QEMU_NS_PER_GTIMER_TICK;

    /// Serves the protocol over TCP for ever: one connection at a time, each a session; the
    /// plan stays loaded from one to the next. A closed or reset connection, a time-out or
    /// garbage ends a session, never the server. No semihosting call (see `serve_uart`) but
    /// the defmt log's, which a board without a debugger writes on UART0 (`arm::logger`).
    fn serve_net(mut net: Net, storage: &'static mut Storage) -> ! {
        let mut device = Device::new(storage.memory());
        loop {
            net.accept();
            let served = device.serve(&mut net);
            #[cfg(feature = "defmt")]
            match served {
                Ok(r) => defmt::info!(
                    "session: {=u32} requests, {=u32} rows, {=u32} refused",
                    r.requests,
                    r.rows,
                    r.errors
                ),
                Err(_) => defmt::info!("session ended by the connection"),
            }
            #[cfg(not(feature = "defmt"))]
            let _ = served;
            net.disconnect();
        }
    }

    /// Brings up GEM0 and the TCP listener for `config`, prints the `SERVE NET` line, serves.
    fn start_net(config: layout::NetConfig, storage: &'static mut Storage) -> ! {
        let Some(gem) = Gem::new(GemConfig {
            mac: MAC,
            phy_address: PHY_ADDRESS,
            link_timeout_ticks: LINK_TIMEOUT_TICKS,
        }) else {
            panic!("GEM0 taken twice")
        };
        let timeouts = NetTimeouts {
            frame_ticks: NET_FRAME_TIMEOUT_TICKS,
            idle_ticks: Some(NET_IDLE_TIMEOUT_TICKS),
            hand_over_ticks: NET_HAND_OVER_TICKS,
        };
        let (phy, link) = (gem.phy(), gem.link());
        let Some(net) = Net::new(gem, MAC, config, timeouts) else {
            panic!("TCP buffers taken twice")
        };
        // With DHCP: the lease's address (or 0.0.0.0 when none came in time).
        let served = net.config();
        let [a, b, c, d] = served.address;
        let m = MAC;
        hprintln!(
            "SERVE NET {}.{}.{}.{}:{} (/{}{}, MAC {:02x}:{:02x}:{:02x}:{:02x}:{:02x}:{:02x}, {}): the host protocol over TCP, connection after connection",
            a,
            b,
            c,
            d,
            served.port,
            served.prefix_len,
            match (served.dhcp, net.leased()) {
                (false, _) => "",
                (true, true) => " leased by DHCP",
                (true, false) => ", no DHCP lease yet: still asking",
            },
            m[0],
            m[1],
            m[2],
            m[3],
            m[4],
            m[5],
            LinkText(phy, link)
        );
        #[cfg(feature = "defmt")]
        defmt::info!(
            "serving the host protocol over TCP at {=u8}.{=u8}.{=u8}.{=u8}:{=u16}",
            a,
            b,
            c,
            d,
            served.port
        );
        serve_net(net, storage)
    }

    /// The PHY and its link for the `SERVE NET` line.
    struct LinkText(
        Option<fsm_firmware::arm::gem::Phy>,
        fsm_firmware::arm::gem::LinkState,
    );

    impl fmt::Display for LinkText {
        fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            let Some(phy) = self.0 else {
                return write!(f, "no PHY answers on MDIO");
            };
            let l = self.1;
            write!(f, "PHY {:#010x} at MDIO {}, link ", phy.id, phy.address)?;
            if l.up {
                write!(
                    f,
                    "up, {} Mb/s {} duplex",
                    l.speed.mbps(),
                    if l.full_duplex { "full" } else { "half" }
                )
            } else {
                write!(
                    f,
                    "down after {} ms (serving anyway)",
                    l.waited_ticks * QEMU_NS_PER_GTIMER_TICK / 1_000_000
                )
            }
        }
    }

    /// Take a failure path on request (scripts/run-qemu.sh --selftest ...).
    fn selftest(t: SelfTest) -> ! {
        hprintln!("SELFTEST {:?}", t);
        match t {
            SelfTest::Panic => panic!("self-test panic"),
            SelfTest::DataAbort => {
                // First MiB is unmapped (null guard): this load takes a data abort.
                let v = unsafe { (0x10 as *const u32).read_volatile() };
                panic!("load from the null guard did not fault (read {:#x})", v);
            }
            SelfTest::Undefined => {
                unsafe { core::arch::asm!("udf #0", options(nomem, nostack)) };
                panic!("udf did not trap");
            }
            SelfTest::Exit(code) => stop(code),
        }
    }

    /// The semihosting file as the batch output.
    struct FileSink(File);

    impl Sink for FileSink {
        type Error = semihosting::Error;
        fn write(&mut self, bytes: &[u8]) -> Result<(), Self::Error> {
            self.0.write_all(bytes)
        }
    }

    /// A short description of a plan for the log.
    struct PlanName<'a>(&'a MethodPlan);

    impl fmt::Display for PlanName<'_> {
        fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            let p = match self.0 {
                MethodPlan::Fsm(p) => p,
                other => {
                    return write!(
                        f,
                        "{} cmax={} frames={}",
                        other.name(),
                        other.projector_columns(),
                        other.frame_count()
                    )
                }
            };
            match p.method {
                Method::Bfsm => write!(f, "bfsm")?,
                Method::Efsm(b) => write!(f, "efsm-cB{}-groups{}", b.block_width, p.group_count())?,
            }
            write!(
                f,
                " cmax={} M={} N={} frames={}",
                p.projector_columns,
                p.band.count,
                p.transform_size,
                p.sequence_len()
            )
        }
    }

    /// Instructions since start-up (exact under -icount shift >= 4).
    fn instructions(shift: u32) -> u64 {
        icount::instructions_from_gtimer_ticks(global_timer_ticks(), shift)
    }

    /// Instruction counts of the table build and of each row (whole loop: unpack,
    /// decode_row, encode, write).
    struct RowClock {
        shift: u32,
        last: u64,
        tables: u64,
        sum: u64,
        min: u64,
        max: u64,
        /// Instructions inside `decode_row_lanes` alone.
        decode_sum: u64,
        decode_start: u64,
    }

    impl Probe for RowClock {
        const PER_PIXEL: bool = false;
        fn tables_built(&mut self) {
            self.tables = instructions(self.shift) - self.last;
            self.last = instructions(self.shift);
        }
        fn before_row(&mut self) {
            self.decode_start = instructions(self.shift);
        }
        fn after_row(&mut self) {
            self.decode_sum += instructions(self.shift) - self.decode_start;
        }
        fn end_row(&mut self, _row: u32, _len: usize) {
            let n = instructions(self.shift) - self.last;
            self.sum += n;
            self.min = self.min.min(n);
            self.max = self.max.max(n);
            self.last = instructions(self.shift);
        }
    }

    /// Instruction counts of each pixel's decode, by the number of candidates it got.
    struct PixelClock {
        shift: u32,
        overhead: u64,
        start: u64,
        count: [u64; 4],
        sum: [u64; 4],
        min: [u64; 4],
        max: [u64; 4],
    }

    impl Probe for PixelClock {
        const PER_PIXEL: bool = true;
        #[inline(always)]
        fn before(&mut self, _x: usize) {
            self.start = instructions(self.shift);
        }
        #[inline(always)]
        fn after(&mut self, _x: usize, pixel: &Pixel) {
            let n = instructions(self.shift) - self.start - self.overhead;
            let c = pixel.candidates.len().min(3);
            self.count[c] += 1;
            self.sum[c] += n;
            self.min[c] = self.min[c].min(n);
            self.max[c] = self.max[c].max(n);
        }
    }

    fn memory(storage: &mut Storage) -> BatchMemory<'_> {
        let m = storage.memory();
        BatchMemory {
            tables: m.tables,
            row: RowBuffers {
                scratch: m.scratch,
                samples: m.samples,
                pixels: m.pixels,
            },
            record: m.record,
        }
    }

    /// Scans the dump into `path`; returns rows and bytes or exits with a message.
    fn scan_to<P: Probe>(
        plan: &MethodPlan,
        dump: &[u8],
        storage: &mut Storage,
        path: &str,
        probe: &mut P,
    ) -> batch::BatchSummary {
        let file = match File::open(path, Mode::Write) {
            Ok(f) => f,
            Err(e) => panic!("open {} for writing: errno {}", path, e.errno),
        };
        let mut sink = FileSink(file);
        match batch::scan_dump(plan, dump, memory(storage), &mut sink, probe) {
            Ok(s) => s,
            Err(e) => {
                drop(sink);
                let _ = semihosting::remove(path);
                hprintln!("ERROR: {}", e);
                stop(EXIT_BAD_INPUT)
            }
        }
    }

    fn run_dump(plan: &MethodPlan, dump: &[u8], storage: &mut Storage, shift: Option<u32>) -> ! {
        hprintln!(
            "PLAN {} fingerprint={:016x}",
            PlanName(plan),
            plan.fingerprint()
        );
        #[cfg(feature = "defmt")]
        defmt::info!(
            "plan {=u64:#018x} accepted, {=usize} frames per row",
            plan.fingerprint(),
            plan.frame_count()
        );
        let summary = match shift {
            None => scan_to(plan, dump, storage, PART_PATH, &mut NoProbe),
            Some(shift) => {
                let mut clock = RowClock {
                    shift,
                    last: instructions(shift),
                    tables: 0,
                    sum: 0,
                    min: u64::MAX,
                    max: 0,
                    decode_sum: 0,
                    decode_start: 0,
                };
                let s = scan_to(plan, dump, storage, PART_PATH, &mut clock);
                let pixels = s.rows as u64 * s.dump.width as u64;
                hprintln!(
                    "BENCH tables instructions={} (Decoder::new: the plan's tables, once per plan)",
                    clock.tables
                );
                hprintln!(
                    "BENCH loop rows={} width={} pixels={} instructions={} per_pixel={} per_row_min={} per_row_max={}",
                    s.rows,
                    s.dump.width,
                    pixels,
                    clock.sum,
                    clock.sum / pixels.max(1),
                    clock.min,
                    clock.max
                );
                hprintln!(
                    "BENCH decode pixels={} instructions={} per_pixel={} (decode_row_lanes alone, {} lanes)",
                    pixels,
                    clock.decode_sum,
                    clock.decode_sum / pixels.max(1),
                    fsm_firmware::limits::LANES
                );
                s
            }
        };
        if let Err(e) = semihosting::rename(PART_PATH, OUT_PATH) {
            panic!("rename {} to {}: errno {}", PART_PATH, OUT_PATH, e.errno);
        }
        hprintln!(
            "CANDIDATES {} rows={} width={} bytes={}",
            OUT_PATH,
            summary.rows,
            summary.dump.width,
            summary.bytes
        );
        #[cfg(feature = "defmt")]
        defmt::info!(
            "decoded {=u32} rows of {=u32} pixels: {=u64} bytes of candidates",
            summary.rows,
            summary.dump.width,
            summary.bytes
        );

        if let Some(shift) = shift {
            // Second pass, pixel by pixel, for the cost of each kind of pixel. Its output must
            // be the same file (checked by the scripts).
            let (a, b) = (instructions(shift), instructions(shift));
            let mut clock = PixelClock {
                shift,
                overhead: b - a,
                start: 0,
                count: [0; 4],
                sum: [0; 4],
                min: [u64::MAX; 4],
                max: [0; 4],
            };
            scan_to(
                plan,
                dump,
                storage,
                "fw-candidates-per-pixel.bin",
                &mut clock,
            );
            let names = ["0", "1", "2", "3+"];
            let (mut n, mut sum) = (0, 0);
            for c in 0..4 {
                n += clock.count[c];
                sum += clock.sum[c];
                if clock.count[c] > 0 {
                    hprintln!(
                        "BENCH pixels candidates={} pixels={} decode_per_pixel={} min={} max={}",
                        names[c],
                        clock.count[c],
                        clock.sum[c] / clock.count[c],
                        clock.min[c],
                        clock.max[c]
                    );
                }
            }
            hprintln!(
                "BENCH pixels candidates=all pixels={} decode_per_pixel={} (timer overhead {} subtracted)",
                n,
                sum / n.max(1),
                clock.overhead
            );
        }
        stop(0)
    }

    /// Serves a recorded request stream; the responses go to `fw-link.bin`.
    fn run_session(requests: &[u8], storage: &mut Storage) -> ! {
        const LINK_PART: &str = "fw-link.bin.part";
        const LINK_PATH: &str = "fw-link.bin";
        let file = match File::open(LINK_PART, Mode::Write) {
            Ok(f) => f,
            Err(e) => panic!("open {} for writing: errno {}", LINK_PART, e.errno),
        };
        let mut device = Device::new(storage.memory());
        let mut link = Replay::new(requests, FileSink(file));
        match device.serve(&mut link) {
            Ok(r) => {
                drop(link);
                if let Err(e) = semihosting::rename(LINK_PART, LINK_PATH) {
                    panic!("rename {} to {}: errno {}", LINK_PART, LINK_PATH, e.errno);
                }
                hprintln!(
                    "SESSION {} requests={} rows={} errors={}",
                    LINK_PATH,
                    r.requests,
                    r.rows,
                    r.errors
                );
                #[cfg(feature = "defmt")]
                defmt::info!(
                    "session: {=u32} requests, {=u32} rows, {=u32} refused",
                    r.requests,
                    r.rows,
                    r.errors
                );
                stop(0)
            }
            Err(e) => {
                drop(link);
                let _ = semihosting::remove(LINK_PART);
                panic!("writing {}: errno {}", LINK_PART, e.errno)
            }
        }
    }

    /// The first console line: version and limits.
    fn banner() {
        hprintln!(
            "fsm-firmware {} (armv7a-none-eabihf, Cortex-A9): buffers {} bytes, rows up to {} pixels / {} samples, {} candidates per pixel",
            env!("CARGO_PKG_VERSION"),
            fsm_firmware::memory::MEMORY_BYTES,
            limits::MAX_WIDTH,
            limits::MAX_ROW_SAMPLES,
            limits::CANDIDATE_CAPACITY
        );
    }

    /// No semihosting host answers: a board that booted on its own (U-Boot's `go`, an SD card)
    /// or `run-qemu.sh --board`. The console is UART1; the camera serves the protocol over
    /// Ethernet at the address of the `NET ` descriptor (U-Boot writes it with `mw.l`,
    /// `scripts/image-arm.sh` makes the commands) or [`layout::NetConfig::DEFAULT`]'s. The input,
    /// plan and UART descriptors are the QEMU scripts' and are not looked at (a board's DDR
    /// holds noise at power-on); a self-test request is honoured, so that a test can see a
    /// panic reach the console and reset the SoC.
    fn board(storage: &'static mut Storage) -> ! {
        banner();
        hprintln!("BOARD no debugger answers: console on UART1, the protocol over Ethernet (GEM0)");
        if let Some(t) = layout::selftest() {
            selftest(t);
        }
        start_net(layout::net().unwrap_or(layout::NetConfig::DEFAULT), storage)
    }

    #[no_mangle]
    pub extern "C" fn fw_main() -> ! {
        // SAFETY: the only reference to STORAGE, taken once.
        let storage: &'static mut Storage = unsafe { &mut *addr_of_mut!(STORAGE) };
        if !semihosting::host_present() {
            board(storage)
        }
        // Before the banner: serving over a UART makes no semihosting call but one. The
        // descriptor comes from QEMU's loader, so a semihosting host is there to print that
        // the UART is ready: a host that sends before RX is enabled loses its bytes (UG585;
        // QEMU's model drops them too). A board booting into `serve_uart` would skip the line.
        // The same for Ethernet: the line comes once the socket listens.
        if let Some(config) = layout::net() {
            start_net(config, storage)
        }
        if let Some((index, port)) = layout::uart().and_then(|i| Some((i, Port::from_index(i)?))) {
            let uart = Uart::new(port, UART_FRAME_TIMEOUT_TICKS);
            hprintln!(
                "SERVE UART{} at {} baud, 8N1: the host protocol, session after session",
                index,
                BAUD
            );
            serve_uart(uart, storage)
        }
        banner();
        if let Some(t) = layout::selftest() {
            selftest(t);
        }
        let shift = icount::shift();
        if let Some(s) = shift {
            hprintln!(
                "ICOUNT shift={} ({})",
                s,
                if s >= icount::EXACT_SHIFT {
                    "exact"
                } else {
                    "approximate: use shift>=4"
                }
            );
        }
        let is_dump = |input: &[u8]| input.starts_with(&fsm_core::wire::row_dump::MAGIC);
        match (layout::input(), layout::plan()) {
            (Some(requests), None) if !is_dump(requests) => {
                hprintln!("INPUT request frames, {} bytes", requests.len());
                run_session(requests, storage)
            }
            (Some(dump), Some(plan_bytes)) if is_dump(dump) => {
                hprintln!("INPUT row dump, {} bytes", dump.len());
                match MethodPlan::from_bytes(plan_bytes) {
                    Ok(plan) => run_dump(&plan, dump, storage, shift),
                    Err(e) => {
                        hprintln!("ERROR: plan mailbox: {}", e);
                        stop(EXIT_BAD_INPUT)
                    }
                }
            }
            (Some(_), None) => {
                hprintln!(
                    "ERROR: a row dump without a plan (put the plan's bytes in the mailbox at {:#010x}: run-qemu.sh --plan)",
                    layout::PLAN_DESC_ADDR
                );
                stop(EXIT_BAD_INPUT)
            }
            (Some(_), Some(_)) => {
                hprintln!(
                    "ERROR: a plan in the mailbox, but the input is no row dump (magic FSMROWS)"
                );
                stop(EXIT_BAD_INPUT)
            }
            (None, _) => {
                hprintln!("INPUT none: nothing to decode");
                stop(0)
            }
        }
    }
}

#[cfg(not(target_os = "none"))]
mod cli;

#[cfg(not(target_os = "none"))]
fn main() {
    std::process::exit(cli::main(std::env::args().skip(1).collect()));
}
