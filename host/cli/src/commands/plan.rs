//! `fsm plan`: write a scan-plan file from a preset (with overrides), or check one.

use std::path::{Path, PathBuf};

use clap::ValueEnum;
use fsm_core::{Method, ScanPlan};
use fsm_io::plan_file::{self, PlanSyntax, Preset};
use fsm_io::stack::sequence_summary;
use fsm_io::{Error, Result};

/// Write or check a scan-plan file (TOML or JSON, chosen by the file extension).
///
/// Examples:
///   fsm plan --preset paper-bfsm --out plan.toml
///   fsm plan --preset paper-efsm-2 --set decoding.noise_factor=5 --out plan.json
///   fsm plan --check plan.toml
///   fsm plan --check plan.toml --wire plan.bin
///
/// Overrides use the file's dotted field names (see the README, "Plan files"); e.g.
/// `--set band.count=512`, `--set method.Efsm.block_width=32`, `--set references.white=false`.
#[derive(clap::Args, Debug)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Start from a preset: the paper's systems (§VII): 768 projector columns; BFSM with 768
    /// fringes, or EFSM with 64-column blocks and one or two groups (76 / 152 patterns).
    #[arg(long, value_enum, conflicts_with = "check")]
    preset: Option<PresetName>,
    /// Override a field: KEY=VALUE (repeatable); the result is validated.
    #[arg(long = "set", value_name = "KEY=VALUE", requires = "preset")]
    settings: Vec<String>,
    /// Write the plan here (.toml or .json); without it the plan is printed.
    #[arg(long, value_name = "FILE", requires = "preset")]
    out: Option<PathBuf>,
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
enum Syntax {
    Toml,
    Json,
}

pub fn run(args: Args) -> Result<()> {
    if let Some(path) = &args.check {
        let plan = plan_file::read_plan(path)?;
        println!("{}: valid plan", path.display());
        print_summary(&plan);
        return write_wire(&plan, args.wire.as_deref());
    }
    let Some(preset) = args.preset else {
        return Err(Error::Usage(
            "give --preset NAME (to write a plan) or --check FILE (to check one); see fsm plan --help".into(),
        ));
    };
    let preset = match preset {
        PresetName::PaperBfsm => Preset::PaperBfsm,
        PresetName::PaperEfsm1 => Preset::PaperEfsm1,
        PresetName::PaperEfsm2 => Preset::PaperEfsm2,
        PresetName::PaperEfsm1Fast => Preset::PaperEfsm1Fast,
        PresetName::PaperEfsm2Fast => Preset::PaperEfsm2Fast,
    };
    let mut settings = Vec::new();
    for s in &args.settings {
        settings.push(
            plan_file::split_setting(s)
                .ok_or_else(|| Error::Usage(format!("--set {s}: expected KEY=VALUE")))?,
        );
    }
    let plan =
        plan_file::apply_settings(&preset.plan(), settings).map_err(|source| Error::PlanFile {
            path: format!("preset {}", preset.name()).into(),
            source,
        })?;
    match &args.out {
        Some(out) => {
            plan_file::write_plan(&plan, out)?;
            eprintln!("wrote {}", out.display());
            print_summary(&plan);
        }
        None => {
            let syntax = match args.format {
                Syntax::Toml => PlanSyntax::Toml,
                Syntax::Json => PlanSyntax::Json,
            };
            print!("{}", plan_file::render_plan(&plan, syntax));
        }
    }
    write_wire(&plan, args.wire.as_deref())
}

/// Writes the plan's wire bytes to `path`, whole or not at all.
fn write_wire(plan: &ScanPlan, path: Option<&Path>) -> Result<()> {
    if let Some(path) = path {
        fsm_io::outputs::write_file(path, &plan.to_bytes())?;
        eprintln!("wrote {} ({} bytes)", path.display(), plan.to_bytes().len());
    }
    Ok(())
}

fn print_summary(plan: &ScanPlan) {
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
}
