//! Scan plans as files: TOML or JSON, versioned, mapping one to one onto [`ScanPlan`]
//! (the format is documented in the host README, "Plan files").
//!
//! A plan file is the serde form of `ScanPlan` with one extra top-level key, `format_version`.
//! Reading goes through a generic value tree so that the version is checked before anything
//! else, unknown keys are reported (a misspelt threshold must not silently fall back to
//! nothing) and every type error names its field path (`band.count`, `method.Efsm.block_width`).
//! Rule violations are reported with [`fsm_core::PlanError`]'s message, which names the field.

use std::fmt;
use std::path::Path;

use fsm_core::{GroupCount, PlanError, ScanPlan};
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
        }
    }
}

impl std::error::Error for PlanFileError {}

/// Parses the text of a plan file and validates the plan.
pub fn parse_plan(text: &str, syntax: PlanSyntax) -> Result<ScanPlan, PlanFileError> {
    let tree = parse_tree(text, syntax)?;
    plan_from_tree(tree)
}

/// Reads and validates the plan file at `path` (syntax from its extension).
pub fn read_plan(path: &Path) -> Result<ScanPlan> {
    let text = std::fs::read_to_string(path).at(path)?;
    parse_plan(&text, PlanSyntax::for_path(path)).map_err(|source| Error::PlanFile {
        path: path.to_path_buf(),
        source,
    })
}

/// The text of a plan file holding `plan`.
pub fn render_plan(plan: &ScanPlan, syntax: PlanSyntax) -> String {
    #[derive(serde::Serialize)]
    struct PlanFile<'a> {
        format_version: u64,
        #[serde(flatten)]
        plan: &'a ScanPlan,
    }
    let file = PlanFile {
        format_version: PLAN_FILE_VERSION,
        plan,
    };
    match syntax {
        PlanSyntax::Toml => {
            let body = toml::to_string(&file).expect("a ScanPlan always has a TOML form");
            format!(
                "# FSM scan plan (format described in the host README, \"Plan files\").\n\
                 # {} frames; plan fingerprint {:016x}.\n{body}",
                plan.sequence_len(),
                plan.fingerprint()
            )
        }
        PlanSyntax::Json => {
            let mut s =
                serde_json::to_string_pretty(&file).expect("a ScanPlan always has a JSON form");
            s.push('\n');
            s
        }
    }
}

/// Validates `plan` and writes it to `path`, whole or not at all.
pub fn write_plan(plan: &ScanPlan, path: &Path) -> Result<()> {
    plan.validate().map_err(|e| Error::PlanFile {
        path: path.to_path_buf(),
        source: PlanFileError::Invalid(e),
    })?;
    outputs::write_file(
        path,
        render_plan(plan, PlanSyntax::for_path(path)).as_bytes(),
    )
}

/// Applies `key=value` overrides (dotted keys as in the file, values in TOML syntax; a bare
/// word is a string) to `plan` and validates the result.
pub fn apply_settings<'a>(
    plan: &ScanPlan,
    settings: impl IntoIterator<Item = (&'a str, &'a str)>,
) -> Result<ScanPlan, PlanFileError> {
    let text = render_plan(plan, PlanSyntax::Toml);
    let mut tree = parse_tree(&text, PlanSyntax::Toml)?;
    for (key, value) in settings {
        set_in_tree(&mut tree, key, parse_setting_value(value))?;
    }
    plan_from_tree(tree)
}

/// Splits `key=value`.
pub fn split_setting(setting: &str) -> Option<(&str, &str)> {
    let (k, v) = setting.split_once('=')?;
    Some((k.trim(), v.trim()))
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

fn plan_from_tree(mut tree: Value) -> Result<ScanPlan, PlanFileError> {
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
    let mut unknown = Vec::new();
    let plan: ScanPlan = {
        let mut record = |path: serde_ignored::Path| unknown.push(path.to_string());
        let ignored = serde_ignored::Deserializer::new(&tree, &mut record);
        serde_path_to_error::deserialize(ignored).map_err(|e| PlanFileError::Field {
            field: field_path(e.path()),
            message: e.into_inner().to_string(),
        })?
    };
    if let Some(field) = unknown.into_iter().next() {
        return Err(PlanFileError::UnknownField { field });
    }
    plan.validate().map_err(PlanFileError::Invalid)?;
    Ok(plan)
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

        let bad = text.replace("noise_factor = 5.0", "noise_factr = 5.0");
        let e = parse_plan(&bad, PlanSyntax::Toml).unwrap_err().to_string();
        assert!(
            e.contains("noise_factor") || e.contains("noise_factr"),
            "{e}"
        );

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
}
