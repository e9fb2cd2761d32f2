//! `fsm plan`: write a plan file for any method (from a preset or from the projector's
//! width, with overrides), or check one.

use std::path::{Path, PathBuf};

use clap::ValueEnum;
use fsm_core::{
    CodeEnsemblePlan, GroupCount, LineScanPlan, Method, MicroPhaseShiftPlan, PhaseShiftPlan,
    ScanPlan,
};
use fsm_io::plan_file::{self, MethodPlan, PlanSyntax, Preset};
use fsm_io::stack::sequence_summary;
use fsm_io::{Error, Result};

/// Write or check a plan file (TOML or JSON, chosen by the file extension).
///
/// Examples:
///   fsm plan --preset paper-bfsm --out plan.toml
///   fsm plan --preset paper-efsm-2 --set decoding.noise_factor=5 --out plan.json
///   fsm plan --method efsm --projector-columns 1024 --block-width 64 --groups 2 --out plan.toml
///   fsm plan --method line-scan --projector-columns 1024 --out ls.toml
///   fsm plan --check plan.toml
///   fsm plan --check plan.toml --wire plan.bin
///
/// --method derives every dependent field from the projector's width: BFSM's band (one fringe
/// per column), EFSM's band and DFT size from the block width, phase shift's Gray-code bits,
/// Micro Phase Shifting's periods (15 over 14-18 columns), line scanning's frames, Code
/// Ensemble's codeword width (10-bit codes; wider projectors share codewords). Overrides
/// use the file's dotted field names (see the README, "Plan files"); e.g.
/// `--set band.count=512`, `--set method.Efsm.block_width=32`, `--set references.white=false`,
/// `--set line_scan.noise_factor=8`.
#[derive(clap::Args, Debug)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Start from a preset: the paper's systems (§VII): 768 projector columns; BFSM with 768
    /// fringes, or EFSM with 64-column blocks and one or two groups (76 / 152 patterns).
    #[arg(long, value_enum, conflicts_with_all = ["check", "method"])]
    preset: Option<PresetName>,
    /// Make a plan of this method for a projector of --projector-columns columns: BFSM, EFSM,
    /// or one of the methods the paper compares them with (phase shift + Gray code, Micro Phase
    /// Shifting, Code Ensemble, line scanning; see docs/comparison.md).
    #[arg(
        long,
        value_enum,
        conflicts_with = "check",
        requires = "projector_columns"
    )]
    method: Option<MethodName>,
    /// The projector's columns, for --method.
    #[arg(long, value_name = "COLUMNS", requires = "method")]
    projector_columns: Option<u16>,
    /// EFSM: block width cB in columns (default 64).
    #[arg(long, value_name = "COLUMNS", default_value_t = 64)]
    block_width: u16,
    /// EFSM: pattern groups, 1 or 2 (default 2).
    #[arg(long, value_name = "N", default_value_t = 2, value_parser = clap::value_parser!(u8).range(1..=2))]
    groups: u8,
    /// Override a field: KEY=VALUE (repeatable); the result is validated.
    #[arg(long = "set", value_name = "KEY=VALUE", conflicts_with = "check")]
    settings: Vec<String>,
    /// Write the plan here (.toml or .json); without it the plan is printed.
    #[arg(long, value_name = "FILE", conflicts_with = "check")]
    out: Option<PathBuf>,
    /// Replace the --out or --wire file if it exists.
    #[arg(long)]
    force: bool,
    /// Check a plan file: print what it describes, or the first field that is wrong.
    #[arg(long, value_name = "FILE")]
    check: Option<PathBuf>,
    /// Also write the plan's 80-byte wire form (fsm_core::wire::plan: the bytes `fsm upload`
    /// sends and the firmware's plan mailbox takes), with --preset or --check.
    #[arg(long, value_name = "FILE")]
    wire: Option<PathBuf>,
    /// Syntax when printing (default TOML).
    #[arg(long, value_enum, default_value_t = Syntax::Toml)]
    format: Syntax,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum PresetName {
    /// ScanPlan::paper_bfsm(): BFSM, 768 columns, 768 fringes f = m/1536, N = 1024.
    PaperBfsm,
    /// ScanPlan::paper_efsm(One): EFSM, block width 64, one group (76 patterns).
    #[value(name = "paper-efsm-1")]
    PaperEfsm1,
    /// ScanPlan::paper_efsm(Two): EFSM, block width 64, two groups (152 patterns).
    #[value(name = "paper-efsm-2")]
    PaperEfsm2,
    /// paper-efsm-1 decoded by the paper's local-maximum search (Hann, Gaussian, N = 64): the
    /// camera's fast decoder, less accurate on blurred light than CLEAN.
    #[value(name = "paper-efsm-1-fast")]
    PaperEfsm1Fast,
    /// paper-efsm-2 decoded by the local-maximum search.
    #[value(name = "paper-efsm-2-fast")]
    PaperEfsm2Fast,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum MethodName {
    /// Basic FSM: one fringe per projector column.
    Bfsm,
    /// Extended FSM: fringes of one block width, blocks told apart by masks.
    Efsm,
    /// Phase shift (6 offsets, period 12 columns) with Gray codes.
    PhaseShift,
    /// Micro Phase Shifting (Gupta & Nayar): 15 periods over 14-18 columns, 17 patterns.
    MicroPhaseShift,
    /// Code Ensemble (Gupta et al.): four 10-bit binary codes with their inverses, 80 patterns.
    CodeEnsemble,
    /// Line scanning: one column lit per pattern.
    LineScan,
}

impl MethodName {
    fn plan(self, columns: u16, block_width: u16, groups: u8) -> MethodPlan {
        match self {
            MethodName::Bfsm => MethodPlan::Fsm(ScanPlan::bfsm(columns)),
            MethodName::Efsm => MethodPlan::Fsm(ScanPlan::efsm(
                columns,
                block_width,
                if groups == 1 {
                    GroupCount::One
                } else {
                    GroupCount::Two
                },
            )),
            MethodName::PhaseShift => {
                MethodPlan::PhaseShift(PhaseShiftPlan::for_projector(columns))
            }
            MethodName::MicroPhaseShift => {
                MethodPlan::MicroPhaseShift(MicroPhaseShiftPlan::spread(columns, 16.0, 4.0, 15))
            }
            MethodName::CodeEnsemble => {
                MethodPlan::CodeEnsemble(CodeEnsemblePlan::for_projector(columns))
            }
            MethodName::LineScan => MethodPlan::LineScan(LineScanPlan {
                projector_columns: columns,
                ..LineScanPlan::paper()
            }),
        }
    }
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum Syntax {
    Toml,
    Json,
}

pub fn run(args: Args) -> Result<()> {
    if let Some(path) = &args.check {
        if let Some(wire) = &args.wire {
            fsm_io::outputs::check_file_target(wire, args.force)?;
        }
        let plan = plan_file::read_method_plan(path)?;
        println!("{}: valid plan", path.display());
        print_summary(&plan);
        return write_wire(&plan, args.wire.as_deref());
    }
    let (start, origin) = match (args.preset, args.method, args.projector_columns) {
        (Some(preset), _, _) => {
            let preset = match preset {
                PresetName::PaperBfsm => Preset::PaperBfsm,
                PresetName::PaperEfsm1 => Preset::PaperEfsm1,
                PresetName::PaperEfsm2 => Preset::PaperEfsm2,
                PresetName::PaperEfsm1Fast => Preset::PaperEfsm1Fast,
                PresetName::PaperEfsm2Fast => Preset::PaperEfsm2Fast,
            };
            (
                MethodPlan::Fsm(preset.plan()),
                format!("preset {}", preset.name()),
            )
        }
        (None, Some(method), Some(columns)) => (
            method.plan(columns, args.block_width, args.groups),
            format!("--method {method:?} --projector-columns {columns}"),
        ),
        _ => {
            return Err(Error::Usage(
                "give --preset NAME or --method NAME --projector-columns N (to write a plan), or --check FILE (to check one); see fsm plan --help".into(),
            ))
        }
    };
    for path in [&args.out, &args.wire].into_iter().flatten() {
        fsm_io::outputs::check_file_target(path, args.force)?;
    }
    let mut settings = Vec::new();
    for s in &args.settings {
        settings.push(
            plan_file::split_setting(s)
                .ok_or_else(|| Error::Usage(format!("--set {s}: expected KEY=VALUE")))?,
        );
    }
    let plan =
        plan_file::apply_method_settings(&start, settings).map_err(|source| Error::PlanFile {
            path: origin.into(),
            source,
        })?;
    match &args.out {
        Some(out) => {
            plan_file::write_method_plan(&plan, out)?;
            eprintln!("wrote {}", out.display());
            print_summary(&plan);
        }
        None => {
            let syntax = match args.format {
                Syntax::Toml => PlanSyntax::Toml,
                Syntax::Json => PlanSyntax::Json,
            };
            print!("{}", plan_file::render_method_plan(&plan, syntax));
        }
    }
    write_wire(&plan, args.wire.as_deref())
}

/// Writes the plan's wire bytes to `path`, whole or not at all: FSM plans only (the camera
/// decodes FSM).
fn write_wire(plan: &MethodPlan, path: Option<&Path>) -> Result<()> {
    let Some(path) = path else {
        return Ok(());
    };
    let plan = plan.fsm().map_err(|source| Error::PlanFile {
        path: path.to_path_buf(),
        source,
    })?;
    fsm_io::outputs::write_file(path, &plan.to_bytes())?;
    eprintln!("wrote {} ({} bytes)", path.display(), plan.to_bytes().len());
    Ok(())
}

fn print_summary(plan: &MethodPlan) {
    let patterns = plan.patterns();
    match plan {
        MethodPlan::Fsm(plan) => print_fsm_summary(plan),
        MethodPlan::PhaseShift(p) => {
            println!("  method:        phase shift + Gray code (a method FSM is compared with)");
            println!("  projector:     {} columns", p.projector_columns);
            println!(
                "  fringes:       {} offsets of period {} columns; {} Gray-code bits",
                p.steps, p.period_columns, p.bits
            );
        }
        MethodPlan::MicroPhaseShift(p) => {
            println!("  method:        Micro Phase Shifting (a method FSM is compared with)");
            println!("  projector:     {} columns", p.projector_columns);
            let periods: Vec<String> = p.periods().iter().map(|l| format!("{l:.3}")).collect();
            println!(
                "  fringes:       {} periods (columns; the first at 3 offsets): {}",
                p.frequencies,
                periods.join(", ")
            );
        }
        MethodPlan::LineScan(p) => {
            println!("  method:        line scanning (a method FSM is compared with)");
            println!(
                "  projector:     {} columns, one lit per pattern",
                p.projector_columns
            );
            println!("  detector:      {:?}", p.detector);
        }
        MethodPlan::CodeEnsemble(p) => {
            println!("  method:        Code Ensemble (a method FSM is compared with)");
            let per_codeword = p.projector_columns as f32 / 1024.0;
            if per_codeword > 1.0 {
                println!(
                    "  projector:     {} columns, {per_codeword:.3} per codeword",
                    p.projector_columns
                );
            } else {
                println!("  projector:     {} columns", p.projector_columns);
            }
            println!(
                "  codes:         conventional Gray, long-run Gray, XOR-04, XOR-02 (10 bits each)"
            );
            println!(
                "  agreement:     two codes within {} codeword(s)",
                p.agreement_columns
            );
        }
    }
    if !matches!(plan, MethodPlan::Fsm(_)) {
        println!(
            "  frames:        {} ({} patterns)",
            patterns.frame_count(),
            patterns.pattern_count()
        );
        println!("  fingerprint:   {:016x}", patterns.fingerprint());
        println!(
            "  patterns:      {:016x} (the fingerprint its row dumps carry)",
            patterns.pattern_fingerprint()
        );
    }
}

fn print_fsm_summary(plan: &ScanPlan) {
    let method = match plan.method {
        Method::Bfsm => "BFSM".to_owned(),
        Method::Efsm(b) => format!(
            "EFSM, block width {} columns, {} group(s), border guard {} columns",
            b.block_width,
            plan.group_count(),
            b.border_guard
        ),
    };
    println!("  method:        {method}");
    println!("  projector:     {} columns", plan.projector_columns);
    println!(
        "  fringes:       {} per group, f = {}/{} … {}/{} cycles per column",
        plan.band.count,
        plan.band.first_harmonic,
        plan.band.period_columns,
        plan.band.first_harmonic + plan.band.count as u32 - 1,
        plan.band.period_columns
    );
    println!(
        "  resolution:    {:.3} columns (two columns closer than {:.3} are not separable)",
        plan.column_resolution(),
        2.0 * plan.column_resolution()
    );
    println!("  DFT size N:    {}", plan.transform_size);
    println!(
        "  frames:        {} ({})",
        plan.sequence_len(),
        sequence_summary(plan)
    );
    println!("  fingerprint:   {:016x}", plan.fingerprint());
    println!(
        "  patterns:      {:016x} (the fingerprint its row dumps carry)",
        plan.pattern_fingerprint()
    );
}
