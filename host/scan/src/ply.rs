//! `points.ply`: binary little-endian PLY that MeshLab, CloudCompare and Open3D open.
//!
//! One vertex per pixel with a point: `float x, y, z` (camera frame, mm), `float intensity`
//! (the direct illumination, sensor DN), `float quality` (the light's signal-to-noise ratio,
//! NaN where the method has none), `ushort pixel_x, pixel_y`.

use std::io::{self, Write};

/// One point of the cloud.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlyPoint {
    /// Camera frame, millimetres.
    pub point_mm: [f32; 3],
    /// Direct illumination, sensor DN.
    pub intensity: f32,
    /// The point's quality ([`crate::Surface::quality`]).
    pub quality: f32,
    /// The camera pixel it was measured at.
    pub pixel: [u16; 2],
}

/// Writes the PLY file of `points` to `out`.
pub fn write_ply(mut out: impl Write, points: &[PlyPoint]) -> io::Result<()> {
    write!(
        out,
        "ply\nformat binary_little_endian 1.0\ncomment fsm scan: camera frame, millimetres\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         property float intensity\nproperty float quality\nproperty ushort pixel_x\nproperty ushort pixel_y\n\
         end_header\n",
        points.len()
    )?;
    for p in points {
        for v in p.point_mm {
            out.write_all(&v.to_le_bytes())?;
        }
        out.write_all(&p.intensity.to_le_bytes())?;
        out.write_all(&p.quality.to_le_bytes())?;
        out.write_all(&p.pixel[0].to_le_bytes())?;
        out.write_all(&p.pixel[1].to_le_bytes())?;
    }
    out.flush()
}
