//! The projector's intensity response as a calibration (`fsm calibrate response`): which model
//! to keep from an estimate (`fsm_io::projector_response`, where it is measured), the report,
//! and the `[projector_response]` section of a calibration file.

use std::path::Path;

use fsm_geometry::file::CalibrationFile;
use fsm_io::projector_response::{ProjectorResponse, ResponseEstimate};
use fsm_io::{Error, Result};
use serde::Serialize;

/// Largest RMS fit residual (fraction of full light) at which [`ResponseModel::Auto`] keeps
/// the power law rather than the measured table.
pub const AUTO_GAMMA_MAX_RMS: f64 = 0.005;

/// Which response to keep.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResponseModel {
    /// The power law if it fits within [`AUTO_GAMMA_MAX_RMS`], the table otherwise.
    Auto,
    /// `light = code^gamma`, the best fit.
    Gamma,
    /// The measured points, interpolated linearly.
    Table,
}

impl ResponseModel {
    /// Every model, with its command-line name.
    pub const ALL: [(ResponseModel, &'static str); 3] = [
        (ResponseModel::Auto, "auto"),
        (ResponseModel::Gamma, "gamma"),
        (ResponseModel::Table, "table"),
    ];

    /// The model called `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.iter().find(|(_, n)| *n == name).map(|(m, _)| *m)
    }
}

/// The response kept from an estimate, and what it is in words.
pub struct ChosenResponse {
    /// The response.
    pub response: ProjectorResponse,
    /// `gamma 2.2000` or `a table of 17 levels`.
    pub what: String,
    /// Whether it is the power law.
    pub is_gamma: bool,
}

/// The response `model` keeps of `estimate`.
pub fn choose(estimate: &ResponseEstimate, model: ResponseModel) -> ChosenResponse {
    let is_gamma = match model {
        ResponseModel::Gamma => true,
        ResponseModel::Table => false,
        ResponseModel::Auto => estimate.fit_rms <= AUTO_GAMMA_MAX_RMS,
    };
    let response = if is_gamma {
        estimate.gamma_response()
    } else {
        estimate.table_response()
    };
    let what = match &response {
        ProjectorResponse::Gamma(g) => format!("gamma {g:.4}"),
        ProjectorResponse::Table(p) => format!("a table of {} levels", p.len()),
    };
    ChosenResponse {
        response,
        what,
        is_gamma,
    }
}

/// The response file's comment: where it was measured and how well the power law fits.
pub fn file_comment(estimate: &ResponseEstimate, images: &Path, levels: usize) -> String {
    format!(
        "Projector response measured by fsm calibrate response from {} ({levels} levels):\n\
         best-fit gamma {:.4}, RMS residual {:.5} of full light (largest {:.5} at level {}).",
        images.display(),
        estimate.gamma,
        estimate.fit_rms,
        estimate.fit_max,
        estimate.fit_max_level
    )
}

/// The JSON report of `fsm calibrate response --json`.
#[derive(Serialize)]
pub struct ResponseReport<'a> {
    /// The captures' folder.
    pub images: String,
    /// The sensor's bit depth the captures were read with.
    pub bit_depth: u8,
    /// "gamma" or "table": what was written.
    pub model: &'static str,
    /// The response file written, if any.
    pub response_file: Option<String>,
    /// The calibration file the response was stored in, if any.
    pub calibration_file: Option<String>,
    /// The estimate.
    #[serde(flatten)]
    pub estimate: &'a ResponseEstimate,
}

impl<'a> ResponseReport<'a> {
    /// The report of `estimate` of the captures in `images`, `chosen` written to
    /// `response_file` and stored in `calibration_file` (where given).
    pub fn new(
        images: &Path,
        estimate: &'a ResponseEstimate,
        chosen: &ChosenResponse,
        response_file: Option<&Path>,
        calibration_file: Option<&Path>,
    ) -> Self {
        ResponseReport {
            images: images.display().to_string(),
            bit_depth: estimate.bit_depth(),
            model: if chosen.is_gamma { "gamma" } else { "table" },
            response_file: response_file.map(|p| p.display().to_string()),
            calibration_file: calibration_file.map(|p| p.display().to_string()),
            estimate,
        }
    }

    /// Writes the report to `path` as JSON, whole or not at all.
    pub fn write(&self, path: &Path) -> Result<()> {
        let json = serde_json::to_string_pretty(self).expect("the report serialises");
        fsm_io::outputs::write_file(path, json.as_bytes())
    }
}

/// Where `fsm calibrate response` puts the response it keeps, each optional. Here rather than
/// in the command because the outputs depend on one another: the report names the response
/// file and the calibration file written.
#[derive(Clone, Copy, Debug, Default)]
pub struct ResponseOutputs<'a> {
    /// A response file (for `fsm patterns --gamma`), its comment from [`file_comment`].
    pub file: Option<&'a Path>,
    /// A calibration file whose `[projector_response]` section is replaced
    /// ([`store_in_calibration`]).
    pub calibration: Option<&'a Path>,
    /// The JSON report ([`ResponseReport`]).
    pub json: Option<&'a Path>,
}

impl ResponseOutputs<'_> {
    /// Writes `chosen`, kept of `estimate` of the captures in `images`, to each output given,
    /// in the order above; `wrote` gets a line as each is written (`wrote response.toml (gamma
    /// 2.2000)`, `stored gamma 2.2000 in cal.toml`, `wrote report.json`).
    pub fn write(
        &self,
        images: &Path,
        estimate: &ResponseEstimate,
        chosen: &ChosenResponse,
        mut wrote: impl FnMut(String),
    ) -> Result<()> {
        let what = &chosen.what;
        if let Some(out) = self.file {
            let comment = file_comment(estimate, images, estimate.levels.len());
            chosen.response.write(out, &comment)?;
            wrote(format!("wrote {} ({what})", out.display()));
        }
        if let Some(path) = self.calibration {
            store_in_calibration(path, &chosen.response)?;
            wrote(format!("stored {what} in {}", path.display()));
        }
        if let Some(path) = self.json {
            let report = ResponseReport::new(images, estimate, chosen, self.file, self.calibration);
            report.write(path)?;
            wrote(format!("wrote {}", path.display()));
        }
        Ok(())
    }
}

/// The projector response of `fsm patterns`: read from a response file (`--gamma`), else from
/// a calibration file's `[projector_response]` section ([`response_from_calibration`]); none
/// without either. One place for the two sources a response comes from.
pub fn read_response(
    file: Option<&Path>,
    calibration: Option<&Path>,
) -> Result<Option<ProjectorResponse>> {
    match (file, calibration) {
        (Some(path), _) => ProjectorResponse::read(path).map(Some),
        (None, Some(path)) => response_from_calibration(path).map(Some),
        (None, None) => Ok(None),
    }
}

/// Replaces the `[projector_response]` section of the calibration file `path` (rewritten whole
/// or not at all).
pub fn store_in_calibration(path: &Path, response: &ProjectorResponse) -> Result<()> {
    let mut file = CalibrationFile::read(path)?;
    file.projector_response = Some(response.into());
    Ok(file.write(path)?)
}

/// The projector response stored in the calibration file `path` (`fsm patterns
/// --calibration`); an error names the file if it has none.
pub fn response_from_calibration(path: &Path) -> Result<ProjectorResponse> {
    let file = CalibrationFile::read(path)?;
    let invalid = |message: String| Error::ProjectorResponse {
        path: path.to_path_buf(),
        message,
    };
    let section = file.projector_response.ok_or_else(|| {
        invalid(format!(
            "has no [projector_response] section: measure it with `fsm calibrate response \
             --images DIR --calibration {}`",
            path.display()
        ))
    })?;
    section.response().map_err(invalid)
}
