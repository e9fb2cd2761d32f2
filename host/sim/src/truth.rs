//! Ground truth of a simulated capture, per camera pixel.

/// What the centre ray of a pixel meets first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SurfaceClass {
    /// Nothing (the ray leaves the scene).
    Background,
    /// A diffuse surface: the pixel measures it.
    Diffuse,
    /// A glossy (rough metal) surface: the pixel measures it, through its BRDF.
    Glossy,
    /// A mirror's front: the pixel sees other surfaces through it, never its own point.
    Mirror,
    /// A black surface or a mirror's back.
    Black,
}

/// Truth of one pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelTruth {
    /// First surface point on the pixel centre's ray, camera frame, mm (`NaN`s on background).
    pub point_mm: [f64; 3],
    /// Index of that surface in the scene.
    pub surface: Option<u16>,
    /// Its kind.
    pub class: SurfaceClass,
    /// The direct column (SPEC §7): projector column coordinate of the point seen at the pixel
    /// centre, when the projector lights that point directly; `NaN` otherwise (shadow,
    /// mirror, background, outside the projector's image).
    pub direct_column: f64,
    /// Direct light over the pixel's footprint under a full-on frame, reference whites.
    pub direct: f32,
    /// Indirect light (through mirrors, interreflection off diffuse or glossy surfaces) under a
    /// full-on frame, reference whites.
    pub indirect: f32,
    /// The footprint is not uniform: it straddles surfaces, the background or a shadow edge,
    /// so its light mixes more than the neighbourhood of one column.
    pub edge: bool,
}

impl PixelTruth {
    /// The projector lights the pixel's point directly, and its footprint is uniform (not an
    /// edge): a pixel that should get a right point.
    pub fn is_lit_directly(&self) -> bool {
        self.direct_column.is_finite() && !self.edge
    }

    /// Pixels with direct light whose indirect light exceeds `ratio ×` the direct light.
    pub fn has_interreflection(&self, ratio: f32) -> bool {
        self.direct > 0.0 && self.indirect > ratio * self.direct
    }

    /// The interreflection pixels: indirect light above 20% of the direct light.
    pub fn is_interreflection(&self) -> bool {
        self.has_interreflection(INTERREFLECTION_RATIO)
    }

    /// Lit only directly: direct light and no indirect light at all.
    pub fn is_direct_only(&self) -> bool {
        self.direct > 0.0 && self.indirect == 0.0
    }

    /// Depth (camera `z`), mm.
    pub fn depth_mm(&self) -> f64 {
        self.point_mm[2]
    }
}

/// Indirect / direct ratio above which a pixel is an interreflection pixel.
pub const INTERREFLECTION_RATIO: f32 = 0.2;

/// Ground truth of the rows a transport covers.
#[derive(Clone, Debug)]
pub struct GroundTruth {
    pub(crate) width: u32,
    pub(crate) first_row: u32,
    pub(crate) pixels: Vec<PixelTruth>,
}

impl GroundTruth {
    /// Image width.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Rows covered: `first_row..first_row + rows`.
    pub fn rows(&self) -> std::ops::Range<u32> {
        let rows = (self.pixels.len() / self.width as usize) as u32;
        self.first_row..self.first_row + rows
    }

    /// Truth of pixel `(x, y)`, if covered.
    pub fn pixel(&self, x: u32, y: u32) -> Option<&PixelTruth> {
        if x >= self.width || !self.rows().contains(&y) {
            return None;
        }
        self.pixels
            .get(((y - self.first_row) * self.width + x) as usize)
    }

    /// Every covered pixel with its coordinates.
    pub fn iter(&self) -> impl Iterator<Item = (u32, u32, &PixelTruth)> + '_ {
        self.pixels.iter().enumerate().map(|(i, p)| {
            let i = i as u32;
            (i % self.width, self.first_row + i / self.width, p)
        })
    }

    /// The interreflection mask (row-major over the covered rows).
    pub fn interreflection_mask(&self) -> Vec<bool> {
        self.pixels.iter().map(|p| p.is_interreflection()).collect()
    }
}
