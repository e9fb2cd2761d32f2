//! # fsm-sim: a light-transport simulator of a calibrated camera–projector pair
//!
//! Renders the captures of any pattern sequence — every FSM [`fsm_core::ScanPlan`], through its
//! one pattern function — with ground truth, and models the interreflections the Frequency
//! Shift Method exists for: a planar mirror (the exact virtual-projector construction) and
//! one-bounce interreflection between diffuse or glossy-metal facets (integrated numerically;
//! the metal's Cook–Torrance BRDF: [`scene::brdf`]).
//!
//! | concept | module |
//! |---|---|
//! | the scanner: calibration (SPEC §5), projector blur, gamma, reference white | [`system`] |
//! | scenes: surfaces, materials (the glossy metal's BRDF), presets | [`scene`] |
//! | irradiance of a pinhole projector, the blurred column profile | [`radiometry`] |
//! | per pixel: sparse (column, weight) light transport, computed once per scene | [`transport`] |
//! | ground truth: 3D point, direct column (SPEC §7), interreflection mask | [`truth`] |
//! | what the projector shows | [`PatternSequence`] (fsm-core's trait, re-exported) |
//! | frames → sensor codes, row by row; row dumps | [`capture`], [`sensor`] |
//! | calibration targets: a printed board at a pose, its true corners | [`target`] |
//! | what `fsm simulate` writes: plan, calibration, captures, truth images, board poses | [`folder`] |
//! | the paper's comparison (`fsm demo`): simulate, decode, select, score against the truth | [`comparison`] |
//!
//! ## Why a pixel's light is a short list of columns
//!
//! Patterns vary along projector columns only, so a pixel's signal under any frame is
//! `ambient + Σ_j w_j·P(j)`. The simulator computes the weights `w_j` once per scene, then
//! renders each frame as that sparse dot product and passes it through the sensor (shot and
//! read noise with a seed, gain, black level, quantisation, saturation).
//!
//! ## The true column, and why the projector must be blurred
//!
//! The ground truth's direct column is the projector column coordinate of the point seen at
//! the pixel centre (SPEC §7). A real projector is slightly defocused, so its image varies
//! continuously across column borders; the simulator blurs the emitted image with a Gaussian of
//! σ = 0.7 column by default ([`System::blur_sigma_columns`]). With σ = 0 a pixel that lies
//! inside one column sees that column's value wherever it lies in it, so *any* decoder (FSM or
//! phase shift) is off the geometric truth by up to ±0.5 column; judge accuracy with the
//! default blur.
//!
//! ```no_run
//! use fsm_core::ScanPlan;
//! use fsm_sim::{simulate, Scene, Sensor, System};
//!
//! let plan = ScanPlan::paper_bfsm();
//! let scene = Scene::preset("plane_mirror").unwrap();
//! let capture = simulate(&plan, &scene, &System::bench(), &Sensor::default(), 7).unwrap();
//! let row = capture.row(120).unwrap(); // frames[i·W + x], for Decoder::decode_row
//! let truth = capture.ground_truth().pixel(160, 120).unwrap();
//! # let _ = (row, truth);
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod capture;
pub mod comparison;
pub mod error;
pub mod folder;
pub mod radiometry;
pub mod scene;
pub mod sensor;
pub mod system;
pub mod target;
pub mod transport;
pub mod truth;

use std::sync::Arc;

use fsm_io::progress::Progress;

pub use capture::Capture;
pub use error::SimError;
pub use fsm_core::PatternSequence;
pub use scene::{Material, Scene, Shape, Surface};
pub use sensor::Sensor;
pub use system::System;
pub use transport::{LightTransport, PathKind, SpanView, TransportSettings};
pub use truth::{GroundTruth, PixelTruth, SurfaceClass};

impl Scene {
    /// A preset by name, or an error that lists the presets.
    pub fn by_name(name: &str) -> Result<Scene, SimError> {
        Scene::preset(name).ok_or_else(|| SimError::UnknownScene(name.into()))
    }
}

/// Simulates the capture of `patterns` (e.g. a [`fsm_core::ScanPlan`]) of `scene` by `system`
/// with `sensor`, noise seeded by `seed`: computes the scene's light transport (default
/// settings) and returns a capture that renders rows on demand. To capture several plans of
/// one scene, compute the [`LightTransport`] once and build each [`Capture`] from it.
pub fn simulate(
    patterns: &(impl PatternSequence + ?Sized),
    scene: &Scene,
    system: &System,
    sensor: &Sensor,
    seed: u64,
) -> Result<Capture, SimError> {
    simulate_with(
        patterns,
        scene,
        system,
        sensor,
        seed,
        &TransportSettings::default(),
        &Progress::hidden(),
    )
}

/// [`simulate`] with the light transport's `settings` (e.g. more rays per pixel), its rows
/// reported to `progress` ([`LightTransport::compute_rows_reporting`]).
pub fn simulate_with(
    patterns: &(impl PatternSequence + ?Sized),
    scene: &Scene,
    system: &System,
    sensor: &Sensor,
    seed: u64,
    settings: &TransportSettings,
    progress: &Progress,
) -> Result<Capture, SimError> {
    let rows = 0..system.height();
    let transport =
        LightTransport::compute_rows_reporting(scene, system, settings, rows, progress)?;
    Capture::new(Arc::new(transport), patterns, system, *sensor, seed)
}
