//! The calibration target: a planar checkerboard, its inner corners in the board frame, and its
//! definition file.
//!
//! ## The board and its frame
//!
//! A checkerboard of `(inner_columns + 1) × (inner_rows + 1)` squares of side `square_mm` has
//! `inner_columns × inner_rows` *inner corners* (the points where four squares meet); only those
//! are measured. The board frame has its origin at inner corner (0, 0), `+x` along a row of
//! corners, `+y` down the rows, `z = 0` on the printed face (so `+z = x × y` points into the
//! board, away from a camera that sees its face the right way round). Corner `(column, row)` is
//! at `(column·square_mm, row·square_mm, 0)`; lists of corners are row-major,
//! `index = row · inner_columns + column`.
//!
//! **Colours.** The square diagonally outside corner (0, 0) — the one covering
//! `x, y ∈ [−square_mm, 0]` — is **dark**; squares alternate from there, so the square between
//! corners `(c, r)` and `(c + 1, r + 1)` is dark when `c + r` is even. The corner detector
//! ([`crate::corners`]) uses this to tell the board's corner (0, 0) from its opposite corner,
//! which it can whenever `inner_columns + inner_rows` is odd (e.g. 9 × 6); see
//! [`crate::corners`] for the rule when it is not.
//!
//! ## The target definition file (TOML, version 1)
//!
//! ```toml
//! format = "fsm-checkerboard"   # required: what the file is
//! version = 1                   # required: the version of this layout
//! inner_columns = 9             # inner corners along a row (squares along a row − 1), ≥ 2
//! inner_rows = 6                # inner corners down a column (squares down a column − 1), ≥ 2
//! square_mm = 20.0              # side of a square as printed (measure it), mm, > 0
//! ```
//!
//! Comments are allowed; any other key is an error (a misspelt key is never silently ignored).
//! Errors name the file and the key, e.g.
//! `target file calibration/targets/x.toml: square_mm = -20: must be a finite number above 0 mm`.
//! The default targets are in `calibration/targets/`.

use std::fmt;
use std::path::Path;

use nalgebra::Point2;

/// The `format` key of every target definition file.
pub const FORMAT: &str = "fsm-checkerboard";
/// The version this build writes and reads.
pub const VERSION: u32 = 1;

/// A planar checkerboard target (see the [module documentation](self) for its frame and colours).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Checkerboard {
    /// Inner corners along a row (`+x`): squares along a row − 1.
    pub inner_columns: u32,
    /// Inner corners down a column (`+y`): squares down a column − 1.
    pub inner_rows: u32,
    /// Side of a square, mm.
    pub square_mm: f64,
}

/// What is wrong with a target definition; the message names the file.
#[derive(Debug)]
pub struct BoardError {
    /// The file (or the caller's label for a string).
    pub source: String,
    /// What is wrong.
    pub kind: BoardErrorKind,
}

/// The host's commands report it as it is (it names the file and the key).
impl From<BoardError> for fsm_io::Error {
    fn from(e: BoardError) -> Self {
        fsm_io::Error::Usage(e.to_string())
    }
}

/// The kinds of [`BoardError`].
#[derive(Debug)]
pub enum BoardErrorKind {
    /// Reading the file failed.
    Io(std::io::Error),
    /// Not UTF-8 or not TOML (the message has the line).
    Syntax(String),
    /// `format` is missing or is not `"fsm-checkerboard"`.
    Format(Option<String>),
    /// `version` is missing, not an integer, or a version this build does not read.
    Version(Option<i64>),
    /// A required key is missing.
    Missing(&'static str),
    /// A key this version does not have.
    Unknown(String),
    /// A key has a value of the wrong type or out of range.
    Field {
        /// The key.
        key: &'static str,
        /// The value as written.
        value: String,
        /// The rule it breaks.
        rule: &'static str,
    },
}

impl fmt::Display for BoardError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "target file {}: ", self.source)?;
        match &self.kind {
            BoardErrorKind::Io(e) => write!(f, "{e}"),
            BoardErrorKind::Syntax(e) => write!(f, "{}", e.trim_end()),
            BoardErrorKind::Format(None) => {
                write!(f, "key `format` is missing: not an {FORMAT} file")
            }
            BoardErrorKind::Format(Some(found)) => {
                write!(f, "format = {found}: expected {FORMAT:?}")
            }
            BoardErrorKind::Version(None) => write!(f, "key `version` is missing or not an integer"),
            BoardErrorKind::Version(Some(v)) => {
                write!(f, "version = {v}: this build reads version {VERSION}")
            }
            BoardErrorKind::Missing(key) => write!(f, "key `{key}` is missing"),
            BoardErrorKind::Unknown(key) => write!(
                f,
                "unknown key `{key}` (version {VERSION} has format, version, inner_columns, inner_rows, square_mm)"
            ),
            BoardErrorKind::Field { key, value, rule } => write!(f, "{key} = {value}: {rule}"),
        }
    }
}

impl std::error::Error for BoardError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match &self.kind {
            BoardErrorKind::Io(e) => Some(e),
            _ => None,
        }
    }
}

const KEYS: [&str; 5] = [
    "format",
    "version",
    "inner_columns",
    "inner_rows",
    "square_mm",
];

impl Checkerboard {
    /// Inner corners in the board frame (the `z = 0` plane), mm, row-major:
    /// `index = row · inner_columns + column`; corner (0, 0) at the origin, `+x` along a row,
    /// `+y` down the rows.
    pub fn corners_mm(&self) -> Vec<Point2<f64>> {
        let mut out = Vec::with_capacity(self.corner_count());
        for row in 0..self.inner_rows {
            for column in 0..self.inner_columns {
                out.push(Point2::new(
                    column as f64 * self.square_mm,
                    row as f64 * self.square_mm,
                ));
            }
        }
        out
    }

    /// The board whose [`Checkerboard::corners_mm`] is `corners_mm` (to 1e-9 of a square),
    /// `None` when the list is not a row-major corner grid of at least 2 × 2.
    pub fn from_corners_mm(corners_mm: &[Point2<f64>]) -> Option<Checkerboard> {
        if corners_mm.len() < 4 || corners_mm[0] != Point2::origin() {
            return None;
        }
        let s = corners_mm[1].x;
        if !(s.is_finite() && s > 0.0) {
            return None;
        }
        let columns = corners_mm
            .iter()
            .position(|p| p.y != 0.0)
            .unwrap_or(corners_mm.len());
        if columns < 2
            || !corners_mm.len().is_multiple_of(columns)
            || corners_mm.len() / columns < 2
        {
            return None;
        }
        let rows = corners_mm.len() / columns;
        let tol = 1e-9 * s * (columns + rows) as f64;
        let regular = corners_mm.iter().enumerate().all(|(i, p)| {
            let (c, r) = ((i % columns) as f64, (i / columns) as f64);
            (p.x - c * s).abs() <= tol && (p.y - r * s).abs() <= tol
        });
        regular.then_some(Checkerboard {
            inner_columns: u32::try_from(columns).ok()?,
            inner_rows: u32::try_from(rows).ok()?,
            square_mm: s,
        })
    }

    /// Number of inner corners, `inner_columns · inner_rows`.
    pub fn corner_count(&self) -> usize {
        self.inner_columns as usize * self.inner_rows as usize
    }

    /// Whether the square between corners `(column, row)` and `(column + 1, row + 1)` is dark
    /// (`column`, `row` may be −1 or the last index for the squares along the border).
    pub fn square_is_dark(column: i64, row: i64) -> bool {
        (column + row).rem_euclid(2) == 0
    }

    /// Checks the board's numbers: at least 2 × 2 inner corners, a finite square above 0 mm.
    /// The error is `(key, rule)`.
    pub fn validate(&self) -> Result<(), (&'static str, &'static str)> {
        if self.inner_columns < 2 {
            return Err((
                "inner_columns",
                "a board needs at least 2 inner corners along a row",
            ));
        }
        if self.inner_rows < 2 {
            return Err((
                "inner_rows",
                "a board needs at least 2 inner corners down a column",
            ));
        }
        if self.inner_columns > 1000 || self.inner_rows > 1000 {
            return Err((
                if self.inner_columns > 1000 {
                    "inner_columns"
                } else {
                    "inner_rows"
                },
                "at most 1000 inner corners per side",
            ));
        }
        if !(self.square_mm.is_finite() && self.square_mm > 0.0) {
            return Err(("square_mm", "must be a finite number above 0 mm"));
        }
        Ok(())
    }

    /// Reads a target definition file (see the [module documentation](self)).
    pub fn read(path: &Path) -> Result<Checkerboard, BoardError> {
        let source = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|e| BoardError {
            source: source.clone(),
            kind: BoardErrorKind::Io(e),
        })?;
        Checkerboard::from_bytes(&bytes, &source)
    }

    /// Parses and validates the bytes of a target definition (UTF-8 TOML), as [`Self::read`]
    /// does a file's; `source` names it in errors.
    pub fn from_bytes(bytes: &[u8], source: &str) -> Result<Checkerboard, BoardError> {
        let text = std::str::from_utf8(bytes).map_err(|e| BoardError {
            source: source.to_string(),
            kind: BoardErrorKind::Syntax(format!(
                "not UTF-8 text (invalid byte at offset {})",
                e.valid_up_to()
            )),
        })?;
        Checkerboard::from_toml(text, source)
    }

    /// Parses and validates the text of a target definition; `source` names it in errors.
    pub fn from_toml(text: &str, source: &str) -> Result<Checkerboard, BoardError> {
        let err = |kind| BoardError {
            source: source.to_string(),
            kind,
        };
        let table: toml::Table =
            toml::from_str(text).map_err(|e| err(BoardErrorKind::Syntax(e.to_string())))?;
        match table.get("format") {
            Some(toml::Value::String(s)) if s == FORMAT => {}
            Some(other) => return Err(err(BoardErrorKind::Format(Some(other.to_string())))),
            None => return Err(err(BoardErrorKind::Format(None))),
        }
        match table.get("version") {
            Some(toml::Value::Integer(v)) if *v == VERSION as i64 => {}
            Some(toml::Value::Integer(v)) => return Err(err(BoardErrorKind::Version(Some(*v)))),
            _ => return Err(err(BoardErrorKind::Version(None))),
        }
        if let Some(key) = table.keys().find(|k| !KEYS.contains(&k.as_str())) {
            return Err(err(BoardErrorKind::Unknown(key.clone())));
        }
        let count = |key: &'static str| -> Result<u32, BoardError> {
            match table.get(key) {
                None => Err(err(BoardErrorKind::Missing(key))),
                Some(toml::Value::Integer(v)) if (2..=1000).contains(v) => Ok(*v as u32),
                Some(v) => Err(err(BoardErrorKind::Field {
                    key,
                    value: v.to_string(),
                    rule: "must be an integer from 2 to 1000",
                })),
            }
        };
        let inner_columns = count("inner_columns")?;
        let inner_rows = count("inner_rows")?;
        let square_mm = match table.get("square_mm") {
            None => return Err(err(BoardErrorKind::Missing("square_mm"))),
            Some(toml::Value::Float(v)) => *v,
            Some(toml::Value::Integer(v)) => *v as f64,
            Some(v) => {
                return Err(err(BoardErrorKind::Field {
                    key: "square_mm",
                    value: v.to_string(),
                    rule: "must be a number (mm)",
                }))
            }
        };
        let board = Checkerboard {
            inner_columns,
            inner_rows,
            square_mm,
        };
        board.validate().map_err(|(key, rule)| {
            err(BoardErrorKind::Field {
                key,
                value: table.get(key).map_or_else(String::new, |v| v.to_string()),
                rule,
            })
        })?;
        Ok(board)
    }

    /// The target definition file of this board (read back by [`Checkerboard::from_toml`]).
    pub fn to_toml(&self) -> String {
        // `{:?}` of an f64 always has a decimal point or an exponent: a TOML float that reads
        // back to the same number.
        format!(
            "# Checkerboard calibration target (fsm-calibrate, board.rs): {} x {} squares.\n\
             format = \"{FORMAT}\"\n\
             version = {VERSION}\n\
             # Inner corners (where four squares meet) along a row and down a column.\n\
             inner_columns = {}\n\
             inner_rows = {}\n\
             # Side of a square as printed, mm.\n\
             square_mm = {:?}\n",
            self.inner_columns + 1,
            self.inner_rows + 1,
            self.inner_columns,
            self.inner_rows,
            self.square_mm
        )
    }
}
