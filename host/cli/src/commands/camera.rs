//! `fsm upload` and `fsm camera`: talking to a smart camera that decodes on board, over TCP
//! (`tcp://host:port`) or a serial port (`/dev/ttyUSB0`, `/dev/ttyUSB0@921600`), with the
//! protocol of `fsm-protocol` (postcard + COBS frames, CRC-32, versioned). The camera takes a
//! plan of any method (BFSM, EFSM, or a baseline the paper compares them with): its canonical
//! bytes travel (`fsm_core::methods::wire`), and its candidate files carry its fingerprint.

use std::path::PathBuf;
use std::time::Duration;

use fsm_io::outputs::StagedFile;
use fsm_io::{Error, Result};
use fsm_protocol::client::{Device, DeviceError};
use fsm_protocol::RowOutput;

/// Upload a plan of any method to a camera; it answers with the plan's fingerprint.
///
/// Examples:
///   fsm upload --plan plan.toml --device tcp://192.168.1.10:7070
///   fsm upload --plan line-scan.toml --device tcp://192.168.1.10:7070
///   fsm upload --plan plan.toml --device /dev/ttyUSB0@921600
#[derive(clap::Args, Debug)]
#[command(verbatim_doc_comment)]
pub struct UploadArgs {
    /// Plan file of any method (BFSM, EFSM, phase shift, Micro Phase Shifting, Code Ensemble,
    /// line scanning).
    #[arg(long, value_name = "FILE")]
    plan: PathBuf,
    #[command(flatten)]
    link: DeviceArgs,
}

/// The camera and how long to wait for it.
#[derive(clap::Args, Debug)]
pub struct DeviceArgs {
    /// The camera: tcp://HOST:PORT or a serial port path (PATH@BAUD).
    #[arg(long, value_name = "ADDR")]
    device: String,
    /// Seconds to wait for each answer.
    #[arg(long, value_name = "S", default_value_t = 10)]
    timeout: u64,
}

impl DeviceArgs {
    /// The camera these options name.
    fn device(&self) -> Device {
        Device::new(&self.device, Duration::from_secs(self.timeout))
    }
}

/// A failed conversation, which names the camera, as the host's error.
fn usage(e: DeviceError) -> Error {
    Error::Usage(e.to_string())
}

/// `fsm camera`'s subcommands.
#[derive(clap::Subcommand, Debug)]
pub enum CameraCommand {
    /// Print the camera's protocol version, limits and loaded plan.
    Info {
        #[command(flatten)]
        link: DeviceArgs,
    },
    /// Scan: upload the plan, stream the rows of a dump to the camera (standing in for its
    /// sensor) and write what it sends back — its candidate file, the same bytes
    /// `fsm decode` writes, or raw rows with --raw.
    Scan {
        #[command(flatten)]
        to: UploadArgs,
        /// Row dump whose rows are sent.
        #[arg(long, value_name = "FILE")]
        dump: PathBuf,
        /// Output file (written whole or not at all).
        #[arg(long, value_name = "FILE")]
        out: PathBuf,
        /// Ask for raw rows (a row dump) instead of candidates.
        #[arg(long)]
        raw: bool,
    },
}

pub fn upload(args: UploadArgs) -> Result<()> {
    let plan = fsm_io::plan_file::read_method_plan(&args.plan)?;
    let (fingerprint, info) = args.link.device().upload(plan).map_err(usage)?;
    let (device, path) = (&args.link.device, args.plan.display());
    eprintln!("{device}: plan {path} accepted (fingerprint {fingerprint:016x}); {info:#}");
    Ok(())
}

pub fn camera(command: CameraCommand) -> Result<()> {
    match command {
        CameraCommand::Info { link } => {
            sayln!("{}", link.device().info().map_err(usage)?);
            Ok(())
        }
        CameraCommand::Scan { to, dump, out, raw } => {
            let plan = fsm_io::plan_file::read_method_plan(&to.plan)?;
            let output = if raw {
                RowOutput::Raw
            } else {
                RowOutput::Candidates
            };
            let mut file = StagedFile::create(&out)?;
            let device = to.link.device();
            let scan = device.scan_dump_file(plan, &dump, output, file.writer());
            let summary = scan.map_err(usage)?;
            file.commit()?;
            eprintln!("{}", summary.report(&device, &dump, &out));
            Ok(())
        }
    }
}
