//! Link arguments for the bare-metal target only.
//!
//! On `target_os = "none"` the firmware binary is linked with our own `link.x` (Zynq-7000 DDR
//! layout, see that file) and, with the `defmt` feature, with defmt's `defmt.x` (which the
//! defmt crate's own build script writes into its OUT_DIR and adds to the search path).
//! On the host nothing is added: the crate is an ordinary lib + bin there.
use std::env;
use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=link.x");

    if env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("none") {
        return;
    }
    let dir = PathBuf::from(env::var("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR"));
    // Copy link.x into OUT_DIR so that only it (not the whole crate dir) is on the search path.
    let out = PathBuf::from(env::var("OUT_DIR").expect("OUT_DIR"));
    std::fs::copy(dir.join("link.x"), out.join("link.x")).expect("copy link.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    if env::var_os("CARGO_FEATURE_DEFMT").is_some() {
        println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    }
}
