//! `thermcomp hub ...`: the flags of the hub subcommands, their checks,
//! and the printing; the link and protocol are in [`crate::hub`].

use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Result};
use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};

use crate::data::blobfile;
use crate::hub::monitor::{self, Names};
use crate::hub::serial::SerialLink;
use crate::hub::session::{self, Session, Timeouts};

/// The hub subcommands.
#[derive(Subcommand)]
pub enum HubCommand {
    /// Upload a model blob to the hub and make it the active model.
    ///
    /// The blob is checked locally first (refused before anything is sent).
    /// Then: Ping (protocol version), UploadBegin (the hub erases the
    /// inactive 128 KiB slot, 1-2 s; nothing is sent until its Ack), 64-byte
    /// chunks each acknowledged (one resend on timeout), UploadCommit (the
    /// hub checks the CRC and decodes the blob before it makes it active).
    Upload(UploadArgs),
    /// Tell the hub the length of the tool now in the spindle.
    SetTool(SetToolArgs),
    /// Check the hub answers and speaks this protocol version.
    Ping(PingArgs),
    /// Print the hub's telemetry, one line per sample.
    Monitor(MonitorArgs),
}

/// The serial port.
#[derive(Args)]
pub struct PortArgs {
    /// The hub's serial port (the ST-LINK virtual COM port, e.g. /dev/ttyACM0).
    #[arg(long)]
    pub port: PathBuf,
    /// Baud rate (the hub runs 115200 8N1).
    #[arg(long, default_value_t = 115_200)]
    pub baud: u32,
    /// Longest wait, s, for UploadBegin's Ack (the erase) and for `ping`;
    /// other replies wait at most 2 s; with `monitor`, the longest gap
    /// between telemetry frames.
    #[arg(long, default_value_t = 10.0)]
    pub timeout_s: f64,
}

impl PortArgs {
    fn timeout(&self) -> Result<Duration> {
        if !(self.timeout_s.is_finite() && self.timeout_s > 0.0 && self.timeout_s <= 3600.0) {
            bail!("--timeout-s must be a number of seconds in (0, 3600]");
        }
        Ok(Duration::from_secs_f64(self.timeout_s))
    }

    fn open(&self) -> Result<Session<SerialLink>> {
        let link = SerialLink::open(&self.port, self.baud)?;
        Session::new(link).map_err(|e| anyhow!("{}: {e}", self.port.display()))
    }
}

/// `hub upload`.
#[derive(Args)]
pub struct UploadArgs {
    #[command(flatten)]
    port: PortArgs,
    /// The model blob (`thermcomp fit`/`model build`).
    #[arg(long)]
    model: PathBuf,
}

/// `hub set-tool`.
#[derive(Args)]
pub struct SetToolArgs {
    #[command(flatten)]
    port: PortArgs,
    /// Tool length, mm (0 ..= 1000, the hub's range).
    #[arg(long, allow_negative_numbers = true)]
    mm: f64,
}

/// `hub ping`.
#[derive(Args)]
pub struct PingArgs {
    #[command(flatten)]
    port: PortArgs,
    /// Print one JSON object: {"protocol": 1, "rtt_ms": 12.3}.
    #[arg(long)]
    json: bool,
}

/// `hub monitor`.
#[derive(Args)]
pub struct MonitorArgs {
    #[command(flatten)]
    port: PortArgs,
    /// Stop after this many telemetry messages (default: run until killed).
    #[arg(long)]
    count: Option<u64>,
    /// One JSON object per line (JSON lines) instead of text.
    #[arg(long)]
    json: bool,
    /// The blob the hub runs: label offsets and temperatures with its
    /// output and input names.
    #[arg(long)]
    model: Option<PathBuf>,
}

/// Runs a hub subcommand.
pub fn run(command: &HubCommand) -> Result<()> {
    match command {
        HubCommand::Upload(a) => upload(a),
        HubCommand::SetTool(a) => set_tool(a),
        HubCommand::Ping(a) => ping(a),
        HubCommand::Monitor(a) => monitor(a),
    }
}

fn upload(a: &UploadArgs) -> Result<()> {
    // Refuse a bad blob before touching the port.
    let (model, blob) = blobfile::read(&a.model)?;
    let timeout = a.port.timeout()?;
    let mut s = a.port.open()?;
    let bar = ProgressBar::new(blob.len() as u64).with_style(
        ProgressStyle::with_template("{msg} [{bar:30}] {bytes}/{total_bytes}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_message("upload");
    let r = s.upload(&blob, Timeouts::from_user(timeout), &mut |n| {
        bar.set_position(u64::from(n))
    });
    bar.finish_and_clear();
    let r = r.map_err(|e| anyhow!("upload of {} failed: {e}", a.model.display()))?;
    eprintln!(
        "uploaded {} to {} ({} bytes, {} model, CRC {:#010x}, {} chunks, {} resent): committed",
        a.model.display(),
        a.port.port.display(),
        r.bytes,
        model.kind().name(),
        r.crc32,
        r.chunks,
        r.retries
    );
    Ok(())
}

fn set_tool(a: &SetToolArgs) -> Result<()> {
    // Read as f64 and judged before the wire's f32 (1e300 was reported as
    // "got inf"), against the range the hub itself takes.
    let tools = crate::fivepoint::HUB_TOOL_MM;
    if !tools.contains(&a.mm) {
        bail!(
            "--mm must be a tool length in 0 ..= {} mm, got {}",
            tools.end(),
            crate::num::shown::Num(a.mm)
        );
    }
    let timeout = a.port.timeout()?;
    let mut s = a.port.open()?;
    #[allow(clippy::cast_possible_truncation)]
    s.set_tool(a.mm as f32, timeout.min(session::REPLY_TIMEOUT))
        .map_err(|e| anyhow!("set-tool: {e}"))?;
    eprintln!("tool length {} mm set", a.mm);
    Ok(())
}

fn ping(a: &PingArgs) -> Result<()> {
    let timeout = a.port.timeout()?;
    let mut s = a.port.open()?;
    let (protocol, rtt) = s.ping(timeout).map_err(|e| anyhow!("ping: {e}"))?;
    let rtt_ms = rtt.as_secs_f64() * 1e3;
    if a.json {
        crate::data::fsio::print_line(
            &serde_json::json!({"protocol": protocol, "rtt_ms": rtt_ms}).to_string(),
        )?;
    } else {
        crate::data::fsio::print_line(&format!(
            "hub on {} answered: protocol {protocol}, {rtt_ms:.1} ms",
            a.port.port.display()
        ))?;
    }
    Ok(())
}

fn monitor(a: &MonitorArgs) -> Result<()> {
    let names = match &a.model {
        Some(path) => {
            let (model, _) = blobfile::read(path)?;
            Some(Names {
                outputs: model.outputs().iter().map(|n| n.to_string()).collect(),
                inputs: model.inputs().iter().map(|c| c.name.to_string()).collect(),
            })
        }
        None => None,
    };
    let timeout = a.port.timeout()?;
    let mut s = a.port.open()?;
    let mut seen = 0u64;
    while a.count.is_none_or(|n| seen < n) {
        let Some(t) = s
            .next_telemetry(Instant::now() + timeout)
            .map_err(|e| anyhow!("monitor: {e}"))?
        else {
            bail!(
                "no telemetry from {} for {:.1} s (is the hub running and the baud rate right?)",
                a.port.port.display(),
                timeout.as_secs_f64()
            );
        };
        if a.json {
            crate::data::fsio::print_line(&monitor::json_line(&t, names.as_ref()).to_string())?;
        } else {
            crate::data::fsio::print_line(&monitor::text_line(&t, names.as_ref()))?;
        }
        seen += 1;
    }
    Ok(())
}
