//! The projector's response (light out for code in) and the gamma pre-correction of pattern
//! images: FSM assumes the projected light is `PA + PB·cos(…)` (paper eq. 4); a projector with
//! gamma turns the cosine into a distorted wave whose harmonics show up as ghost peaks at
//! multiples of the column. Pre-correcting the codes with the inverse response restores it.
//!
//! A response file (TOML, documented in the host README, "Projector response files"):
//!
//! ```toml
//! format_version = 1
//! gamma = 2.2                    # light = code^gamma, code and light as fractions of full scale
//! ```
//!
//! or a measured table (`input` strictly increasing from 0 to 1, `output` in any unit,
//! strictly increasing; interpolated linearly):
//!
//! ```toml
//! format_version = 1
//! input = [0.0, 0.25, 0.5, 0.75, 1.0]
//! output = [0.8, 12.0, 48.0, 110.0, 200.0]
//! ```

use std::path::Path;

use crate::error::{Error, IoContext, Result};

/// Version of the response-file format.
pub const RESPONSE_FILE_VERSION: u64 = 1;

/// A projector's response, normalised so that code 0 gives light 0 and full code light 1.
#[derive(Clone, Debug, PartialEq)]
pub enum ProjectorResponse {
    /// `light = code^gamma`.
    Gamma(f64),
    /// Measured `(code, light)` points, both normalised to `[0, 1]`, strictly increasing.
    Table(Vec<(f64, f64)>),
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct ResponseFile {
    format_version: u64,
    gamma: Option<f64>,
    input: Option<Vec<f64>>,
    output: Option<Vec<f64>>,
}

impl ProjectorResponse {
    /// Reads a response file.
    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).at(path)?;
        Self::parse(&text).map_err(|message| Error::ProjectorResponse {
            path: path.to_path_buf(),
            message,
        })
    }

    /// Parses the text of a response file; the error names the field.
    pub fn parse(text: &str) -> Result<Self, String> {
        let file: ResponseFile =
            toml::from_str(text).map_err(|e| e.to_string().trim().to_owned())?;
        if file.format_version != RESPONSE_FILE_VERSION {
            return Err(format!(
                "field format_version = {} is not supported (this build reads {RESPONSE_FILE_VERSION})",
                file.format_version
            ));
        }
        match (file.gamma, file.input, file.output) {
            (Some(g), None, None) => {
                if g.is_finite() && (0.1..=10.0).contains(&g) {
                    Ok(ProjectorResponse::Gamma(g))
                } else {
                    Err(format!("field gamma = {g}: must lie in 0.1..=10"))
                }
            }
            (None, Some(input), Some(output)) => Self::table(&input, &output),
            _ => Err("give either field gamma, or both fields input and output".into()),
        }
    }

    fn table(input: &[f64], output: &[f64]) -> Result<Self, String> {
        if input.len() != output.len() || input.len() < 2 {
            return Err(format!(
                "fields input ({} values) and output ({} values) must have the same length, at least 2",
                input.len(),
                output.len()
            ));
        }
        if input[0] != 0.0 || input[input.len() - 1] != 1.0 {
            return Err("field input must run from 0 to 1 (fractions of the full code)".into());
        }
        for (name, values) in [("input", input), ("output", output)] {
            for (i, w) in values.windows(2).enumerate() {
                if w[1] <= w[0] || !w[0].is_finite() || !w[1].is_finite() {
                    return Err(format!(
                        "field {name}: values must be finite and strictly increasing (entry {} = {} after {})",
                        i + 1,
                        w[1],
                        w[0]
                    ));
                }
            }
        }
        let (lo, hi) = (output[0], output[output.len() - 1]);
        let points = input
            .iter()
            .zip(output)
            .map(|(&c, &l)| (c, (l - lo) / (hi - lo)))
            .collect();
        Ok(ProjectorResponse::Table(points))
    }

    /// The code (fraction of full scale) that makes the projector emit relative light `light`
    /// (clamped to `[0, 1]`).
    pub fn code_for(&self, light: f64) -> f64 {
        let light = light.clamp(0.0, 1.0);
        match self {
            ProjectorResponse::Gamma(g) => light.powf(1.0 / g),
            ProjectorResponse::Table(points) => {
                let i = points
                    .partition_point(|&(_, l)| l < light)
                    .clamp(1, points.len() - 1);
                let (c0, l0) = points[i - 1];
                let (c1, l1) = points[i];
                c0 + (c1 - c0) * (light - l0) / (l1 - l0)
            }
        }
    }

    /// Relative light for code `code` (fraction of full scale): the forward model.
    pub fn light_for(&self, code: f64) -> f64 {
        let code = code.clamp(0.0, 1.0);
        match self {
            ProjectorResponse::Gamma(g) => code.powf(*g),
            ProjectorResponse::Table(points) => {
                let i = points
                    .partition_point(|&(c, _)| c < code)
                    .clamp(1, points.len() - 1);
                let (c0, l0) = points[i - 1];
                let (c1, l1) = points[i];
                l0 + (l1 - l0) * (code - c0) / (c1 - c0)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pre_correction_inverts_the_response() {
        let gamma = ProjectorResponse::parse("format_version = 1\ngamma = 2.2").unwrap();
        let table = ProjectorResponse::parse(
            "format_version = 1\ninput = [0.0, 0.5, 1.0]\noutput = [2.0, 40.0, 202.0]",
        )
        .unwrap();
        for r in [gamma, table] {
            for i in 0..=20 {
                let light = i as f64 / 20.0;
                assert!(
                    (r.light_for(r.code_for(light)) - light).abs() < 1e-9,
                    "{r:?} {light}"
                );
            }
        }
    }

    #[test]
    fn errors_name_the_field() {
        for (text, field) in [
            ("format_version = 1\ngamma = 0", "gamma"),
            (
                "format_version = 1\ninput = [0.0, 1.0]\noutput = [1.0, 1.0]",
                "output",
            ),
            (
                "format_version = 1\ninput = [0.0, 0.9]\noutput = [1.0, 2.0]",
                "input",
            ),
            ("format_version = 1\ngama = 2.2", "gama"),
            ("format_version = 3\ngamma = 2.2", "format_version"),
        ] {
            let e = ProjectorResponse::parse(text).unwrap_err();
            assert!(e.contains(field), "{text}: {e}");
        }
    }
}
