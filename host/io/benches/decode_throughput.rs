//! Decode throughput of the host pipeline and its peak memory.
//!
//! `cargo bench -p fsm-io --bench decode_throughput`
//!
//! BFSM with the paper's plan (`ScanPlan::paper_bfsm()`: 770 frames, M = 768 fringes,
//! N = 1024), a synthetic 12-bit scene (every pixel lit directly, a quarter of them also by a
//! second column, as by a reflection), decoded with 2 threads:
//!
//! - from a row dump held in memory,
//! - from a stack of 16-bit PNGs on disk (whole stack in one band, and in 8 bands),
//!
//! and, for scale, the same rows with 1 thread, and each source read without decoding (what
//! the host pipeline itself costs). Each case runs in its own process (this binary re-runs
//! itself with `--case NAME`), so that its peak resident memory (`VmHWM`) is its own.
//!
//! Size: `FSM_BENCH_WIDTH` × `FSM_BENCH_ROWS` camera pixels (default 1024 × 256). Each dump
//! case is the median of 5 passes; the EFSM cases (the paper's two-group plan, cB 64) decode a
//! dump of the same scene.
//! Paper anchor (§VII-E): 1.25 Mpx/s for DFT + peaks on an RTX 2080 Super.

use std::io::Cursor;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use fsm_core::wire::row_dump::RowDumpHeader;
use fsm_core::wire::HEADER_LEN;
use fsm_core::{GroupCount, ScanPlan};
use fsm_io::capture::{BadRows, Capture, RowBatch, RowBatches};
use fsm_io::decode::{self, DecodeOptions, DecodeSummary};
use fsm_io::dump::{DumpReader, DumpWriter};
use fsm_io::image_files;
use fsm_io::progress::Progress;
use rayon::prelude::*;

const BITS: u8 = 12;

fn size() -> (u32, u32) {
    let var = |name: &str, default: u32| {
        std::env::var(name)
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(default)
    };
    (var("FSM_BENCH_WIDTH", 1024), var("FSM_BENCH_ROWS", 256))
}

/// Sample of frame `i` at pixel `(x, y)` of the synthetic scene: pixel `x` sees column
/// `x·cmax/W + y` (mod `cmax`), every fourth pixel also column `+311` at 30% (a reflection);
/// 12-bit, dark 60 DN, uniform noise of ±3.5 DN.
fn sample(
    plan: &ScanPlan,
    pattern: fsm_core::Pattern,
    x: u32,
    y: u32,
    width: u32,
    i: usize,
) -> u16 {
    let cmax = plan.projector_columns as u32;
    let direct = (x * cmax / width + y) % cmax;
    let mut light = 2400.0 * plan.intensity(pattern, direct);
    if (x + y).is_multiple_of(4) {
        light += 700.0 * plan.intensity(pattern, (direct + 311) % cmax);
    }
    let hash = (x.wrapping_mul(73_856_093)
        ^ y.wrapping_mul(19_349_663)
        ^ (i as u32).wrapping_mul(83_492_791))
    .wrapping_mul(2_654_435_761);
    let noise = (hash >> 29) as f32 - 3.5;
    (60.0 + light + noise).round().clamp(0.0, 4095.0) as u16
}

/// Frame `i` of the scene, row-major `W × H`.
fn frame(plan: &ScanPlan, i: usize, width: u32, height: u32) -> Vec<u16> {
    let pattern = plan.pattern(i).expect("frame index");
    (0..height)
        .flat_map(|y| (0..width).map(move |x| (x, y)))
        .map(|(x, y)| sample(plan, pattern, x, y, width, i))
        .collect()
}

fn write_stack(plan: &ScanPlan, dir: &Path, width: u32, height: u32) {
    std::fs::create_dir_all(dir).unwrap();
    (0..plan.sequence_len()).into_par_iter().for_each(|i| {
        let data = frame(plan, i, width, height);
        let file = std::fs::File::create(dir.join(format!("{i:04}.png"))).unwrap();
        image_files::write_png_gray16(std::io::BufWriter::new(file), width, height, &data).unwrap();
    });
}

/// The scene as a dump in memory, generated row by row (only the dump is held).
fn dump_in_memory(plan: &ScanPlan, width: u32, height: u32) -> Vec<u8> {
    let header = RowDumpHeader::for_plan(plan, width, height, BITS);
    let capacity = HEADER_LEN + height as usize * header.record_len().unwrap();
    let mut writer = DumpWriter::new(Vec::with_capacity(capacity), header).unwrap();
    let patterns: Vec<_> = plan.sequence().collect();
    let w = width as usize;
    let mut row = vec![0u16; patterns.len() * w];
    for y in 0..height {
        row.par_chunks_mut(w).enumerate().for_each(|(i, frame)| {
            for (x, s) in frame.iter_mut().enumerate() {
                *s = sample(plan, patterns[i], x as u32, y, width, i);
            }
        });
        writer.write_row(y, &row).unwrap();
    }
    writer.finish().unwrap()
}

/// Peak resident memory of this process, bytes.
fn peak_memory() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find(|l| l.starts_with("VmHWM:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|kb| kb.parse::<u64>().ok())
        .map_or(0, |kb| kb * 1024)
}

/// Decodes everything `batches` holds, keeping what `fsm decode` keeps (candidate records,
/// column map) but writing no file.
fn decode_all(plan: &ScanPlan, batches: &mut RowBatches<'_>, threads: usize) -> DecodeSummary {
    let options = DecodeOptions {
        memory_budget_bytes: u64::MAX,
        threads,
    };
    let mut map = fsm_io::column_map::ColumnMap::new(batches.width(), batches.height());
    let mut bytes = 0usize;
    let keep = decode::candidate_record(decode::candidate_header(
        plan,
        batches.width(),
        batches.height(),
    ));
    let summary =
        decode::decode_batches(plan, batches, &options, &Progress::hidden(), keep, |row| {
            bytes += row.kept.len();
            map.set_row_columns(row.row, &row.strongest);
            Ok(())
        })
        .unwrap();
    assert!(bytes > 0);
    summary
}

/// Reads every batch without decoding: the host pipeline's own cost.
fn read_all(batches: &mut RowBatches<'_>) -> (f64, u64) {
    let start = Instant::now();
    let mut batch = RowBatch::default();
    let mut rows = 0u64;
    while batches.next_batch(&mut batch).unwrap() {
        rows += batch.rows.len() as u64;
    }
    (start.elapsed().as_secs_f64(), rows)
}

/// Runs one case in this process and prints one result line.
/// Passes over the same input per case; the median is reported (the machine's other tenants
/// make single passes scatter by tens of percent).
const PASSES: usize = 5;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn run_case(case: &str, stack_dir: &Path) {
    let (plan, method, case) = match case.strip_prefix("efsm2-") {
        Some(case) => (ScanPlan::paper_efsm(GroupCount::Two), "EFSM x2", case),
        None => (ScanPlan::paper_bfsm(), "BFSM", case),
    };
    let (width, height) = size();
    let pixels = width as f64 * height as f64;
    let samples_bytes = plan.sequence_len() as u64 * pixels as u64 * 2;
    let dump_rows = decode::dump_batch_rows(2);
    let (label, seconds, held_bytes) = match case {
        "dump-memory" | "dump-memory-1-thread" | "dump-memory-read-only" => {
            let bytes = dump_in_memory(&plan, width, height);
            let held = bytes.len() as u64;
            let open = || {
                let reader = DumpReader::new(Cursor::new(&bytes[..]), Path::new("memory")).unwrap();
                reader.check(plan, Some(BITS)).unwrap();
                RowBatches::from_dump(reader.boxed(), dump_rows, BadRows::Refuse)
            };
            let pass = || match case {
                "dump-memory-read-only" => read_all(&mut open()).0,
                "dump-memory-1-thread" => decode_all(&plan, &mut open(), 1).seconds,
                _ => decode_all(&plan, &mut open(), 2).seconds,
            };
            let seconds = median((0..PASSES).map(|_| pass()).collect());
            let label = match case {
                "dump-memory-read-only" => "dump in memory, read only (no decode)",
                "dump-memory-1-thread" => "dump in memory, 1 thread",
                _ => "dump in memory, 2 threads",
            };
            (label, seconds, held)
        }
        "stack-png" | "stack-png-8-bands" | "stack-png-read-only" => {
            let capture = Capture::open_stack(stack_dir, plan, Some(BITS)).unwrap();
            let budget = match case {
                "stack-png-8-bands" => capture.samples_bytes().div_ceil(8),
                _ => capture.samples_bytes(),
            };
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(2)
                .build()
                .unwrap();
            let mut batches = capture.batches(budget, dump_rows).unwrap();
            let seconds = match case {
                "stack-png-read-only" => pool.install(|| read_all(&mut batches)).0,
                _ => decode_all(&plan, &mut batches, 2).seconds,
            };
            let label = match case {
                "stack-png-read-only" => "PNG stack, one band, read only (no decode, 2 threads)",
                "stack-png-8-bands" => "PNG stack, 8 bands, 2 threads",
                _ => "PNG stack, one band, 2 threads",
            };
            (label, seconds, 0)
        }
        other => panic!("unknown case {other}"),
    };
    let peak = peak_memory();
    println!(
        "RESULT|{method}, {label}|{:.4}|{seconds:.3}|{}|{}|{}",
        pixels / seconds / 1e6,
        peak,
        samples_bytes,
        held_bytes
    );
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if let Some(i) = args.iter().position(|a| a == "--case") {
        run_case(&args[i + 1], Path::new(&args[i + 2]));
        return;
    }
    let plan = ScanPlan::paper_bfsm();
    let (width, height) = size();
    let work = tempfile::tempdir().unwrap();
    let stack_dir: PathBuf = work.path().join("stack");
    let start = Instant::now();
    rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap()
        .install(|| {
            write_stack(&plan, &stack_dir, width, height);
        });
    let samples_mib =
        plan.sequence_len() as f64 * width as f64 * height as f64 * 2.0 / (1 << 20) as f64;
    println!(
        "BFSM paper plan (770 frames, M = 768, N = 1024), {width} x {height} pixels, 12-bit; \
         stack of {samples_mib:.0} MiB as u16 samples (PNG stack written in {:.1} s)",
        start.elapsed().as_secs_f64()
    );
    println!(
        "{:<56} {:>8} {:>8} {:>12} {:>14}",
        "case", "Mpx/s", "s", "peak MiB", "peak / stack"
    );
    let exe = std::env::current_exe().unwrap();
    let mut rates = std::collections::HashMap::new();
    for case in [
        "dump-memory",
        "dump-memory-1-thread",
        "dump-memory-read-only",
        "efsm2-dump-memory",
        "efsm2-dump-memory-1-thread",
        "efsm2-dump-memory-read-only",
        "stack-png",
        "stack-png-8-bands",
        "stack-png-read-only",
    ] {
        let out = Command::new(&exe)
            .args(["--case", case, stack_dir.to_str().unwrap()])
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{case}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let stdout = String::from_utf8(out.stdout).unwrap();
        let line = stdout
            .lines()
            .find(|l| l.starts_with("RESULT|"))
            .expect("a result line");
        let f: Vec<&str> = line.split('|').collect();
        rates.insert(case, f[2].parse::<f64>().unwrap());
        let peak: f64 = f[4].parse().unwrap();
        let stack: f64 = f[5].parse().unwrap();
        let held: f64 = f[6].parse().unwrap();
        let mib = |b: f64| b / (1 << 20) as f64;
        let note = if held > 0.0 {
            format!("(holds the {:.0} MiB dump)", mib(held))
        } else {
            format!("{:.2}", peak / stack)
        };
        println!(
            "{:<56} {:>8} {:>8} {:>12.0} {:>14}",
            f[1],
            f[2],
            f[3],
            mib(peak),
            note
        );
    }
    for (name, two, one) in [
        ("BFSM", "dump-memory", "dump-memory-1-thread"),
        ("EFSM x2", "efsm2-dump-memory", "efsm2-dump-memory-1-thread"),
    ] {
        println!(
            "{name}: 2 threads decode {:.2}x as fast as 1 (dump in memory)",
            rates[two] / rates[one]
        );
    }
    println!(
        "decoder lanes on this CPU: {:?}; paper anchor: 1.25 Mpx/s (DFT + peaks, RTX 2080 Super, §VII-E)",
        fsm_core::transform::isa::Isa::detect()
    );
}
