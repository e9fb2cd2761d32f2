//! The digest of the build under test (the workspace's test profile) is the one stored in
//! `digest.expected`; CI checks the release build's against the same file.

use std::process::Command;

#[test]
fn the_digest_is_the_one_stored_in_the_repository() {
    let output = Command::new(env!("CARGO_BIN_EXE_digest"))
        .output()
        .expect("the digest runs");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let printed = String::from_utf8(output.stdout).expect("UTF-8");
    assert!(
        printed == include_str!("../digest.expected"),
        "the decoder's output changed: if on purpose, update core/digest/digest.expected \
         (cargo run -q -p fsm-digest > core/digest/digest.expected) and say why\n{printed}"
    );
}
