//! Plan files of every method (FSM and the baselines): the text is parsed as every syntax
//! (TOML and JSON). Errors have a message; a plan that parses is valid and renders, in either
//! syntax, to text that parses back to it.
#![no_main]

use fsm_io::plan_file::{parse_method_plan, render_method_plan, MethodPlanText, PlanSyntax};
use libfuzzer_sys::fuzz_target;

const SYNTAXES: [PlanSyntax; 2] = [PlanSyntax::Toml, PlanSyntax::Json];

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    for syntax in SYNTAXES {
        match parse_method_plan(text, syntax) {
            Ok(plan) => {
                plan.validate().expect("a parsed plan is valid");
                for out in SYNTAXES {
                    let rendered = render_method_plan(&plan, out);
                    let back = parse_method_plan(&rendered, out).unwrap_or_else(|e| {
                        panic!("rendered {out:?} plan does not parse: {e}\n{rendered}")
                    });
                    assert_eq!(back, plan, "{syntax:?} -> {out:?}");
                }
            }
            Err(e) => assert!(!e.to_string().trim().is_empty(), "empty error"),
        }
    }
});
