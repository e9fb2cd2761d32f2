//! Projector response files (TOML: a gamma or a measured table). Errors have a message; a
//! response that parses is usable (its inverse is finite, in 0..=1 and monotone) and writes
//! back, with any comment, to text that parses to the same response.
#![no_main]

use fsm_io::projector_response::ProjectorResponse;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let response = match ProjectorResponse::parse(text) {
        Ok(r) => r,
        Err(e) => {
            assert!(!e.trim().is_empty(), "empty error");
            return;
        }
    };
    let mut previous = 0.0;
    for i in 0..=16 {
        let light = i as f64 / 16.0;
        let code = response.code_for(light);
        assert!(
            code.is_finite() && (0.0..=1.0).contains(&code) && code >= previous,
            "{response:?}: code_for({light}) = {code} (previous {previous})"
        );
        previous = code;
        let back = response.light_for(code);
        assert!(back.is_finite(), "{response:?}: light_for({code}) = {back}");
    }
    // The comment is the first line of the input: anything may be in it.
    let comment = text.lines().next().unwrap_or("");
    let written = response.to_file_text(comment);
    let back = ProjectorResponse::parse(&written)
        .unwrap_or_else(|e| panic!("written response does not parse: {e}\n{written}"));
    assert_eq!(back, response);
});
