//! The plan-file parser under arbitrary input: it never panics, and a field given a wrong
//! value is reported by name.

use fsm_core::GroupCount;
use fsm_core::ScanPlan;
use fsm_io::plan_file::{parse_plan, render_plan, PlanFileError, PlanSyntax};
use proptest::prelude::*;
use serde_json::Value;

/// Every leaf field path of a plan file (`band.count`, `method.Efsm.block_width`, …).
fn leaf_paths(value: &Value, prefix: &str, out: &mut Vec<String>) {
    match value {
        Value::Object(map) => {
            for (k, v) in map {
                let path = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                leaf_paths(v, &path, out);
            }
        }
        _ => out.push(prefix.to_owned()),
    }
}

fn set_path(tree: &mut Value, path: &str, value: Value) {
    let mut node = tree;
    let parts: Vec<&str> = path.split('.').collect();
    for part in &parts[..parts.len() - 1] {
        node = node.get_mut(*part).unwrap();
    }
    node[parts[parts.len() - 1]] = value;
}

fn presets() -> [ScanPlan; 3] {
    [
        ScanPlan::paper_bfsm(),
        ScanPlan::paper_efsm(GroupCount::One),
        ScanPlan::paper_efsm(GroupCount::Two),
    ]
}

/// Field names a rule message may mention.
const FIELD_NAMES: [&str; 23] = [
    "projector_columns",
    "transform_size",
    "period_columns",
    "first_harmonic",
    "count",
    "block_width",
    "groups",
    "border_guard",
    "offset",
    "amplitude",
    "dark",
    "white",
    "window",
    "estimator",
    "max_peaks",
    "noise_factor",
    "relative_floor",
    "min_amplitude_dn",
    "mask_noise_factor",
    "mask_relative_floor",
    "merge_tolerance",
    "full_scale_electrons",
    "read_noise_electrons",
];

fn arbitrary_value() -> impl Strategy<Value = Value> {
    prop_oneof![
        any::<i64>().prop_map(Value::from),
        (-1e6f64..1e6).prop_map(Value::from),
        prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(-0.0)]
            .prop_map(|f| serde_json::json!(f)),
        any::<bool>().prop_map(Value::from),
        "[a-zA-Z]{0,8}".prop_map(Value::from),
        Just(Value::Null),
        proptest::collection::vec(any::<u8>(), 0..3).prop_map(|v| serde_json::json!(v)),
        Just(serde_json::json!({"x": 1})),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn arbitrary_text_never_panics(text in ".{0,300}") {
        for syntax in [PlanSyntax::Toml, PlanSyntax::Json] {
            if let Err(e) = parse_plan(&text, syntax) {
                prop_assert!(!e.to_string().is_empty());
            }
        }
    }

    #[test]
    fn arbitrary_bytes_in_a_valid_file_never_panic(at in 0usize..2000, byte in any::<u8>(), preset in 0usize..3) {
        let text = render_plan(&presets()[preset], PlanSyntax::Toml);
        let mut bytes = text.into_bytes();
        let at = at % bytes.len();
        bytes[at] = byte;
        if let Ok(text) = String::from_utf8(bytes) {
            let _ = parse_plan(&text, PlanSyntax::Toml);
        }
    }

    #[test]
    fn a_wrong_field_value_is_reported_by_name(
        preset in 0usize..3,
        field in any::<prop::sample::Index>(),
        value in arbitrary_value(),
        json in any::<bool>(),
    ) {
        let plan = &presets()[preset];
        let mut tree: Value = serde_json::from_str(&render_plan(plan, PlanSyntax::Json)).unwrap();
        let mut paths = Vec::new();
        leaf_paths(&tree, "", &mut paths);
        let path = field.get(&paths).clone();
        set_path(&mut tree, &path, value.clone());
        let text = if json {
            serde_json::to_string(&tree).unwrap()
        } else {
            // TOML has no null and no NaN literal in serde_json's form: such values are absent
            // or strings there, which the parser must report just the same.
            match toml::to_string(&tree) {
                Ok(t) => t,
                Err(_) => return Ok(()),
            }
        };
        let syntax = if json { PlanSyntax::Json } else { PlanSyntax::Toml };
        match parse_plan(&text, syntax) {
            Ok(parsed) => {
                // Accepted: it must be a valid plan that carries the value given.
                prop_assert!(parsed.validate().is_ok());
            }
            Err(PlanFileError::Field { field, message }) => {
                // A type or range error names the field it is about: the one changed, or —
                // when a value became absent — its parent, whose message names the missing key.
                let leaf = path.rsplit('.').next().unwrap();
                prop_assert!(
                    field == path || (path.starts_with(&field) && message.contains(leaf)) || path.starts_with(&format!("{field}.")),
                    "changed {}, error at {:?}: {}", path, field, message
                );
            }
            Err(PlanFileError::UnknownField { field }) => {
                prop_assert!(field.starts_with(&path) || path.starts_with(&field), "changed {}, unknown {}", path, field);
            }
            Err(PlanFileError::Invalid(e)) => {
                let message = e.to_string();
                prop_assert!(FIELD_NAMES.iter().any(|f| message.contains(f)), "rule message names no field: {}", message);
            }
            Err(PlanFileError::MissingVersion) | Err(PlanFileError::Version { .. }) => {
                prop_assert_eq!(path.as_str(), "format_version");
            }
            Err(e) => prop_assert!(false, "changed {} to {}: unexpected {:?}", path, value, e),
        }
    }
}

#[test]
fn the_paper_presets_parse_back_from_both_syntaxes() {
    for plan in presets() {
        for syntax in [PlanSyntax::Toml, PlanSyntax::Json] {
            assert_eq!(
                parse_plan(&render_plan(&plan, syntax), syntax).unwrap(),
                plan
            );
        }
    }
}

#[test]
fn new_plans_take_overrides_and_name_their_start_in_errors() {
    use fsm_io::plan_file::{apply_method_settings, MethodKind, MethodPlan, Preset};
    let set = [("decoding.noise_factor", "5")];
    let preset = Preset::PaperEfsm2.plan_with(set).unwrap();
    let expected = apply_method_settings(&MethodPlan::Fsm(Preset::PaperEfsm2.plan()), set);
    assert_eq!(preset, expected.unwrap());
    let method = MethodKind::Efsm
        .plan_with(1024, 32, GroupCount::One, set)
        .unwrap();
    let start = MethodKind::Efsm.plan(1024, 32, GroupCount::One);
    assert_eq!(method, apply_method_settings(&start, set).unwrap());

    let e = Preset::PaperBfsm
        .plan_with([("band.cuont", "3")])
        .unwrap_err();
    let e = e.to_string();
    assert!(e.starts_with("preset paper-bfsm: --set band.cuont"), "{e}");
    let e = MethodKind::LineScan.plan_with(1024, 64, GroupCount::Two, [("nope", "1")]);
    let e = e.unwrap_err().to_string();
    assert!(
        e.starts_with("--method line-scan --projector-columns 1024: --set nope"),
        "{e}"
    );
}

#[test]
fn a_setting_is_key_equals_value() {
    use fsm_io::plan_file::parse_setting;
    let pair = |k: &str, v: &str| (k.to_owned(), v.to_owned());
    assert_eq!(
        parse_setting(" band.count = 512 "),
        Ok(pair("band.count", "512"))
    );
    assert_eq!(parse_setting("a=b=c"), Ok(pair("a", "b=c")));
    assert_eq!(
        parse_setting("band.count"),
        Err("expected KEY=VALUE".to_owned())
    );
}
