//! The firmware image (bare metal) / the same demo as a host program.
//!
//! Bare metal: `_start` (src/arm/start.rs) calls `fw_main`, which runs the bring-up demo,
//! prints a `RESULT ...` line over semihosting, writes and reads back the host file
//! `fw-out.bin` (in QEMU's working directory), checksums the input placed in RAM by
//! scripts/run-qemu.sh, and exits 0 (or panics: QEMU exit code 101).
//! Host: prints the same `RESULT ...` line, so the two can be compared.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod fw {
    use core::hint::black_box;

    use fsm_firmware::arm::cpu::{cycles, global_timer_ticks};
    use fsm_firmware::arm::semihosting::{exit, File, Mode};
    use fsm_firmware::demo::{self, OutputRecord, N, OUTPUT_LEN};
    use fsm_firmware::layout::SelfTest;
    use fsm_firmware::{hprintln, icount, layout};

    /// Host file the demo writes (relative to QEMU's working directory).
    const OUT_PATH: &str = "fw-out.bin";

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
            SelfTest::Exit(code) => exit(code),
        }
    }

    #[no_mangle]
    pub extern "C" fn fw_main() -> ! {
        hprintln!(
            "fsm-firmware {} (armv7a-none-eabihf, Cortex-A9)",
            env!("CARGO_PKG_VERSION")
        );
        if let Some(t) = layout::selftest() {
            selftest(t);
        }
        let shift = icount::shift();

        let mut buf = [0.0f32; N];
        demo::synth(&mut buf);
        black_box(&mut buf);

        // Cost of the measurement itself (back-to-back reads), subtracted below.
        let (o0, p0) = (global_timer_ticks(), cycles());
        let (o1, p1) = (global_timer_ticks(), cycles());

        let (t0, c0) = (global_timer_ticks(), cycles());
        let spec = demo::rfft(&mut buf);
        let (t1, c1) = (global_timer_ticks(), cycles());
        let spec = black_box(spec);

        let fft_instructions = match shift {
            Some(s) => {
                let ins = |t| icount::instructions_from_gtimer_ticks(t, s);
                let n = (ins(t1) - ins(t0)) - (ins(o1) - ins(o0));
                hprintln!(
                    "ICOUNT shift={} rfft_1024 instructions={} ({}; measurement overhead {} subtracted)",
                    s,
                    n,
                    if s >= icount::EXACT_SHIFT { "exact" } else { "approximate: use shift>=4" },
                    ins(o1) - ins(o0)
                );
                n as u32
            }
            None => {
                hprintln!(
                    "TIMER rfft_1024 gtimer_ticks={} (QEMU without --icount: follows host time, not reproducible)",
                    (t1 - t0) - (o1 - o0)
                );
                0
            }
        };
        let pmu = c1.wrapping_sub(c0).wrapping_sub(p1.wrapping_sub(p0));
        if pmu != 0 {
            // Real silicon only: QEMU's cortex-a9 has no PMU.
            hprintln!("CYCLES rfft_1024={}", pmu);
        }

        let report = demo::analyse(spec);
        let libm = demo::libm_report();
        hprintln!("{}", demo::result_line(&report, &libm));
        #[cfg(feature = "defmt")]
        {
            let p = report.peaks[0];
            defmt::info!(
                "rfft_1024: peak bin {=u16} mag {=f32} phase {=f32}",
                p.bin,
                p.mag,
                p.phase
            );
            defmt::info!(
                "rfft_1024: {=u32} instructions (0 = not under --icount)",
                fft_instructions
            );
        }
        if let Err(e) = demo::check(&report) {
            panic!("FFT check failed: {}", e);
        }

        let (input_len, input_crc) = match layout::input() {
            Some(data) => {
                let crc = demo::crc32(data);
                let head = &data[..data.len().min(8)];
                hprintln!(
                    "INPUT len={} crc32={:08x} head={:02x?}",
                    data.len(),
                    crc,
                    head
                );
                #[cfg(feature = "defmt")]
                defmt::info!("input: {=usize} bytes, crc32 {=u32:#010x}", data.len(), crc);
                (data.len() as u32, crc)
            }
            None => {
                hprintln!(
                    "INPUT none (no descriptor at {:#010x})",
                    layout::INPUT_DESC_ADDR
                );
                (0, 0)
            }
        };

        let record = OutputRecord {
            peak_bin: report.peaks[0].bin as u32,
            peak_mag: report.peaks[0].mag,
            peak_phase: report.peaks[0].phase,
            input_len,
            input_crc,
            fft_instructions,
        };
        let bytes = record.encode();
        match File::open(OUT_PATH, Mode::Write) {
            Ok(mut f) => f.write_all(&bytes).expect("write fw-out.bin"),
            Err(e) => panic!("open {} for writing: errno {}", OUT_PATH, e.errno),
        }
        // Read it back through semihosting too.
        let mut back = [0u8; OUTPUT_LEN];
        {
            let mut f = File::open(OUT_PATH, Mode::Read).expect("open fw-out.bin for reading");
            assert_eq!(f.len(), Ok(OUTPUT_LEN), "fw-out.bin length");
            f.read_exact(&mut back).expect("read fw-out.bin");
        }
        assert_eq!(back, bytes, "fw-out.bin read back differs");
        hprintln!(
            "FILE {} {} bytes written and read back",
            OUT_PATH,
            OUTPUT_LEN
        );

        if let Some(s) = shift {
            // The global timer was started in fsm_fw_init, just before fw_main.
            let total = icount::instructions_from_gtimer_ticks(global_timer_ticks(), s);
            hprintln!("ICOUNT total instructions since start-up={}", total);
        }
        #[cfg(feature = "defmt")]
        defmt::info!("done");
        exit(0)
    }
}

#[cfg(not(target_os = "none"))]
fn main() {
    use fsm_firmware::demo;

    let mut buf = [0.0f32; demo::N];
    demo::synth(&mut buf);
    let report = demo::analyse(demo::rfft(&mut buf));
    println!("{}", demo::result_line(&report, &demo::libm_report()));
    if let Err(e) = demo::check(&report) {
        eprintln!("FFT check failed: {e}");
        std::process::exit(1);
    }
}
