//! # fsm-protocol: host ⇄ camera messages
//!
//! The link between the host (`fsm upload`, `fsm camera`) and the camera's firmware: upload a
//! plan of any method (BFSM, EFSM or a baseline the paper compares them with) and have it
//! acknowledged by its fingerprint, start a scan, send rows, receive the
//! candidates of every row (or the raw rows, for decoding on the host), end the scan, and
//! hear about every refusal. `no_std` and allocation-free, so the camera links the very code
//! the host uses; the feature `std` adds the host's [`client`] over TCP and serial ports.
//!
//! Plans, rows and candidates travel as the bytes of `fsm_core::wire` (plan bytes of
//! `fsm_core::methods::wire`,
//! `row_dump` records, `candidates` records, each with its own CRC): a scan received over the
//! link, header + records, is byte for byte the file `fsm decode` writes for the same rows.
//!
//! ## Frames
//!
//! Every message is one frame:
//!
//! ```text
//! 0x00 ‖ COBS( version: u8 ‖ message: postcard ‖ crc: u32 LE ) ‖ 0x00
//! ```
//!
//! | part | bytes | meaning |
//! |---|---|---|
//! | version | 1 | [`PROTOCOL_VERSION`]; any other value is refused ([`FrameError::Version`]) |
//! | message | 1.. | a [`Request`] (host → camera) or a [`Response`] (camera → host), [postcard](https://docs.rs/postcard) encoding |
//! | crc | 4 | CRC-32/ISO-HDLC (`fsm_core::wire::crc32`) of version and message, little-endian |
//! | COBS, 0x00 | +1 per 254, +1 | Consistent Overhead Byte Stuffing: no zero inside a frame, a zero ends it |
//! | leading 0x00 | 1 | an empty frame (skipped): ends the remains of a truncated previous frame |
//!
//! A receiver rejects a frame as a whole when its COBS structure, length, CRC, version or
//! message does not check, or when it overruns the receive buffer (it then skips to the next
//! zero); nothing of a rejected frame is applied. The camera answers a rejected frame with
//! [`Response::Error`]`(`[`DeviceError::Frame`]`)` and keeps serving. Longest frame:
//! [`frame::max_frame_len`] of the message length.
//!
//! ## Message encoding (postcard)
//!
//! An enum is its variant's tag (varint) followed by its fields in order; `u8` is one byte;
//! `u16`, `u32`, `u64` are varints (LEB128, 7 bits per byte, least significant first);
//! `bytes` and `str` are a varint length then the bytes; `Option<T>` is `0` or `1` then `T`.
//!
//! ### Requests (host → camera); each gets exactly one response, in order
//!
//! | tag | request | fields | answer |
//! |---|---|---|---|
//! | 0 | [`Request::Hello`] | — | `Info` |
//! | 1 | [`Request::UploadPlan`] | `plan`: bytes (`MethodPlan::to_bytes`: 80 for FSM, 32 or 96 for a baseline), `fingerprint`: u64 (`MethodPlan::fingerprint`) | `PlanAccepted` |
//! | 2 | [`Request::StartScan`] | `fingerprint`: u64, `width`: u32, `height`: u32, `bit_depth`: u8, `output`: 0 candidates / 1 raw | `ScanStarted` |
//! | 3 | [`Request::Row`] | `record`: bytes (a `row_dump` record: u32 row, `W·M` u16 samples, u32 CRC) | `CandidateRow` or `RawRow` |
//! | 4 | [`Request::EndScan`] | — | `ScanEnded` |
//!
//! ### Responses (camera → host)
//!
//! | tag | response | fields |
//! |---|---|---|
//! | 0 | [`Response::Info`] | `protocol_version`: u8, `max_width`: u32, `max_row_samples`: u32, `max_table_floats`: u32, `candidate_capacity`: u16, `max_frame_len`: u32, `plan_fingerprint`: Option\<u64\> |
//! | 1 | [`Response::PlanAccepted`] | `fingerprint`: u64, computed by the camera from the bytes it received |
//! | 2 | [`Response::ScanStarted`] | `header`: bytes (64: `CandidateHeader`, or `RowDumpHeader` for raw output) |
//! | 3 | [`Response::CandidateRow`] | `record`: bytes (a `candidates` record) |
//! | 4 | [`Response::RawRow`] | `record`: bytes (a `row_dump` record) |
//! | 5 | [`Response::ScanEnded`] | `rows`: u32 answered |
//! | 6 | [`Response::Error`] | a [`DeviceError`] |
//!
//! ### Errors ([`DeviceError`], inside `Error`)
//!
//! | tag | error | fields |
//! |---|---|---|
//! | 0 | `Frame` | [`FrameError`]: 0 `TooLong` {limit u32}, 1 `Cobs`, 2 `TooShort` {len u32}, 3 `Crc` {stored u32, computed u32}, 4 `Version` {got u8, supported u8}, 5 `Message` |
//! | 1 | `State` | `request`: 0 Hello … 4 EndScan, `state`: 0 no plan, 1 idle, 2 scanning |
//! | 2 | `PlanLength` | `got`: u32 (no method's plan has that length) |
//! | 3 | `PlanInvalid` | `reason`: str (core's message, e.g. the field) |
//! | 4 | `PlanFingerprint` | `stated`: u64, `computed`: u64 |
//! | 5 | `PlanTooLarge` | `table_floats`: u32, `max`: u32 |
//! | 6 | `PlanMismatch` | `requested`: u64, `loaded`: u64 |
//! | 7 | `ScanField` | `field`: str, `value`: u32 |
//! | 8 | `ScanTooLarge` | `width`, `frames`, `max_width`, `max_row_samples`: u32 |
//! | 9 | `RowLength` | `row`: Option\<u32\>, `expected`: u32, `got`: u32 |
//! | 10 | `RowCorrupt` | `row`, `stored`, `computed`: u32 |
//! | 11 | `RowOutOfRange` | `row`, `height`: u32 |
//! | 12 | `Decode` | `row`: Option\<u32\>, `reason`: str |
//!
//! The tags are pinned by this crate's tests. A change to any table is a new
//! [`PROTOCOL_VERSION`].
//!
//! ## A session
//!
//! ```text
//! host                                   camera
//! Hello                              →
//!                                    ←   Info { limits, loaded plan }
//! UploadPlan { plan, fingerprint }   →   (recomputes the fingerprint, validates, builds tables)
//!                                    ←   PlanAccepted { fingerprint }
//! StartScan { fingerprint, W, H, … } →
//!                                    ←   ScanStarted { 64-byte candidate header }
//! Row { record y }                   →   (checks length, CRC, y < H; decodes)
//!                                    ←   CandidateRow { record y }
//! …
//! EndScan                            →
//!                                    ←   ScanEnded { rows }
//! ```
#![cfg_attr(not(any(feature = "std", test)), no_std)]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod frame;
pub mod message;

#[cfg(feature = "std")]
pub mod client;
#[cfg(feature = "std")]
pub mod transport;

pub use frame::{FrameError, FrameReader};
pub use message::{
    DeviceError, DeviceInfo, DeviceState, Request, RequestKind, Response, RowOutput, ScanSpec,
};

/// Version of this protocol, the first byte of every frame.
pub const PROTOCOL_VERSION: u8 = 1;

/// The TCP port a camera serves the protocol on: the emulator's default (`fsm-firmware serve`)
/// and the firmware's over Ethernet. The one place this number is defined.
pub const DEFAULT_TCP_PORT: u16 = 7070;
