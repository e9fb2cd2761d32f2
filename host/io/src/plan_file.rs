//! Scan plans as files: TOML or JSON, versioned, mapping one to one onto [`ScanPlan`], or onto
//! one of the baselines FSM is compared with ([`MethodPlan`]; the format is documented in the
//! host README, "Plan files").
//!
//! A plan file is the serde form of `ScanPlan` with one extra top-level key, `format_version`.
//! A baseline's plan file has `format_version` and one table named for its method
//! (`[phase_shift]`, `[micro_phase_shift]`, `[code_ensemble]` or `[line_scan]`) holding the serde form of its plan.
//! Reading goes through a generic value tree so that the version is checked before anything
//! else, unknown keys are reported (a misspelt threshold must not silently fall back to
//! nothing) and every type error names its field path (`band.count`, `method.Efsm.block_width`).
//! Rule violations are reported with [`fsm_core::PlanError`]'s message, which names the field.

use std::fmt;
use std::path::Path;

use fsm_core::{
    CodeEnsemblePlan, GroupCount, LineScanPlan, MicroPhaseShiftPlan, PhaseShiftPlan, PlanError,
    ScanPlan,
};
use serde_json::Value;

use crate::error::{Error, IoContext, Result};
use crate::outputs;

/// Version of the plan-file format this build writes and reads.
pub const PLAN_FILE_VERSION: u64 = 1;

/// Text syntax of a plan file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlanSyntax {
    /// TOML (the default for `.toml` and unknown extensions).
    Toml,
    /// JSON (`.json`).
    Json,
}

impl PlanSyntax {
    /// Every syntax, with its command-line name (`fsm plan --format`).
    pub const ALL: [(PlanSyntax, &'static str); 2] =
        [(PlanSyntax::Toml, "toml"), (PlanSyntax::Json, "json")];

    /// The syntax a file name implies: `.json` is JSON, anything else TOML.
    pub fn for_path(path: &Path) -> Self {
        match path.extension().and_then(|e| e.to_str()) {
            Some(e) if e.eq_ignore_ascii_case("json") => PlanSyntax::Json,
            _ => PlanSyntax::Toml,
        }
    }
}

/// The plans `fsm plan --preset` knows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Preset {
    /// [`ScanPlan::paper_bfsm`]: 768 columns, 768 fringes, `N = 1024`.
    PaperBfsm,
    /// [`ScanPlan::paper_efsm`] with one group: `cB = 64`, 76 patterns.
    PaperEfsm1,
    /// [`ScanPlan::paper_efsm`] with two groups: `cB = 64`, 152 patterns.
    PaperEfsm2,
    /// [`Preset::PaperEfsm1`] decoded by the paper's local-maximum search
    /// ([`ScanPlan::with_local_maxima`]): the camera's fast decoder.
    PaperEfsm1Fast,
    /// [`Preset::PaperEfsm2`] decoded by the local-maximum search.
    PaperEfsm2Fast,
}

impl Preset {
    /// Every preset, with its command-line name.
    pub const ALL: [(Preset, &'static str); 5] = [
        (Preset::PaperBfsm, "paper-bfsm"),
        (Preset::PaperEfsm1, "paper-efsm-1"),
        (Preset::PaperEfsm2, "paper-efsm-2"),
        (Preset::PaperEfsm1Fast, "paper-efsm-1-fast"),
        (Preset::PaperEfsm2Fast, "paper-efsm-2-fast"),
    ];

    /// The preset called `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.iter().find(|(_, n)| *n == name).map(|(p, _)| *p)
    }

    /// The command-line name.
    pub fn name(self) -> &'static str {
        Self::ALL
            .iter()
            .find(|(p, _)| *p == self)
            .map(|(_, n)| *n)
            .unwrap_or("?")
    }

    /// The plan.
    pub fn plan(self) -> ScanPlan {
        match self {
            Preset::PaperBfsm => ScanPlan::paper_bfsm(),
            Preset::PaperEfsm1 => ScanPlan::paper_efsm(GroupCount::One),
            Preset::PaperEfsm2 => ScanPlan::paper_efsm(GroupCount::Two),
            Preset::PaperEfsm1Fast => ScanPlan::paper_efsm(GroupCount::One).with_local_maxima(),
            Preset::PaperEfsm2Fast => ScanPlan::paper_efsm(GroupCount::Two).with_local_maxima(),
        }
    }

    /// The plan with `fsm plan --set` overrides ([`apply_method_settings`]); an error names
    /// the start, `preset paper-bfsm: …`.
    pub fn plan_with<'a>(
        self,
        settings: impl IntoIterator<Item = (&'a str, &'a str)>,
    ) -> Result<MethodPlan> {
        let origin = format!("preset {}", self.name());
        settings_on(&MethodPlan::Fsm(self.plan()), settings, origin)
    }
}

/// The methods `fsm plan --method` makes plans of, for a projector of a given width.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MethodKind {
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

impl MethodKind {
    /// Every method, with its command-line name.
    pub const ALL: [(MethodKind, &'static str); 6] = [
        (MethodKind::Bfsm, "bfsm"),
        (MethodKind::Efsm, "efsm"),
        (MethodKind::PhaseShift, "phase-shift"),
        (MethodKind::MicroPhaseShift, "micro-phase-shift"),
        (MethodKind::CodeEnsemble, "code-ensemble"),
        (MethodKind::LineScan, "line-scan"),
    ];

    /// The method called `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.iter().find(|(_, n)| *n == name).map(|(m, _)| *m)
    }

    /// The command-line name.
    pub fn name(self) -> &'static str {
        Self::ALL
            .iter()
            .find(|(m, _)| *m == self)
            .expect("listed")
            .1
    }

    /// The method's plan for a projector of `columns` columns, every dependent field derived
    /// from the width; `block_width` and `groups` are EFSM's.
    pub fn plan(self, columns: u16, block_width: u16, groups: GroupCount) -> MethodPlan {
        match self {
            MethodKind::Bfsm => MethodPlan::Fsm(ScanPlan::bfsm(columns)),
            MethodKind::Efsm => MethodPlan::Fsm(ScanPlan::efsm(columns, block_width, groups)),
            MethodKind::PhaseShift => {
                MethodPlan::PhaseShift(PhaseShiftPlan::for_projector(columns))
            }
            MethodKind::MicroPhaseShift => {
                MethodPlan::MicroPhaseShift(MicroPhaseShiftPlan::spread(columns, 16.0, 4.0, 15))
            }
            MethodKind::CodeEnsemble => {
                MethodPlan::CodeEnsemble(CodeEnsemblePlan::for_projector(columns))
            }
            MethodKind::LineScan => MethodPlan::LineScan(LineScanPlan {
                projector_columns: columns,
                ..LineScanPlan::paper()
            }),
        }
    }

    /// [`MethodKind::plan`] with `fsm plan --set` overrides ([`apply_method_settings`]); an
    /// error names the start, `--method efsm --projector-columns 1024: …`.
    pub fn plan_with<'a>(
        self,
        columns: u16,
        block_width: u16,
        groups: GroupCount,
        settings: impl IntoIterator<Item = (&'a str, &'a str)>,
    ) -> Result<MethodPlan> {
        let origin = format!("--method {} --projector-columns {columns}", self.name());
        settings_on(&self.plan(columns, block_width, groups), settings, origin)
    }
}

/// [`apply_method_settings`] to a new plan, an error named by `origin` (where the plan
/// started: `fsm plan`'s preset or method), as a file's error is named by its path.
fn settings_on<'a>(
    start: &MethodPlan,
    settings: impl IntoIterator<Item = (&'a str, &'a str)>,
    origin: String,
) -> Result<MethodPlan> {
    apply_method_settings(start, settings).map_err(|source| Error::PlanFile {
        path: origin.into(),
        source,
    })
}

pub use fsm_core::methods::BASELINE_TABLES;
/// A plan of any method the toolkit knows (`fsm_core::methods::MethodPlan`): its fingerprints,
/// frames, bytes and decoder are the core's; its words ([`MethodPlanText`]) are the host's.
pub use fsm_core::MethodPlan;

impl From<fsm_core::MethodPlanError> for PlanFileError {
    fn from(e: fsm_core::MethodPlanError) -> Self {
        match e {
            fsm_core::MethodPlanError::Fsm(e) => PlanFileError::Invalid(e),
            other => PlanFileError::BaselineInvalid {
                method: match other {
                    fsm_core::MethodPlanError::PhaseShift(_) => BASELINE_TABLES[0],
                    fsm_core::MethodPlanError::MicroPhaseShift(_) => BASELINE_TABLES[1],
                    fsm_core::MethodPlanError::LineScan(_) => BASELINE_TABLES[2],
                    _ => BASELINE_TABLES[3],
                },
                message: other.to_string(),
            },
        }
    }
}

/// What the host says about a plan of any method, in words, and the plan-file errors of its
/// rules: the `String`-returning side of [`MethodPlan`], which `fsm_core` (no allocation)
/// leaves to the host.
pub trait MethodPlanText {
    /// Checks the method's rules, as a plan file's error.
    fn validate(&self) -> Result<(), PlanFileError>;
    /// The frames in words ("dark, white, 768 fringes"; "17 Micro Phase Shifting fringes").
    fn sequence_summary(&self) -> String;
    /// What the plan is and what it resolves to, one `  field:  value` line each (`fsm plan`
    /// prints it): method, projector, fringes or codes, frames and both fingerprints.
    fn description(&self) -> String;
    /// The FSM plan, or the error a command that takes only FSM plans gives.
    fn fsm(self) -> Result<ScanPlan, PlanFileError>;
}

impl MethodPlanText for MethodPlan {
    fn validate(&self) -> Result<(), PlanFileError> {
        self.check().map_err(PlanFileError::from)
    }

    fn sequence_summary(&self) -> String {
        match self {
            MethodPlan::Fsm(p) => crate::stack::sequence_summary(p),
            MethodPlan::PhaseShift(p) => format!(
                "dark, white, {} phase-shift fringes, {} Gray codes",
                p.steps, p.bits
            ),
            MethodPlan::MicroPhaseShift(p) => {
                format!("{} Micro Phase Shifting fringes", p.sequence_len())
            }
            MethodPlan::LineScan(p) => {
                format!("dark, white, {} lines", p.projector_columns)
            }
            MethodPlan::CodeEnsemble(p) => format!(
                "{} Code Ensemble binary patterns (4 codes × 10 bits, each with its inverse)",
                p.sequence_len()
            ),
        }
    }

    fn description(&self) -> String {
        let mut lines: Vec<String> = Vec::new();
        let mut line = |field: &str, value: String| lines.push(format!("  {field:<14} {value}"));
        let compared = "(a method FSM is compared with)";
        match self {
            MethodPlan::Fsm(plan) => {
                line(
                    "method:",
                    match plan.method {
                        fsm_core::Method::Bfsm => "BFSM".to_owned(),
                        fsm_core::Method::Efsm(b) => format!(
                            "EFSM, block width {} columns, {} group(s), border guard {} columns",
                            b.block_width,
                            plan.group_count(),
                            b.border_guard
                        ),
                    },
                );
                line("projector:", format!("{} columns", plan.projector_columns));
                let band = &plan.band;
                line(
                    "fringes:",
                    format!(
                        "{} per group, f = {}/{} … {}/{} cycles per column",
                        band.count,
                        band.first_harmonic,
                        band.period_columns,
                        band.first_harmonic + band.count as u32 - 1,
                        band.period_columns
                    ),
                );
                line(
                    "resolution:",
                    format!(
                        "{:.3} columns (two columns closer than {:.3} are not separable)",
                        plan.column_resolution(),
                        2.0 * plan.column_resolution()
                    ),
                );
                line("DFT size N:", plan.transform_size.to_string());
            }
            MethodPlan::PhaseShift(p) => {
                line("method:", format!("phase shift + Gray code {compared}"));
                line("projector:", format!("{} columns", p.projector_columns));
                line(
                    "fringes:",
                    format!(
                        "{} offsets of period {} columns; {} Gray-code bits",
                        p.steps, p.period_columns, p.bits
                    ),
                );
            }
            MethodPlan::MicroPhaseShift(p) => {
                line("method:", format!("Micro Phase Shifting {compared}"));
                line("projector:", format!("{} columns", p.projector_columns));
                let periods: Vec<String> = p.periods().iter().map(|l| format!("{l:.3}")).collect();
                line(
                    "fringes:",
                    format!(
                        "{} periods (columns; the first at 3 offsets): {}",
                        p.frequencies,
                        periods.join(", ")
                    ),
                );
            }
            MethodPlan::LineScan(p) => {
                line("method:", format!("line scanning {compared}"));
                line(
                    "projector:",
                    format!("{} columns, one lit per pattern", p.projector_columns),
                );
                line("detector:", format!("{:?}", p.detector));
            }
            MethodPlan::CodeEnsemble(p) => {
                line("method:", format!("Code Ensemble {compared}"));
                let per_codeword = p.projector_columns as f32 / 1024.0;
                line(
                    "projector:",
                    if per_codeword > 1.0 {
                        format!(
                            "{} columns, {per_codeword:.3} per codeword",
                            p.projector_columns
                        )
                    } else {
                        format!("{} columns", p.projector_columns)
                    },
                );
                line(
                    "codes:",
                    "conventional Gray, long-run Gray, XOR-04, XOR-02 (10 bits each)".to_owned(),
                );
                line(
                    "agreement:",
                    format!("two codes within {} codeword(s)", p.agreement_columns),
                );
            }
        }
        let patterns = self.patterns();
        line(
            "frames:",
            match self {
                MethodPlan::Fsm(_) => {
                    format!("{} ({})", self.frame_count(), self.sequence_summary())
                }
                _ => format!(
                    "{} ({} patterns)",
                    patterns.frame_count(),
                    patterns.pattern_count()
                ),
            },
        );
        line("fingerprint:", format!("{:016x}", self.fingerprint()));
        line(
            "patterns:",
            format!(
                "{:016x} (the fingerprint its row dumps carry)",
                self.pattern_fingerprint()
            ),
        );
        let mut text = lines.join("\n");
        text.push('\n');
        text
    }

    fn fsm(self) -> Result<ScanPlan, PlanFileError> {
        match self {
            MethodPlan::Fsm(p) => Ok(p),
            other => Err(PlanFileError::OtherMethod {
                found: other.table().unwrap_or("FSM"),
                wanted: "FSM (BFSM or EFSM)",
            }),
        }
    }
}

/// What is wrong with a plan file's text.
#[derive(Clone, Debug, PartialEq)]
pub enum PlanFileError {
    /// Not valid TOML/JSON.
    Syntax {
        /// The parser's message (with line and column).
        message: String,
    },
    /// The top level is not a table/object.
    NotATable,
    /// `format_version` is missing.
    MissingVersion,
    /// `format_version` is not a version this build reads.
    Version {
        /// The value found, as written.
        found: String,
    },
    /// A field has the wrong type or value, or is missing.
    Field {
        /// Dotted path of the field (`band.count`); empty for the top level.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A key that is not part of the format.
    UnknownField {
        /// Dotted path of the key.
        field: String,
    },
    /// A `--set key=value` override names no field of the plan.
    UnknownSetting {
        /// The key given.
        key: String,
        /// The keys that exist at that level.
        known: Vec<String>,
    },
    /// The plan breaks a rule of SPEC §2–§3 (the message names the field).
    Invalid(PlanError),
    /// A baseline's plan breaks one of its rules (the message names the field).
    BaselineInvalid {
        /// The method's table name (`line_scan`, …).
        method: &'static str,
        /// The rule's message.
        message: String,
    },
    /// The file holds a plan of another method than the command takes.
    OtherMethod {
        /// What the file holds (`line_scan`, …).
        found: &'static str,
        /// What the command takes.
        wanted: &'static str,
    },
}

impl fmt::Display for PlanFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PlanFileError::Syntax { message } => write!(f, "not a readable plan file: {message}"),
            PlanFileError::NotATable => write!(f, "the top level must be a table of plan fields"),
            PlanFileError::MissingVersion => write!(
                f,
                "field format_version is missing (this build reads format_version = {PLAN_FILE_VERSION})"
            ),
            PlanFileError::Version { found } => write!(
                f,
                "field format_version = {found} is not supported (this build reads format_version = {PLAN_FILE_VERSION})"
            ),
            PlanFileError::Field { field, message } if field.is_empty() => write!(f, "{message}"),
            PlanFileError::Field { field, message } => write!(f, "field {field}: {message}"),
            PlanFileError::UnknownField { field } => {
                write!(f, "field {field} is not part of the plan format (misspelt?)")
            }
            PlanFileError::UnknownSetting { key, known } => write!(
                f,
                "--set {key}: no such plan field (fields here: {})",
                known.join(", ")
            ),
            PlanFileError::Invalid(e) => write!(f, "invalid plan: {e}"),
            PlanFileError::BaselineInvalid { method, message } => {
                write!(f, "invalid {method} plan: {message}")
            }
            PlanFileError::OtherMethod { found, wanted } => write!(
                f,
                "this is a {found} plan; this command takes {wanted} plans (see the README, \"Plan files\")"
            ),
        }
    }
}

impl std::error::Error for PlanFileError {}

/// Parses the text of an FSM plan file and validates the plan.
pub fn parse_plan(text: &str, syntax: PlanSyntax) -> Result<ScanPlan, PlanFileError> {
    parse_method_plan(text, syntax)?.fsm()
}

/// Parses the text of a plan file of any method and validates the plan.
pub fn parse_method_plan(text: &str, syntax: PlanSyntax) -> Result<MethodPlan, PlanFileError> {
    let tree = parse_tree(text, syntax)?;
    plan_from_tree(tree)
}

/// Reads and validates the FSM plan file at `path` (syntax from its extension).
pub fn read_plan(path: &Path) -> Result<ScanPlan> {
    read_method_plan(path)?
        .fsm()
        .map_err(|source| Error::PlanFile {
            path: path.to_path_buf(),
            source,
        })
}

/// Reads and validates the plan file of any method at `path` (syntax from its extension).
pub fn read_method_plan(path: &Path) -> Result<MethodPlan> {
    let text = std::fs::read_to_string(path).at(path)?;
    parse_method_plan(&text, PlanSyntax::for_path(path)).map_err(|source| Error::PlanFile {
        path: path.to_path_buf(),
        source,
    })
}

/// The text of a plan file holding `plan`.
pub fn render_plan(plan: &ScanPlan, syntax: PlanSyntax) -> String {
    render_method_plan(&MethodPlan::Fsm(*plan), syntax)
}

/// The text of a plan file holding `plan`, of any method.
pub fn render_method_plan(plan: &MethodPlan, syntax: PlanSyntax) -> String {
    use serde::Serialize;
    // The fields in the plan types' order, `format_version` first.
    #[derive(Serialize)]
    struct Fsm<'a> {
        format_version: u64,
        #[serde(flatten)]
        plan: &'a ScanPlan,
    }
    #[derive(Serialize)]
    struct PhaseShift<'a> {
        format_version: u64,
        phase_shift: &'a PhaseShiftPlan,
    }
    #[derive(Serialize)]
    struct MicroPhaseShift<'a> {
        format_version: u64,
        micro_phase_shift: &'a MicroPhaseShiftPlan,
    }
    #[derive(Serialize)]
    struct LineScan<'a> {
        format_version: u64,
        line_scan: &'a LineScanPlan,
    }
    #[derive(Serialize)]
    struct CodeEnsemble<'a> {
        format_version: u64,
        code_ensemble: &'a CodeEnsemblePlan,
    }
    fn text(file: &impl Serialize, syntax: PlanSyntax) -> String {
        match syntax {
            PlanSyntax::Toml => toml::to_string(file).expect("a plan always has a TOML form"),
            PlanSyntax::Json => {
                let mut s =
                    serde_json::to_string_pretty(file).expect("a plan always has a JSON form");
                s.push('\n');
                s
            }
        }
    }
    let format_version = PLAN_FILE_VERSION;
    let body = match plan {
        MethodPlan::Fsm(plan) => text(
            &Fsm {
                format_version,
                plan,
            },
            syntax,
        ),
        MethodPlan::PhaseShift(p) => text(
            &PhaseShift {
                format_version,
                phase_shift: p,
            },
            syntax,
        ),
        MethodPlan::MicroPhaseShift(p) => text(
            &MicroPhaseShift {
                format_version,
                micro_phase_shift: p,
            },
            syntax,
        ),
        MethodPlan::LineScan(p) => text(
            &LineScan {
                format_version,
                line_scan: p,
            },
            syntax,
        ),
        MethodPlan::CodeEnsemble(p) => text(
            &CodeEnsemble {
                format_version,
                code_ensemble: p,
            },
            syntax,
        ),
    };
    match syntax {
        PlanSyntax::Toml => {
            let patterns = plan.patterns();
            let what = match plan {
                MethodPlan::Fsm(_) => "FSM scan plan".to_owned(),
                _ => format!("{} plan (a method FSM is compared with)", plan.name()),
            };
            format!(
                "# {what} (format described in the host README, \"Plan files\").\n\
                 # {} frames; plan fingerprint {:016x}, pattern fingerprint {:016x}.\n{body}",
                patterns.frame_count(),
                patterns.fingerprint(),
                patterns.pattern_fingerprint()
            )
        }
        PlanSyntax::Json => body,
    }
}

/// `plan` as its plan file holds it, without `format_version` (a pattern manifest's `plan`).
pub fn plan_value(plan: &MethodPlan) -> Value {
    let mut tree: Value = serde_json::from_str(&render_method_plan(plan, PlanSyntax::Json))
        .expect("a rendered plan is JSON");
    if let Some(object) = tree.as_object_mut() {
        object.remove("format_version");
    }
    tree
}

/// Validates `plan` and writes it to `path`, whole or not at all.
pub fn write_plan(plan: &ScanPlan, path: &Path) -> Result<()> {
    write_method_plan(&MethodPlan::Fsm(*plan), path)
}

/// Validates `plan` (any method) and writes it to `path`, whole or not at all.
pub fn write_method_plan(plan: &MethodPlan, path: &Path) -> Result<()> {
    plan.validate().map_err(|source| Error::PlanFile {
        path: path.to_path_buf(),
        source,
    })?;
    outputs::write_file(
        path,
        render_method_plan(plan, PlanSyntax::for_path(path)).as_bytes(),
    )
}

/// Writes the plan's canonical bytes (`fsm_core::methods::wire`: an FSM plan's 80, a
/// baseline's 32 or 96; the bytes `fsm upload` sends) to `path`, whole or not at all, and
/// returns their length.
pub fn write_wire(plan: &MethodPlan, path: &Path) -> Result<usize> {
    let bytes = plan.to_bytes();
    outputs::write_file(path, &bytes)?;
    Ok(bytes.len())
}

/// Applies `key=value` overrides (dotted keys as in the file, values in TOML syntax; a bare
/// word is a string) to `plan` and validates the result.
pub fn apply_settings<'a>(
    plan: &ScanPlan,
    settings: impl IntoIterator<Item = (&'a str, &'a str)>,
) -> Result<ScanPlan, PlanFileError> {
    apply_method_settings(&MethodPlan::Fsm(*plan), settings)?.fsm()
}

/// [`apply_settings`] for a plan of any method (a baseline's keys start with its table:
/// `line_scan.noise_factor`).
pub fn apply_method_settings<'a>(
    plan: &MethodPlan,
    settings: impl IntoIterator<Item = (&'a str, &'a str)>,
) -> Result<MethodPlan, PlanFileError> {
    let text = render_method_plan(plan, PlanSyntax::Toml);
    let mut tree = parse_tree(&text, PlanSyntax::Toml)?;
    for (key, value) in settings {
        set_in_tree(&mut tree, key, parse_setting_value(value))?;
    }
    plan_from_tree(tree)
}

/// `fsm plan --set`'s `KEY=VALUE`, split and trimmed (the value is read by
/// [`apply_method_settings`]); the error says `expected KEY=VALUE`. The command's parser, here
/// with the settings it feeds.
pub fn parse_setting(setting: &str) -> Result<(String, String), String> {
    let (k, v) = setting.split_once('=').ok_or("expected KEY=VALUE")?;
    Ok((k.trim().to_owned(), v.trim().to_owned()))
}

fn parse_tree(text: &str, syntax: PlanSyntax) -> Result<Value, PlanFileError> {
    let syntax_error = |message: String| PlanFileError::Syntax { message };
    let tree: Value = match syntax {
        PlanSyntax::Toml => {
            let table: toml::Table =
                toml::from_str(text).map_err(|e| syntax_error(e.to_string().trim().to_owned()))?;
            serde_json::to_value(table).map_err(|e| syntax_error(e.to_string()))?
        }
        PlanSyntax::Json => serde_json::from_str(text).map_err(|e| syntax_error(e.to_string()))?,
    };
    if !tree.is_object() {
        return Err(PlanFileError::NotATable);
    }
    Ok(tree)
}

fn plan_from_tree(mut tree: Value) -> Result<MethodPlan, PlanFileError> {
    let object = tree.as_object_mut().ok_or(PlanFileError::NotATable)?;
    match object.remove("format_version") {
        None => return Err(PlanFileError::MissingVersion),
        Some(v) if v.as_u64() == Some(PLAN_FILE_VERSION) => {}
        Some(v) => {
            return Err(PlanFileError::Version {
                found: v.to_string(),
            })
        }
    }
    let baseline = BASELINE_TABLES.iter().position(|t| object.contains_key(*t));
    let plan = match baseline {
        None => MethodPlan::Fsm(deserialize_checked(tree, "")?),
        Some(i) => {
            let table = BASELINE_TABLES[i];
            let body = object.remove(table).expect("found above");
            // A baseline's file holds its table alone.
            if let Some(other) = object.keys().next() {
                return Err(PlanFileError::UnknownField {
                    field: other.clone(),
                });
            }
            let prefix = format!("{table}.");
            match i {
                0 => MethodPlan::PhaseShift(deserialize_checked(body, &prefix)?),
                1 => MethodPlan::MicroPhaseShift(deserialize_checked(body, &prefix)?),
                2 => MethodPlan::LineScan(deserialize_checked(body, &prefix)?),
                _ => MethodPlan::CodeEnsemble(deserialize_checked(body, &prefix)?),
            }
        }
    };
    plan.validate()?;
    Ok(plan)
}

/// `T` from `tree`, every type error and unknown key named by its dotted path after `prefix`.
fn deserialize_checked<T: serde::de::DeserializeOwned>(
    tree: Value,
    prefix: &str,
) -> Result<T, PlanFileError> {
    let mut unknown = Vec::new();
    let result: Result<T, _> = {
        let mut record = |path: serde_ignored::Path| unknown.push(path.to_string());
        let ignored = serde_ignored::Deserializer::new(&tree, &mut record);
        serde_path_to_error::deserialize(ignored)
    };
    // A misspelt key is named as the user wrote it, before the field it leaves missing.
    let value = match (result, unknown.first()) {
        (Ok(value), _) => value,
        (Err(_), Some(field)) => {
            return Err(PlanFileError::UnknownField {
                field: format!("{prefix}{field}"),
            })
        }
        (Err(e), None) => {
            return Err(PlanFileError::Field {
                field: match field_path(e.path()) {
                    p if p.is_empty() => prefix.trim_end_matches('.').to_owned(),
                    p => format!("{prefix}{p}"),
                },
                message: e.into_inner().to_string(),
            })
        }
    };
    if let Some(field) = unknown.into_iter().next() {
        return Err(PlanFileError::UnknownField {
            field: format!("{prefix}{field}"),
        });
    }
    Ok(value)
}

/// `serde_path_to_error` writes `.` for the root; the files' users know no root.
fn field_path(path: &serde_path_to_error::Path) -> String {
    let s = path.to_string();
    if s == "." {
        String::new()
    } else {
        s
    }
}

fn parse_setting_value(value: &str) -> Value {
    // TOML's literal syntax: numbers, booleans, quoted strings; a bare word is a string.
    let parsed: Option<Value> = toml::from_str::<toml::Table>(&format!("v = {value}"))
        .ok()
        .and_then(|t| serde_json::to_value(t).ok())
        .and_then(|mut v| v.as_object_mut()?.remove("v"));
    parsed.unwrap_or_else(|| Value::String(value.to_owned()))
}

fn set_in_tree(tree: &mut Value, key: &str, value: Value) -> Result<(), PlanFileError> {
    let parts: Vec<&str> = key.split('.').collect();
    let mut node = tree;
    for (i, part) in parts.iter().enumerate() {
        let last = i + 1 == parts.len();
        let unknown = |node: &Value| PlanFileError::UnknownSetting {
            key: key.to_owned(),
            known: node
                .as_object()
                .map(|o| o.keys().cloned().collect())
                .unwrap_or_default(),
        };
        // An enum given as a string (`method = "Bfsm"`) becomes a table when a variant's field
        // is set (`method.Efsm.block_width = 32`): the variant then needs all its fields.
        if !node.is_object() {
            return Err(unknown(node));
        }
        let object = node.as_object_mut().expect("checked above");
        if last {
            if !object.contains_key(*part) && !is_variant_name(part) {
                return Err(unknown(&Value::Object(object.clone())));
            }
            object.insert((*part).to_owned(), value);
            return Ok(());
        }
        if !object.contains_key(*part) {
            if is_variant_name(part) {
                object.clear();
                object.insert((*part).to_owned(), Value::Object(Default::default()));
            } else {
                return Err(unknown(&Value::Object(object.clone())));
            }
        }
        let child = object.get_mut(*part).expect("present");
        if let Value::String(variant) = child {
            let variant = variant.clone();
            let next = parts.get(i + 1).copied().unwrap_or_default();
            if next != variant && is_variant_name(next) {
                *child = Value::Object(Default::default());
            }
        }
        node = child;
    }
    Ok(())
}

/// Enum variants carrying data are written `{ Variant = { … } }`: a capitalised key.
fn is_variant_name(part: &str) -> bool {
    part.chars().next().is_some_and(|c| c.is_ascii_uppercase())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_round_trip_through_both_syntaxes() {
        for (preset, _) in Preset::ALL {
            let plan = preset.plan();
            for syntax in [PlanSyntax::Toml, PlanSyntax::Json] {
                let text = render_plan(&plan, syntax);
                let back = parse_plan(&text, syntax).unwrap();
                assert_eq!(back, plan);
                assert_eq!(back.fingerprint(), plan.fingerprint());
            }
        }
    }

    #[test]
    fn a_plan_file_without_the_search_decodes_with_clean() {
        // Plan files written before `decoding.search` existed, and before `decoding.sensor`.
        let plan = Preset::PaperEfsm2.plan().with_clean();
        let text = render_plan(&plan, PlanSyntax::Toml);
        assert!(text.contains("search = \"Clean\""), "{text}");
        assert!(text.contains("[decoding.sensor]"), "{text}");
        let old: String = text
            .split("[decoding.sensor]")
            .next()
            .unwrap()
            .lines()
            .filter(|l| !l.starts_with("search ="))
            .map(|l| format!("{l}\n"))
            .collect();
        assert_eq!(parse_plan(&old, PlanSyntax::Toml).unwrap(), plan);
        // Today's presets decode with the cosine search.
        let text = render_plan(&Preset::PaperEfsm2.plan(), PlanSyntax::Toml);
        assert!(text.contains("search = \"Cosine\""), "{text}");
        let fast = Preset::PaperEfsm2Fast.plan();
        let text = render_plan(&fast, PlanSyntax::Toml);
        assert!(text.contains("search = \"LocalMaxima\""), "{text}");
        assert_eq!(parse_plan(&text, PlanSyntax::Toml).unwrap(), fast);
    }

    #[test]
    fn errors_name_the_field() {
        let text = render_plan(&ScanPlan::paper_bfsm(), PlanSyntax::Toml);
        let bad = text.replace("count = 768", "count = 70000");
        let e = parse_plan(&bad, PlanSyntax::Toml).unwrap_err();
        assert!(e.to_string().contains("band.count"), "{e}");

        // The misspelt key as written, not only the field it leaves missing.
        let bad = text.replace("\nnoise_factor = 5.0", "\nnoise_factr = 5.0");
        assert_ne!(bad, text);
        let e = parse_plan(&bad, PlanSyntax::Toml).unwrap_err().to_string();
        assert!(e.contains("field decoding.noise_factr is not part"), "{e}");

        let bad = text.replace("count = 768", "count = 8");
        let e = parse_plan(&bad, PlanSyntax::Toml).unwrap_err();
        assert_eq!(
            e,
            PlanFileError::Invalid(PlanError::TooFewFringes { count: 8, min: 16 })
        );
        assert!(e.to_string().contains("count = 8"));

        let bad = text.replace("format_version = 1", "format_version = 2");
        let e = parse_plan(&bad, PlanSyntax::Toml).unwrap_err();
        assert!(matches!(e, PlanFileError::Version { .. }));
    }

    #[test]
    fn settings_override_fields_and_variants() {
        let plan = ScanPlan::paper_bfsm();
        let p = apply_settings(
            &plan,
            [("decoding.noise_factor", "5"), ("transform_size", "2048")],
        )
        .unwrap();
        assert_eq!(p.decoding.noise_factor, 5.0);
        assert_eq!(p.transform_size, 2048);

        let efsm = ScanPlan::paper_efsm(GroupCount::Two);
        let p = apply_settings(&efsm, [("method.Efsm.groups", "One")]).unwrap();
        assert_eq!(p, ScanPlan::paper_efsm(GroupCount::One));

        // Switching method: the band must follow, else the Nyquist rule names the field.
        let e = apply_settings(&efsm, [("method", "Bfsm")]).unwrap_err();
        assert!(e.to_string().contains("period_columns"), "{e}");
        let p = apply_settings(
            &efsm,
            [
                ("method", "Bfsm"),
                ("band.period_columns", "1536"),
                ("band.count", "768"),
                ("transform_size", "1024"),
            ],
        )
        .unwrap();
        assert_eq!(p, ScanPlan::paper_bfsm());

        let e = apply_settings(&plan, [("band.cuont", "3")]).unwrap_err();
        assert!(e.to_string().contains("band.cuont"), "{e}");
        assert!(e.to_string().contains("count"), "{e}");
    }

    fn baselines() -> [MethodPlan; 3] {
        [
            MethodPlan::PhaseShift(PhaseShiftPlan::for_projector(256)),
            MethodPlan::MicroPhaseShift(MicroPhaseShiftPlan::spread(256, 16.0, 4.0, 15)),
            MethodPlan::LineScan(LineScanPlan {
                projector_columns: 256,
                ..LineScanPlan::paper()
            }),
        ]
    }

    #[test]
    fn baseline_plans_round_trip_and_are_not_fsm_plans() {
        for plan in baselines() {
            let table = plan.table().unwrap();
            for syntax in [PlanSyntax::Toml, PlanSyntax::Json] {
                let text = render_method_plan(&plan, syntax);
                assert!(text.contains(table), "{text}");
                assert_eq!(parse_method_plan(&text, syntax).unwrap(), plan);
                // A command that takes FSM plans says what the file holds.
                let e = parse_plan(&text, syntax).unwrap_err();
                assert_eq!(
                    e,
                    PlanFileError::OtherMethod {
                        found: table,
                        wanted: "FSM (BFSM or EFSM)"
                    }
                );
                assert!(e.to_string().contains(table), "{e}");
            }
        }
        // FSM plans read as before through both entry points.
        let bfsm = Preset::PaperBfsm.plan();
        let text = render_plan(&bfsm, PlanSyntax::Toml);
        assert_eq!(
            parse_method_plan(&text, PlanSyntax::Toml).unwrap(),
            MethodPlan::Fsm(bfsm)
        );
    }

    #[test]
    fn baseline_errors_name_the_field() {
        let [ps, mps, ls] = baselines();
        let text = render_method_plan(&ls, PlanSyntax::Toml);
        let bad = text.replace("noise_factor =", "noise_factr =");
        let e = parse_method_plan(&bad, PlanSyntax::Toml).unwrap_err();
        assert_eq!(
            e,
            PlanFileError::UnknownField {
                field: "line_scan.noise_factr".into()
            }
        );
        let bad = text.replace("projector_columns = 256", "projector_columns = \"wide\"");
        let e = parse_method_plan(&bad, PlanSyntax::Toml).unwrap_err();
        assert!(e.to_string().contains("line_scan.projector_columns"), "{e}");
        // A rule of the method, named by its field.
        let text = render_method_plan(&ps, PlanSyntax::Toml);
        let bad = text.replace("bits = 6", "bits = 5");
        let e = parse_method_plan(&bad, PlanSyntax::Toml).unwrap_err();
        assert!(
            e.to_string().contains("invalid phase_shift plan: bits = 5"),
            "{e}"
        );
        // A second method's table beside the first.
        let text = render_method_plan(&mps, PlanSyntax::Toml) + "[line_scan]\n";
        let e = parse_method_plan(&text, PlanSyntax::Toml).unwrap_err();
        assert!(matches!(e, PlanFileError::UnknownField { .. }), "{e}");
    }

    #[test]
    fn baseline_settings_are_keyed_by_their_table() {
        let [_, _, ls] = baselines();
        let p = apply_method_settings(&ls, [("line_scan.noise_factor", "8")]).unwrap();
        let MethodPlan::LineScan(p) = p else {
            panic!("{p:?}")
        };
        assert_eq!(p.noise_factor, 8.0);
        let e = apply_method_settings(&ls, [("line_scan.noise", "8")]).unwrap_err();
        assert!(e.to_string().contains("noise_factor"), "{e}");
    }

    #[test]
    fn the_wire_form_is_written_for_every_method() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plan.bin");
        let plan = Preset::PaperEfsm2.plan();
        let len = write_wire(&MethodPlan::Fsm(plan), &path).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(
            (len, ScanPlan::from_bytes(&bytes).unwrap()),
            (bytes.len(), plan)
        );
        for (kind, _) in MethodKind::ALL {
            let plan = kind.plan(256, 64, GroupCount::Two);
            let path = dir.path().join(format!("{}.bin", kind.name()));
            let len = write_wire(&plan, &path).unwrap();
            let bytes = std::fs::read(&path).unwrap();
            assert_eq!(len, plan.wire_len());
            assert_eq!(MethodPlan::from_bytes(&bytes), Ok(plan));
        }
    }

    #[test]
    fn names_are_the_tables() {
        for (method, name) in MethodKind::ALL {
            assert_eq!(MethodKind::from_name(method.name()), Some(method), "{name}");
        }
    }
}
