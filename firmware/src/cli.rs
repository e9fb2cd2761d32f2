//! The host build of the firmware binary: the camera emulator and the cross-check tools.

use std::fs;
use std::path::{Path, PathBuf};

use fsm_core::{
    CodeEnsemblePlan, GroupCount, LineScanPlan, MethodPlan, MicroPhaseShiftPlan, PhaseShiftPlan,
    ScanPlan,
};
use fsm_firmware::batch::{self, BatchMemory};
use fsm_firmware::emulator;
use fsm_firmware::limits;
use fsm_firmware::memory::HostStorage;
use fsm_firmware::reference;
use fsm_firmware::scan::{NoProbe, RowBuffers};
use fsm_firmware::scene::MirrorScene;
use fsm_firmware::session;

fn usage() -> &'static str {
    "usage: fsm-firmware <command> [options]

commands (PLAN is bfsm, efsm1, efsm2, one of them with -fast (the paper's local-maximum
search instead of CLEAN, e.g. efsm1-fast); ps, mps, ce or ls, a baseline on a projector of
128 columns (phase shift + Gray code, Micro Phase Shifting with 7 periods, Code Ensemble, line
scanning); or a plan file of any method's canonical bytes, written by `scene --plan-out` or
`fsm plan --wire`):
  scene --plan PLAN --width W --rows H --dump OUT [--plan-out FILE]
        render the mirror scene (interreflections) as a row dump
  decode --plan PLAN --dump DUMP --out CANDIDATES
        the host's decode of a dump with fsm-core (what `fsm decode` writes)
  batch --plan PLAN --dump DUMP --out CANDIDATES
        the firmware's replay loop, run on the host
  session --plan PLAN --dump DUMP --out REQUESTS [--bad-input yes]
        record the request frames of a session that scans DUMP (optionally with one of each
        kind of bad input first), for replay by the firmware under QEMU
  replies --plan PLAN --dump DUMP --in RESPONSES --out CANDIDATES [--bad-input yes]
        check the camera's recorded answers to that session; write the candidates they carry
  truth --plan PLAN --width W --rows H --candidates FILE [--tolerance C]
        check a candidate file of the mirror scene `scene` renders against its truth: every
        row present, the direct (and mirrored) light of the lit pixels within C columns
        (default 0.5; 99% of direct, 95% of mirrored lights), at most 10% of the lit pixels
        flagged as mixtures, no candidate in shadow (exit 1 otherwise); a baseline, which
        sees one light per pixel, is held to 95% of the pixels the mirror does not light
        and 95% of the shadow
  compare EXPECTED ACTUAL [--min-rows N] [--min-lit N]
        byte-compare two candidate files; on a difference, name its row and pixel (exit 1);
        identical files must also hold N rows and N pixels with a candidate (default 1 each)
  serve [--listen ADDR] [--frame-timeout S] [--idle-timeout S] [--hand-over S]
        the camera emulator on TCP (default 127.0.0.1:7070); a connection is given up after
        S seconds of silence inside a frame (default 5) or between frames (default 120, 0:
        never), and handed to a waiting host after S seconds between frames (default 1)
  info  the camera's limits and memory"
}

/// Runs a command; returns the process exit code.
pub fn main(args: Vec<String>) -> i32 {
    match run(&args) {
        Ok(()) => 0,
        Err(Failure::Usage(msg)) => {
            eprintln!("fsm-firmware: {msg}\n\n{}", usage());
            2
        }
        Err(Failure::Error(msg)) => {
            eprintln!("fsm-firmware: {msg}");
            1
        }
    }
}

enum Failure {
    Usage(String),
    Error(String),
}

fn err(msg: impl Into<String>) -> Failure {
    Failure::Error(msg.into())
}

/// `--name value` options after the command.
struct Options<'a> {
    pairs: Vec<(&'a str, &'a str)>,
    free: Vec<&'a str>,
}

impl<'a> Options<'a> {
    fn parse(args: &'a [String]) -> Result<Self, Failure> {
        let (mut pairs, mut free) = (Vec::new(), Vec::new());
        let mut it = args.iter();
        while let Some(a) = it.next() {
            if let Some(name) = a.strip_prefix("--") {
                let v = it
                    .next()
                    .ok_or_else(|| Failure::Usage(format!("--{name} needs a value")))?;
                pairs.push((name, v.as_str()));
            } else {
                free.push(a.as_str());
            }
        }
        Ok(Options { pairs, free })
    }

    fn get(&self, name: &str) -> Option<&'a str> {
        self.pairs.iter().find(|(n, _)| *n == name).map(|(_, v)| *v)
    }

    fn need(&self, name: &str) -> Result<&'a str, Failure> {
        self.get(name)
            .ok_or_else(|| Failure::Usage(format!("--{name} is required")))
    }

    fn number(&self, name: &str) -> Result<u32, Failure> {
        let v = self.need(name)?;
        v.parse()
            .map_err(|_| Failure::Usage(format!("--{name} {v}: not a number")))
    }

    /// A duration in (decimal) seconds.
    fn seconds(&self, name: &str) -> Result<Option<std::time::Duration>, Failure> {
        let Some(v) = self.get(name) else {
            return Ok(None);
        };
        v.parse::<f64>()
            .ok()
            .and_then(|s| std::time::Duration::try_from_secs_f64(s).ok())
            .map(Some)
            .ok_or_else(|| Failure::Usage(format!("--{name} {v}: not a number of seconds")))
    }

    fn only(&self, names: &[&str], free: usize) -> Result<(), Failure> {
        if let Some((n, _)) = self.pairs.iter().find(|(n, _)| !names.contains(n)) {
            return Err(Failure::Usage(format!("unknown option --{n}")));
        }
        if self.free.len() != free {
            return Err(Failure::Usage(format!(
                "{} arguments given, {free} expected",
                self.free.len()
            )));
        }
        Ok(())
    }
}

/// Projector columns of the baseline presets: small, so that QEMU runs them in seconds.
const BASELINE_COLUMNS: u16 = 128;

/// A preset name or a plan file. An FSM preset name with `-fast` decodes with the paper's
/// local-maximum search (`ScanPlan::with_local_maxima`) instead of CLEAN.
fn plan(spec: &str) -> Result<MethodPlan, Failure> {
    let (preset, fast) = match spec.strip_suffix("-fast") {
        Some(preset) => (preset, true),
        None => (spec, false),
    };
    let mut plan = match preset {
        "bfsm" => ScanPlan::paper_bfsm(),
        "efsm1" => ScanPlan::paper_efsm(GroupCount::One),
        "efsm2" => ScanPlan::paper_efsm(GroupCount::Two),
        _ if fast => return plan_file(spec),
        "ps" => return Ok(PhaseShiftPlan::for_projector(BASELINE_COLUMNS).into()),
        "mps" => return Ok(MicroPhaseShiftPlan::spread(BASELINE_COLUMNS, 16.0, 4.0, 7).into()),
        "ce" => return Ok(CodeEnsemblePlan::for_projector(BASELINE_COLUMNS).into()),
        "ls" => {
            let plan = LineScanPlan {
                projector_columns: BASELINE_COLUMNS,
                ..LineScanPlan::paper()
            };
            return Ok(plan.into());
        }
        _ => return plan_file(spec),
    };
    if fast {
        plan = plan.with_local_maxima();
    }
    Ok(plan.into())
}

/// A plan file: any method's canonical bytes (`MethodPlan::to_bytes`).
fn plan_file(path: &str) -> Result<MethodPlan, Failure> {
    let bytes = fs::read(path).map_err(|e| err(format!("plan {path}: {e}")))?;
    MethodPlan::from_bytes(&bytes).map_err(|e| err(format!("plan {path}: {e}")))
}

fn read(path: &str) -> Result<Vec<u8>, Failure> {
    fs::read(path).map_err(|e| err(format!("{path}: {e}")))
}

/// Writes `bytes` to `path` whole or not at all (a `.part` file renamed when complete).
fn write(path: &str, bytes: &[u8]) -> Result<(), Failure> {
    let target = Path::new(path);
    let mut name = target.file_name().unwrap_or_default().to_os_string();
    name.push(".part");
    let tmp: PathBuf = target.with_file_name(name);
    fs::write(&tmp, bytes)
        .and_then(|_| fs::rename(&tmp, target))
        .map_err(|e| {
            let _ = fs::remove_file(&tmp);
            err(format!("{path}: {e}"))
        })
}

fn run(args: &[String]) -> Result<(), Failure> {
    let Some((command, rest)) = args.split_first() else {
        return Err(Failure::Usage("no command".into()));
    };
    if matches!(command.as_str(), "help" | "--help" | "-h") {
        println!("{}", usage());
        return Ok(());
    }
    let o = Options::parse(rest)?;
    match command.as_str() {
        "scene" => {
            o.only(&["plan", "width", "rows", "dump", "plan-out"], 0)?;
            let plan = plan(o.need("plan")?)?;
            let (width, rows) = (o.number("width")?, o.number("rows")?);
            if width == 0 || rows == 0 {
                return Err(Failure::Usage("--width and --rows must be positive".into()));
            }
            let scene = MirrorScene::for_plan(plan, width, rows);
            write(o.need("dump")?, &scene.dump(plan))?;
            if let Some(p) = o.get("plan-out") {
                write(p, &plan.to_bytes())?;
            }
            println!(
                "scene: {width} x {rows} pixels, {} plan, {} frames per row, plan {:016x}",
                plan.name(),
                plan.frame_count(),
                plan.fingerprint()
            );
            Ok(())
        }
        "decode" | "batch" => {
            o.only(&["plan", "dump", "out"], 0)?;
            let plan = plan(o.need("plan")?)?;
            let dump_path = o.need("dump")?;
            let dump = read(dump_path)?;
            let out = if command == "decode" {
                reference::decode_dump(plan, &dump).map_err(|e| err(format!("{dump_path}: {e}")))?
            } else {
                let mut storage = HostStorage::default();
                let m = storage.memory();
                let memory = BatchMemory {
                    tables: m.tables,
                    row: RowBuffers {
                        scratch: m.scratch,
                        samples: m.samples,
                        pixels: m.pixels,
                    },
                    record: m.record,
                };
                let mut out = Vec::new();
                batch::scan_dump(plan, &dump, memory, &mut out, &mut NoProbe)
                    .map_err(|e| err(format!("{dump_path}: {e}")))?;
                out
            };
            let census = reference::census(&out).map_err(|e| err(e.to_string()))?;
            write(o.need("out")?, &out)?;
            println!("{command}: {census}");
            Ok(())
        }
        "session" | "replies" => {
            let names: &[&str] = if command == "session" {
                &["plan", "dump", "out", "bad-input"]
            } else {
                &["plan", "dump", "in", "out", "bad-input"]
            };
            o.only(names, 0)?;
            let plan = plan(o.need("plan")?)?;
            let dump_path = o.need("dump")?;
            let dump = read(dump_path)?;
            let bad = match o.get("bad-input") {
                None | Some("no") => false,
                Some("yes") => true,
                Some(v) => return Err(Failure::Usage(format!("--bad-input {v}: yes or no"))),
            };
            let script =
                session::script(plan, &dump, bad).map_err(|e| err(format!("{dump_path}: {e}")))?;
            if command == "session" {
                write(o.need("out")?, &script.requests)?;
                println!(
                    "session: {} requests, {} bytes",
                    script.expect.len(),
                    script.requests.len()
                );
            } else {
                let path = o.need("in")?;
                let candidates = session::check_replies(&script, &read(path)?)
                    .map_err(|e| err(format!("{path}: {e}")))?;
                write(o.need("out")?, &candidates)?;
                println!(
                    "replies: all {} answers as expected; {}",
                    script.expect.len(),
                    reference::census(&candidates).map_err(|e| err(e.to_string()))?
                );
            }
            Ok(())
        }
        "truth" => {
            o.only(&["plan", "width", "rows", "candidates", "tolerance"], 0)?;
            let plan = plan(o.need("plan")?)?;
            let (width, rows) = (o.number("width")?, o.number("rows")?);
            let tolerance = match o.get("tolerance") {
                None => 0.5,
                Some(t) => t
                    .parse::<f64>()
                    .ok()
                    .filter(|t| *t > 0.0)
                    .ok_or_else(|| Failure::Usage(format!("--tolerance {t}: columns, > 0")))?,
            };
            let path = o.need("candidates")?;
            let bytes = read(path)?;
            let header = fsm_core::wire::candidates::CandidateHeader::decode(&bytes)
                .map_err(|e| err(format!("{path}: {e}")))?;
            if header.plan_fingerprint != plan.fingerprint() {
                return Err(err(format!(
                    "{path}: decoded with plan {:016x}, not the plan given ({:016x})",
                    header.plan_fingerprint,
                    plan.fingerprint()
                )));
            }
            let scene = MirrorScene::for_plan(plan, width, rows);
            let check = scene
                .check(&bytes, tolerance)
                .map_err(|e| err(format!("{path}: {e}")))?;
            let (passes, wanted) = match plan {
                MethodPlan::Fsm(_) => (
                    check.passes(rows),
                    "99% of direct and 95% of mirrored lights found, at most 10% flagged",
                ),
                _ => (
                    check.passes_single_light(rows),
                    "the light of 95% of the pixels lit once found (a baseline)",
                ),
            };
            let shadow = match plan {
                MethodPlan::Fsm(_) => "shadow dark",
                _ => "95% of the shadow dark",
            };
            if passes {
                println!("truth: {path}: {check} (within {tolerance} column)");
                Ok(())
            } else {
                Err(err(format!(
                    "{path}: not the scene's truth: {check} (within {tolerance} column; expected {rows} rows, {wanted}, {shadow})"
                )))
            }
        }
        "compare" => {
            o.only(&["min-rows", "min-lit"], 2)?;
            let (a, b) = (read(o.free[0])?, read(o.free[1])?);
            match reference::compare(&a, &b) {
                Ok(()) => {
                    let census = reference::census(&a).map_err(|e| err(e.to_string()))?;
                    // Two empty files are identical too: say how much must be there.
                    let lit = census.width as usize * census.rows - census.by_count[0];
                    let min = |name| o.get(name).map_or(Ok(1), |_| o.number(name));
                    let (min_rows, min_lit) = (min("min-rows")?, min("min-lit")?);
                    if census.rows < min_rows as usize || lit < min_lit as usize {
                        return Err(err(format!(
                            "{} and {} are identical but hold too little: {census}; at least {min_rows} rows and {min_lit} pixels with a candidate wanted",
                            o.free[0], o.free[1]
                        )));
                    }
                    println!(
                        "identical: {} and {} ({} bytes; {census})",
                        o.free[0],
                        o.free[1],
                        a.len()
                    );
                    Ok(())
                }
                Err(d) => Err(err(format!("{} vs {}: {d}", o.free[0], o.free[1]))),
            }
        }
        "serve" => {
            o.only(&["listen", "frame-timeout", "idle-timeout", "hand-over"], 0)?;
            let default_addr = format!("127.0.0.1:{}", fsm_protocol::DEFAULT_TCP_PORT);
            let addr = o.get("listen").unwrap_or(&default_addr);
            let mut timeouts = emulator::Timeouts::default();
            if let Some(s) = o.seconds("frame-timeout")? {
                timeouts.frame = s;
            }
            if let Some(s) = o.seconds("idle-timeout")? {
                timeouts.idle = (!s.is_zero()).then_some(s);
            }
            if let Some(s) = o.seconds("hand-over")? {
                timeouts.hand_over = s;
            }
            let listener =
                std::net::TcpListener::bind(addr).map_err(|e| err(format!("{addr}: {e}")))?;
            println!(
                "camera emulator on tcp://{} (rows up to {} pixels / {} samples)",
                listener.local_addr().map_err(|e| err(e.to_string()))?,
                limits::MAX_WIDTH,
                limits::MAX_ROW_SAMPLES
            );
            let stop = std::sync::atomic::AtomicBool::new(false);
            emulator::serve_tcp(&listener, timeouts, &stop, |peer, result| {
                let peer = peer.map_or("(peer gone)".to_string(), |p| p.to_string());
                match result {
                    Ok(r) => println!(
                        "{peer}: {} requests, {} rows, {} errors",
                        r.requests, r.rows, r.errors
                    ),
                    Err(e) => println!("{peer}: link given up: {e}"),
                }
            })
            .map_err(|e| err(format!("{addr}: {e}")))
        }
        "info" => {
            o.only(&[], 0)?;
            println!(
                "rows up to {} pixels and {} samples; {} candidates per pixel; decoder tables up to {} floats; buffers {} bytes",
                limits::MAX_WIDTH,
                limits::MAX_ROW_SAMPLES,
                limits::CANDIDATE_CAPACITY,
                limits::MAX_TABLE_FLOATS,
                fsm_firmware::memory::MEMORY_BYTES
            );
            Ok(())
        }
        other => Err(Failure::Usage(format!("unknown command {other}"))),
    }
}
