//! Build proof that `fsm-core` is `no_std`: std defines the `panic_impl` lang item, so if any
//! dependency linked std this crate's own `#[panic_handler]` would be a duplicate and the build
//! would fail. CI builds it on its own, so that feature unification with host crates cannot
//! hide a leak:
//!
//! ```sh
//! cargo rustc --manifest-path core/no-std-proof/Cargo.toml --release -- \
//!     -C panic=abort -C link-arg=-nostartfiles
//! ```
#![no_std]
#![no_main]

use core::panic::PanicInfo;

#[panic_handler]
fn panic(_: &PanicInfo) -> ! {
    loop {}
}

/// The host's precompiled `core` is built for unwinding and names this symbol; the binary is
/// only linked, never run, so an empty one completes the link.
#[no_mangle]
pub extern "C" fn rust_eh_personality() {}

/// The decoder's copies and fills call the C library's `memcpy`, `memmove` and `memset`, which a
/// bare binary does not link (the firmware takes them from `compiler_builtins`' `mem` feature).
/// The binary is only linked, never run, so stubs complete the link, as above.
#[no_mangle]
pub extern "C" fn memcpy(dest: *mut u8, _src: *const u8, _n: usize) -> *mut u8 {
    dest
}

/// See [`memcpy`].
#[no_mangle]
pub extern "C" fn memmove(dest: *mut u8, _src: *const u8, _n: usize) -> *mut u8 {
    dest
}

/// See [`memcpy`].
#[no_mangle]
pub extern "C" fn memset(dest: *mut u8, _c: i32, _n: usize) -> *mut u8 {
    dest
}

/// Touches the decoder so it is compiled into this binary, not just type-checked.
#[no_mangle]
pub extern "C" fn fsm_core_no_std_proof(tables: &mut [f32; 4096]) -> usize {
    let plan = fsm_core::ScanPlan::paper_efsm(fsm_core::GroupCount::Two);
    match fsm_core::Decoder::new(&plan, tables) {
        Ok(d) => d.plan().sequence_len(),
        Err(_) => 0,
    }
}

/// Touches every method's plan bytes and row decoder (`fsm_core::methods`), likewise.
#[no_mangle]
pub extern "C" fn fsm_core_methods_no_std_proof(
    bytes: &[u8; 96],
    tables: &mut [f32; 4096],
) -> usize {
    match fsm_core::MethodPlan::from_bytes(bytes) {
        Ok(plan) => match fsm_core::MethodDecoder::new(&plan, tables) {
            Ok(d) => d.plan().to_bytes().len(),
            Err(_) => 1,
        },
        Err(_) => 0,
    }
}
