//! `fsm plan`: write a plan file for any method (from a preset or from the projector's
//! width, with overrides), or check one.

use std::path::{Path, PathBuf};

use clap::builder::PossibleValuesParser;
use clap::ValueEnum;
use fsm_core::GroupCount;
use fsm_io::plan_file::{self, MethodKind, MethodPlan, PlanSyntax, Preset};
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
    /// fringes, or EFSM with 64-column blocks and one or two groups (76 / 152 patterns); the
    /// -fast ones are decoded by the paper's local-maximum search (Hann, Gaussian, N = 64),
    /// the camera's fast decoder, less accurate on blurred light.
    #[arg(long, conflicts_with_all = ["check", "method"], value_parser = super::preset_parser())]
    preset: Option<String>,
    /// Make a plan of this method for a projector of --projector-columns columns: BFSM, EFSM,
    /// or one of the methods the paper compares them with (phase shift + Gray code, Micro Phase
    /// Shifting, Code Ensemble, line scanning; see docs/comparison.md).
    #[arg(
        long,
        conflicts_with = "check",
        requires = "projector_columns",
        value_parser = PossibleValuesParser::new(MethodKind::ALL.map(|(_, n)| n))
    )]
    method: Option<String>,
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
        sayln!("{}: valid plan", path.display());
        print_summary(&plan);
        return write_wire(&plan, args.wire.as_deref());
    }
    let (start, origin) = match (&args.preset, &args.method, args.projector_columns) {
        (Some(name), _, _) => (
            MethodPlan::Fsm(Preset::from_name(name).expect("clap checked").plan()),
            format!("preset {name}"),
        ),
        (None, Some(name), Some(columns)) => {
            let groups = if args.groups == 1 {
                GroupCount::One
            } else {
                GroupCount::Two
            };
            let method = MethodKind::from_name(name).expect("clap checked");
            (
                method.plan(columns, args.block_width, groups),
                format!("--method {name} --projector-columns {columns}"),
            )
        }
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
            say!("{}", plan_file::render_method_plan(&plan, syntax));
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
    say!("{}", plan.description());
}
