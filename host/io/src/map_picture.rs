//! Map pictures read as measurements: the map's pixels as they are (one per camera pixel), and
//! beside them a colour bar labelled with its range and unit, so that a depth, column or light
//! picture says what its colours are worth. The range is the caller's (a robust one: the
//! percentiles of the surface, not its outliers); values outside it take the end colours.

use std::path::Path;
use std::sync::Once;

use plotters::prelude::*;
use plotters::style::colors::colormaps::{ColorMap, ViridisRGB};
use plotters::style::FontStyle;

use crate::error::{Error, Result};
use crate::image_files;
use crate::outputs::StagedFile;

/// The font every picture's text is drawn with.
pub(crate) const FONT: &str = "sans-serif";

/// plotters draws text with a registered font; DejaVu Sans is compiled in so that pictures
/// need no system fonts.
pub(crate) fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let _ = plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular());
    });
}

/// Columns of pixels the colour bar and its labels take beside the map.
pub const BAR_PANEL_PX: u32 = 110;

/// Least height of a picture, so that the bar has room for its labels.
pub const MIN_HEIGHT_PX: u32 = 140;

/// How values become colours.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Palette {
    /// Viridis, dark blue at the low end to yellow at the high end.
    Viridis,
    /// Black at the low end to white at the high end.
    Grey,
}

/// The range a picture's colours span, its unit and palette.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scale<'a> {
    /// The value of the low end.
    pub low: f32,
    /// The value of the high end (above `low`).
    pub high: f32,
    /// The values' unit, printed above the bar (`mm`, `column`, `DN`).
    pub unit: &'a str,
    /// The colours.
    pub palette: Palette,
}

impl Scale<'_> {
    /// The colour of `value` (black where it is not finite; clamped to the range).
    pub fn colour(&self, value: f32) -> [u8; 3] {
        if !value.is_finite() {
            return [0, 0, 0];
        }
        let high = self
            .high
            .max(self.low + f32::EPSILON * self.low.abs().max(1.0));
        let v = value.clamp(self.low, high);
        match self.palette {
            Palette::Viridis => {
                let c = ViridisRGB.get_color_normalized(v, self.low, high);
                [c.0, c.1, c.2]
            }
            Palette::Grey => {
                let g = (255.0 * (v - self.low) / (high - self.low)).round() as u8;
                [g, g, g]
            }
        }
    }
}

/// The label of a value: as many decimals as the range needs to tell its ticks apart.
fn label(value: f32, range: f32) -> String {
    let decimals = (2.0 - range.abs().max(1e-6).log10().floor()).clamp(0.0, 4.0) as usize;
    format!("{value:.decimals$}")
}

/// The RGB picture of `values` (`width × height`, row-major) with its colour bar on the right:
/// `(pixels, picture width, picture height)`. The map's pixels are exactly
/// [`Scale::colour`] of each value; below a map shorter than [`MIN_HEIGHT_PX`] is white.
pub fn picture(
    values: &[f32],
    width: u32,
    height: u32,
    scale: &Scale<'_>,
) -> std::result::Result<(Vec<u8>, u32, u32), String> {
    if values.len() != width as usize * height as usize {
        return Err(format!(
            "{} values for a {width}x{height} map",
            values.len()
        ));
    }
    let (pw, ph) = (width + BAR_PANEL_PX, height.max(MIN_HEIGHT_PX));
    let mut rgb = vec![255u8; pw as usize * ph as usize * 3];
    for (i, &v) in values.iter().enumerate() {
        let (x, y) = (i % width as usize, i / width as usize);
        let at = (y * pw as usize + x) * 3;
        rgb[at..at + 3].copy_from_slice(&scale.colour(v));
    }
    // The bar: 14 columns, the high end at the top.
    let (x0, top, bottom) = (width as i32 + 10, 22i32, ph as i32 - 12);
    let span = (bottom - top).max(1);
    for y in top..=bottom {
        let t = (bottom - y) as f32 / span as f32;
        let colour = scale.colour(scale.low + t * (scale.high - scale.low));
        for x in x0..x0 + 14 {
            let at = (y as usize * pw as usize + x as usize) * 3;
            rgb[at..at + 3].copy_from_slice(&colour);
        }
    }
    register_font();
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (pw, ph)).into_drawing_area();
        root.draw(&Rectangle::new(
            [(x0 - 1, top - 1), (x0 + 14, bottom + 1)],
            BLACK,
        ))
        .map_err(|e| e.to_string())?;
        let style = TextStyle::from((FONT, 12).into_font()).color(&BLACK);
        root.draw(&Text::new(scale.unit.to_owned(), (x0, 4), style.clone()))
            .map_err(|e| e.to_string())?;
        let range = scale.high - scale.low;
        for k in 0..=4 {
            let t = k as f32 / 4.0;
            let y = bottom - (t * span as f32).round() as i32;
            root.draw(&PathElement::new(vec![(x0 + 14, y), (x0 + 18, y)], BLACK))
                .map_err(|e| e.to_string())?;
            root.draw(&Text::new(
                label(scale.low + t * range, range),
                (x0 + 21, y - 6),
                style.clone(),
            ))
            .map_err(|e| e.to_string())?;
        }
        root.present().map_err(|e| e.to_string())?;
    }
    Ok((rgb, pw, ph))
}

/// Writes [`picture`] as PNG at `path`, whole or not at all.
pub fn write_map_png(
    path: &Path,
    values: &[f32],
    width: u32,
    height: u32,
    scale: &Scale<'_>,
) -> Result<()> {
    write_png(path, picture(values, width, height, scale))
}

/// Writes a picture (`(pixels, width, height)`, RGB) as PNG at `path`, whole or not at all.
fn write_png(path: &Path, picture: std::result::Result<(Vec<u8>, u32, u32), String>) -> Result<()> {
    let encode = |message: String| Error::Encode {
        path: path.to_path_buf(),
        message,
    };
    let (rgb, pw, ph) = picture.map_err(encode)?;
    let mut file = StagedFile::create(path)?;
    image_files::write_png_rgb8(file.writer(), pw, ph, &rgb).map_err(|e| encode(e.0))?;
    file.commit()
}

/// One category of a [`category_picture`]: its legend line and its colour.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Category {
    /// The legend's text for it (a name, a count).
    pub label: String,
    /// Its colour in the map.
    pub colour: [u8; 3],
}

/// Columns of pixels the legend of a [`category_picture`] takes beside the map.
pub const LEGEND_PANEL_PX: u32 = 190;

/// Rows of pixels one legend line takes.
const LEGEND_LINE_PX: u32 = 16;

/// The RGB picture of a map of categories (`codes[i]` indexes `categories`; `width × height`,
/// row-major) with its legend on the right, one line per category: `(pixels, picture width,
/// picture height)`. The map's pixels are exactly their category's colour.
pub fn category_picture(
    codes: &[u8],
    width: u32,
    height: u32,
    categories: &[Category],
) -> std::result::Result<(Vec<u8>, u32, u32), String> {
    if codes.len() != width as usize * height as usize {
        return Err(format!("{} codes for a {width}x{height} map", codes.len()));
    }
    if let Some(&code) = codes.iter().find(|&&c| c as usize >= categories.len()) {
        return Err(format!(
            "code {code} in a map of {} categories",
            categories.len()
        ));
    }
    let legend = 8 + LEGEND_LINE_PX * categories.len() as u32;
    let (pw, ph) = (width + LEGEND_PANEL_PX, height.max(legend));
    let mut rgb = vec![255u8; pw as usize * ph as usize * 3];
    for (i, &code) in codes.iter().enumerate() {
        let (x, y) = (i % width as usize, i / width as usize);
        let at = (y * pw as usize + x) * 3;
        rgb[at..at + 3].copy_from_slice(&categories[code as usize].colour);
    }
    let x0 = width as usize + 8;
    for (k, category) in categories.iter().enumerate() {
        let top = 6 + LEGEND_LINE_PX as usize * k;
        for y in top..top + 10 {
            for x in x0..x0 + 10 {
                let at = (y * pw as usize + x) * 3;
                rgb[at..at + 3].copy_from_slice(&category.colour);
            }
        }
    }
    register_font();
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (pw, ph)).into_drawing_area();
        let style = TextStyle::from((FONT, 12).into_font()).color(&BLACK);
        for (k, category) in categories.iter().enumerate() {
            let top = 6 + (LEGEND_LINE_PX as usize * k) as i32;
            root.draw(&Rectangle::new(
                [(x0 as i32 - 1, top - 1), (x0 as i32 + 10, top + 10)],
                BLACK,
            ))
            .map_err(|e| e.to_string())?;
            root.draw(&Text::new(
                category.label.clone(),
                (x0 as i32 + 16, top - 1),
                style.clone(),
            ))
            .map_err(|e| e.to_string())?;
        }
        root.present().map_err(|e| e.to_string())?;
    }
    Ok((rgb, pw, ph))
}

/// Writes [`category_picture`] as PNG at `path`, whole or not at all.
pub fn write_category_png(
    path: &Path,
    codes: &[u8],
    width: u32,
    height: u32,
    categories: &[Category],
) -> Result<()> {
    write_png(path, category_picture(codes, width, height, categories))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_map_keeps_its_pixels_and_the_bar_spans_the_range() {
        let (w, h) = (40u32, 30u32);
        let values: Vec<f32> = (0..w * h)
            .map(|i| {
                if i == 5 {
                    f32::NAN
                } else {
                    400.0 + i as f32 / 10.0
                }
            })
            .collect();
        let scale = Scale {
            low: 420.0,
            high: 500.0,
            unit: "mm",
            palette: Palette::Viridis,
        };
        let (rgb, pw, ph) = picture(&values, w, h, &scale).unwrap();
        assert_eq!((pw, ph), (w + BAR_PANEL_PX, MIN_HEIGHT_PX));
        let pixel = |x: u32, y: u32| {
            let at = (y * pw + x) as usize * 3;
            [rgb[at], rgb[at + 1], rgb[at + 2]]
        };
        for (i, &v) in values.iter().enumerate() {
            let (x, y) = (i as u32 % w, i as u32 / w);
            assert_eq!(pixel(x, y), scale.colour(v), "pixel ({x}, {y})");
        }
        assert_eq!(pixel(5, 0), [0, 0, 0], "no value: black");
        // The bar: the high end's colour at its top, the low end's at its bottom.
        let x = w + 17;
        assert_eq!(pixel(x, 22), scale.colour(500.0));
        assert_eq!(pixel(x, ph - 12), scale.colour(420.0));
        // Labels were drawn right of the bar: dark pixels there.
        let dark = (w + 31..pw)
            .flat_map(|x| (0..ph).map(move |y| (x, y)))
            .filter(|&(x, y)| pixel(x, y)[0] < 100)
            .count();
        assert!(dark > 100, "{dark} dark label pixels");
        assert_eq!(label(420.0, 80.0), "420.0");
        assert_eq!(label(0.25, 1.0), "0.25");
        assert_eq!(label(0.125, 0.5), "0.125");
    }

    #[test]
    fn a_value_count_that_is_not_the_map_is_refused() {
        let scale = Scale {
            low: 0.0,
            high: 1.0,
            unit: "column",
            palette: Palette::Grey,
        };
        assert!(picture(&[0.0; 5], 2, 2, &scale).is_err());
        assert_eq!(scale.colour(1.0), [255, 255, 255]);
        assert_eq!(scale.colour(-3.0), [0, 0, 0]);
    }

    #[test]
    fn a_category_map_keeps_its_pixels_and_its_legend_shows_every_colour() {
        let (w, h) = (30u32, 20u32);
        let categories: Vec<Category> = [[200, 200, 200], [255, 0, 0], [0, 0, 255]]
            .into_iter()
            .enumerate()
            .map(|(k, colour)| Category {
                label: format!("category {k}"),
                colour,
            })
            .collect();
        let codes: Vec<u8> = (0..w * h).map(|i| (i % 3) as u8).collect();
        let (rgb, pw, ph) = category_picture(&codes, w, h, &categories).unwrap();
        assert_eq!(pw, w + LEGEND_PANEL_PX);
        assert!(ph >= h && ph >= 8 + 3 * LEGEND_LINE_PX);
        let pixel = |x: u32, y: u32| {
            let at = (y * pw + x) as usize * 3;
            [rgb[at], rgb[at + 1], rgb[at + 2]]
        };
        for (i, &code) in codes.iter().enumerate() {
            let (x, y) = (i as u32 % w, i as u32 / w);
            assert_eq!(pixel(x, y), categories[code as usize].colour);
        }
        // Each legend line's swatch, inside its frame.
        for (k, category) in categories.iter().enumerate() {
            let y = 6 + LEGEND_LINE_PX * k as u32 + 5;
            assert_eq!(pixel(w + 8 + 5, y), category.colour, "line {k}");
        }
        assert!(category_picture(&[3], 1, 1, &categories).is_err());
        assert!(category_picture(&[0, 0], 1, 1, &categories).is_err());
    }
}
