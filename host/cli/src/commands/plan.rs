//! `fsm plan`: write a plan file for any method (from a preset or from the projector's
//! width, with overrides), or check one.

use std::path::PathBuf;

use fsm_core::GroupCount;
use fsm_io::plan_file::{self, MethodKind, MethodPlan, MethodPlanText, PlanSyntax, Preset};
use fsm_io::Result;

use super::named;

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
/// per column), EFSM's band and DFT size from the block width, the other methods' as
/// docs/comparison.md says. Overrides use the file's dotted field names (README, "Plan files"),
/// e.g. `--set band.count=512`, `--set method.Efsm.block_width=32`, `--set references.white=false`,
/// `--set line_scan.noise_factor=8`.
#[derive(clap::Args, Debug)]
#[command(verbatim_doc_comment)]
#[command(group(clap::ArgGroup::new("source").required(true).args(["preset", "method", "check"])))]
pub struct Args {
    /// Start from a preset: the paper's systems (§VII): 768 projector columns; BFSM with 768
    /// fringes, or EFSM with 64-column blocks and one or two groups (76 / 152 patterns); the
    /// -fast ones are decoded by the paper's local-maximum search (Hann, Gaussian, N = 64),
    /// the camera's fast decoder, less accurate on blurred light.
    #[arg(long, conflicts_with_all = ["check", "method"], value_parser = named(Preset::ALL))]
    preset: Option<Preset>,
    /// Make a plan of this method for a projector of --projector-columns columns: BFSM, EFSM,
    /// or one of the methods the paper compares them with (phase shift + Gray code, Micro Phase
    /// Shifting, Code Ensemble, line scanning; see docs/comparison.md).
    #[arg(
        long,
        conflicts_with = "check",
        requires = "projector_columns",
        value_parser = named(MethodKind::ALL)
    )]
    method: Option<MethodKind>,
    /// The projector's columns, for --method.
    #[arg(long, value_name = "COLUMNS", requires = "method")]
    projector_columns: Option<u16>,
    /// EFSM: block width cB in columns (default 64).
    #[arg(long, value_name = "COLUMNS", default_value_t = 64)]
    block_width: u16,
    /// EFSM: pattern groups, 1 or 2 (default 2).
    #[arg(long, value_name = "N", default_value = "2", value_parser = named([(GroupCount::One, "1"), (GroupCount::Two, "2")]))]
    groups: GroupCount,
    /// Override a field: KEY=VALUE (repeatable); the result is validated.
    #[arg(long = "set", value_name = "KEY=VALUE", conflicts_with = "check", value_parser = plan_file::parse_setting)]
    settings: Vec<(String, String)>,
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
    #[arg(long, default_value = "toml", value_parser = named(PlanSyntax::ALL))]
    format: PlanSyntax,
}

pub fn run(args: Args) -> Result<()> {
    let optional = [args.out.as_deref(), args.wire.as_deref()];
    fsm_io::outputs::check_file_targets(optional.into_iter().flatten(), args.force)?;
    let plan = match &args.check {
        Some(path) => {
            let plan = plan_file::read_method_plan(path)?;
            sayln!("{}: valid plan", path.display());
            say!("{}", plan.description());
            plan
        }
        None => write(&args)?,
    };
    if let Some(path) = &args.wire {
        let bytes = plan_file::write_wire(&plan, path)?;
        eprintln!("wrote {} ({bytes} bytes)", path.display());
    }
    Ok(())
}

/// The plan of --preset or --method with the --set overrides, written to --out or printed.
fn write(args: &Args) -> Result<MethodPlan> {
    let settings = args.settings.iter().map(|(k, v)| (k.as_str(), v.as_str()));
    let plan = match (args.preset, args.method, args.projector_columns) {
        (Some(preset), ..) => preset.plan_with(settings)?,
        (None, Some(method), Some(columns)) => {
            method.plan_with(columns, args.block_width, args.groups, settings)?
        }
        _ => unreachable!("clap requires --preset, --method with --projector-columns, or --check"),
    };
    match &args.out {
        Some(out) => {
            plan_file::write_method_plan(&plan, out)?;
            eprintln!("wrote {}", out.display());
            say!("{}", plan.description());
        }
        None => say!("{}", plan_file::render_method_plan(&plan, args.format)),
    }
    Ok(plan)
}
