//! Grey-level manifests (`levels.json`, JSON). Errors have a message; a manifest that parses
//! has at least 3 levels running from 0 to 1 and writes back to JSON that parses to it.
#![no_main]

use fsm_io::projector_response::GreyLevelManifest;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match GreyLevelManifest::parse(text) {
        Ok(m) => {
            let f = m.fractions();
            assert!(
                f.len() >= 3 && f[0] == 0.0 && f[f.len() - 1] == 1.0,
                "{f:?}"
            );
            assert!(f.windows(2).all(|w| w[0] < w[1]), "{f:?}");
            let json = serde_json::to_string_pretty(&m).expect("a manifest serialises");
            let back = GreyLevelManifest::parse(&json)
                .unwrap_or_else(|e| panic!("written manifest does not parse: {e}\n{json}"));
            assert_eq!(back, m);
        }
        Err(e) => assert!(!e.trim().is_empty(), "empty error"),
    }
});
