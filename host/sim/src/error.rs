//! Errors of the simulator.

use std::fmt;
use std::ops::Range;

/// Why a simulation could not be made or written.
#[derive(Debug)]
pub enum SimError {
    /// No preset of that name.
    UnknownScene(String),
    /// The system's optics break a rule.
    System(String),
    /// The sensor breaks a rule.
    Sensor(String),
    /// A setting breaks a rule.
    Settings(String),
    /// Rows outside the image or not computed.
    Rows {
        /// Rows asked for.
        rows: Range<u32>,
        /// Image height.
        height: u32,
    },
    /// The pattern sequence and the projector disagree on the number of columns.
    ProjectorColumns {
        /// The plan's `cmax`.
        plan: u32,
        /// The projector's.
        system: u32,
    },
    /// A buffer of the wrong length.
    BufferLength {
        /// Samples needed (`M × W`).
        expected: usize,
        /// Samples given.
        actual: usize,
    },
    /// A whole-image output asked of a capture of some rows only.
    PartialCapture {
        /// Rows the capture has.
        rows: Range<u32>,
        /// Image height.
        height: u32,
    },
    /// Encoding a row record failed.
    Wire(fsm_core::wire::WireError),
    /// Writing failed.
    Io(std::io::Error),
    /// Writing a file failed.
    File {
        /// The file.
        path: String,
        /// Why.
        source: Box<SimError>,
    },
}

impl fmt::Display for SimError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SimError::UnknownScene(name) => write!(
                f,
                "unknown scene {name:?}; presets: {}",
                crate::scene::presets::NAMES.join(", ")
            ),
            SimError::System(e) | SimError::Sensor(e) | SimError::Settings(e) => {
                write!(f, "{e}")
            }
            SimError::Rows { rows, height } => write!(
                f,
                "rows {}..{} are not available (image height {height}, or not computed)",
                rows.start, rows.end
            ),
            SimError::ProjectorColumns { plan, system } => write!(
                f,
                "the plan addresses {plan} projector columns, the simulated projector has {system}"
            ),
            SimError::BufferLength { expected, actual } => {
                write!(f, "row buffer holds {actual} samples, {expected} needed")
            }
            SimError::PartialCapture { rows, height } => write!(
                f,
                "the capture covers rows {}..{} of {height}: a row dump needs every row",
                rows.start, rows.end
            ),
            SimError::Wire(e) => write!(f, "{e}"),
            SimError::Io(e) => write!(f, "{e}"),
            SimError::File { path, source } => write!(f, "{path}: {source}"),
        }
    }
}

impl std::error::Error for SimError {}

/// A simulation's error as the host's, for the writers and the comparison that go through
/// `fsm_io` (the message says it came from the simulation).
impl From<SimError> for fsm_io::Error {
    fn from(e: SimError) -> fsm_io::Error {
        fsm_io::Error::Usage(format!("simulation: {e}"))
    }
}
