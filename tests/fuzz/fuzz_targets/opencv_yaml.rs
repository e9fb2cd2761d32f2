//! OpenCV FileStorage YAML (`%YAML:1.0`): the text is parsed and, when it parses, imported for
//! every tool. A syntax error names a line inside the text; an import that succeeds exports
//! (as YAML) to text that imports again to the same calibration.
#![no_main]

use fsm_geometry::opencv::Syntax;
use libfuzzer_sys::fuzz_target;

#[path = "../support/filestorage.rs"]
mod filestorage;

fuzz_target!(|data: &[u8]| {
    filestorage::check(data, Syntax::Yaml, "%YAML:1.0\n");
});
