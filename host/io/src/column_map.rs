//! The column map: each camera pixel's strongest candidate column (NaN where a pixel has
//! none), as a 32-bit float TIFF for programs and a colour PNG preview for people.

use std::path::Path;

use fsm_core::PixelCandidates;

use crate::error::{Error, Result};
use crate::image_files;
use crate::map_picture::{write_map_png, Palette, Scale};
use crate::outputs::StagedFile;

/// File name of the float map in `fsm decode`'s output folder.
pub const COLUMN_TIFF_NAME: &str = "column.tiff";
/// File name of the preview.
pub const COLUMN_PREVIEW_NAME: &str = "column.png";

/// Strongest-candidate column of every pixel, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct ColumnMap {
    width: u32,
    height: u32,
    columns: Vec<f32>,
}

impl ColumnMap {
    /// A map of NaN (no candidate anywhere yet).
    pub fn new(width: u32, height: u32) -> Self {
        ColumnMap {
            width,
            height,
            columns: vec![f32::NAN; width as usize * height as usize],
        }
    }

    /// Pixels per row.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Rows.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Row-major columns.
    pub fn columns(&self) -> &[f32] {
        &self.columns
    }

    /// Column of pixel `(x, y)`.
    pub fn at(&self, x: u32, y: u32) -> f32 {
        self.columns[y as usize * self.width as usize + x as usize]
    }

    /// Sets row `y` from the strongest candidates of its pixels.
    pub fn set_row<const K: usize>(&mut self, y: u32, pixels: &[PixelCandidates<K>]) {
        let w = self.width as usize;
        let row = &mut self.columns[y as usize * w..(y as usize + 1) * w];
        for (c, p) in row.iter_mut().zip(pixels) {
            *c = p.strongest().map_or(f32::NAN, |s| s.column);
        }
    }

    /// Sets row `y` from already extracted columns.
    pub fn set_row_columns(&mut self, y: u32, columns: &[f32]) {
        let w = self.width as usize;
        self.columns[y as usize * w..(y as usize + 1) * w].copy_from_slice(columns);
    }

    /// Writes the map as a 32-bit float grey TIFF, whole or not at all.
    pub fn write_tiff(&self, path: &Path) -> Result<()> {
        let mut file = StagedFile::create(path)?;
        image_files::write_tiff_f32(file.writer(), self.width, self.height, &self.columns)
            .map_err(|e| Error::Encode {
                path: path.to_path_buf(),
                message: e.0,
            })?;
        file.commit()
    }

    /// Writes the colour preview PNG with its colour bar (projector columns), whole or not
    /// at all.
    pub fn write_preview(&self, path: &Path, projector_columns: u16) -> Result<()> {
        let scale = Scale {
            low: 0.0,
            high: (projector_columns.max(2) - 1) as f32,
            unit: "column",
            palette: Palette::Viridis,
        };
        write_map_png(path, &self.columns, self.width, self.height, &scale)
    }
}
