//! The hub as one CANopen node: NMT state, dictionary, SDO server, PDOs,
//! EMCY and heartbeat together, frames in and frames out. No hardware: the
//! RTIC app (`main.rs`) hands it every received frame and each sample's
//! report and sends what it returns; `thermcomp replay` does the same on
//! the host.

use embedded_can::{Frame, Id};

use crate::can_frames::{frame, NmtState, StatusInfo, REPORT_FRAMES_MAX};
use crate::can_rx::RxMessage;
use crate::offsets::{MAX_OUTPUTS, POSITION_REFERENCE_MM};
use crate::report::Report;

use super::abort::SdoAbort;
use super::emcy::{self, EmcyProducer};
use super::nmt::{self, HeartbeatProducer, NmtCommand};
use super::od::{self, Dictionary, OBJECTS};
use super::pdo::{self, RPDO_MAPPING, TPDO_MAPPING};
use super::sdo::SdoServer;
use super::settings::{self, Settings};

/// NMT commands' COB-ID (CiA 301 §7.3.3, table 41).
pub const NMT_ID: u16 = 0x000;
/// Boot-up and heartbeat: 0x700 + node id.
pub const HEARTBEAT_BASE: u16 = 0x700;
/// SDO requests: 0x600 + node id.
pub const SDO_RX_BASE: u16 = 0x600;
/// SDO responses: 0x580 + node id.
pub const SDO_TX_BASE: u16 = 0x580;

/// Most frames one sample produces: EMCYs, then the TPDOs.
pub const SAMPLE_FRAMES_MAX: usize = emcy::MAX_PER_SAMPLE + REPORT_FRAMES_MAX;

/// What a received frame asks of the application.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum Event {
    /// New values from the CNC (an RPDO, or an SDO write of 0x2200/0x2201),
    /// for `cnc_inputs::CncInputs::receive`.
    Input(RxMessage),
    /// NMT reset node: restart the application (on the board, a system
    /// reset, which boots with the stored settings).
    ResetNode,
    /// 0x1010 "save" (the current settings) or 0x1011 "load" (the
    /// defaults): write these to flash (`canopen::store`), at low priority.
    Store(Settings),
}

/// The answer to one received frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Reaction<F> {
    /// Frames to send (an SDO response, a boot-up, an EMCY).
    pub frames: heapless::Vec<F, 2>,
    /// What the application must do.
    pub event: Option<Event>,
}

impl<F> Reaction<F> {
    fn none() -> Self {
        Self {
            frames: heapless::Vec::new(),
            event: None,
        }
    }
}

/// See the module docs.
#[derive(Clone, Debug)]
pub struct Node {
    od: Dictionary,
    settings: Settings,
    state: NmtState,
    sdo: SdoServer,
    heartbeat: HeartbeatProducer,
    emcy: EmcyProducer,
}

impl Node {
    /// A node with `settings` (the stored ones, or the defaults), before
    /// boot-up. Refuses settings the dictionary would refuse.
    pub fn new(settings: Settings) -> Result<Self, SdoAbort> {
        let od = settings.to_od()?;
        Ok(Self {
            od,
            settings,
            state: NmtState::BootUp,
            sdo: SdoServer::new(),
            heartbeat: HeartbeatProducer::new(settings.heartbeat_ms),
            emcy: EmcyProducer::new(),
        })
    }

    /// The node id.
    pub fn node_id(&self) -> u8 {
        self.od.node_id()
    }

    /// The NMT state.
    pub fn state(&self) -> NmtState {
        self.state
    }

    /// The settings the node booted with (what runs now).
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// The dictionary.
    pub fn dictionary(&self) -> &Dictionary {
        &self.od
    }

    /// The COB-IDs the node receives (NMT, SDO requests, RPDO1, RPDO2): the
    /// board's CAN filter passes exactly these.
    pub fn rx_ids(&self) -> [u16; 4] {
        let id = u16::from(self.node_id());
        [
            NMT_ID,
            SDO_RX_BASE + id,
            self.od.get(0x1400, 1) as u16,
            self.od.get(0x1401, 1) as u16,
        ]
    }

    fn own<F: Frame>(&self, base: u16, data: &[u8]) -> Option<F> {
        frame(base + u16::from(self.node_id()), data)
    }

    /// Boot-up (CiA 301 §7.2.8.3.2.1): the boot-up message (0x700 + node
    /// id, `[0x00]`), then pre-operational, or operational if
    /// 0x2008 says so. The first heartbeat follows a period after it.
    pub fn boot<F: Frame>(&mut self, now_ms: u32) -> Option<F> {
        self.state = if self.settings.auto_start {
            NmtState::Operational
        } else {
            NmtState::PreOperational
        };
        self.heartbeat.start(now_ms);
        self.own(HEARTBEAT_BASE, &[NmtState::BootUp as u8])
    }

    /// The heartbeat frame if one is due at `now_ms` (in every state).
    pub fn poll_heartbeat<F: Frame>(&mut self, now_ms: u32) -> Option<F> {
        if self.state == NmtState::BootUp || !self.heartbeat.poll(now_ms) {
            return None;
        }
        self.own(HEARTBEAT_BASE, &[self.state as u8])
    }

    /// One received frame.
    pub fn on_frame<F: Frame>(&mut self, f: &F, now_ms: u32) -> Reaction<F> {
        let mut out = Reaction::none();
        let id = match f.id() {
            Id::Standard(id) if !f.is_remote_frame() => id.as_raw(),
            _ => return out,
        };
        let node = u16::from(self.node_id());
        if id == NMT_ID {
            if let Some(cmd) = NmtCommand::parse(f.data(), self.node_id()) {
                self.nmt(cmd, now_ms, &mut out);
            }
        } else if id == SDO_RX_BASE + node {
            if nmt::accepts_sdo(self.state) {
                self.sdo_request(f.data(), &mut out);
            }
        } else if let Some(n) = self.rx_ids()[2..].iter().position(|r| *r == id) {
            if nmt::accepts_pdo(self.state) {
                self.rpdo(n, f.data(), &mut out);
            }
        }
        out
    }

    fn nmt<F: Frame>(&mut self, cmd: NmtCommand, now_ms: u32, out: &mut Reaction<F>) {
        match cmd {
            NmtCommand::Start => self.state = NmtState::Operational,
            NmtCommand::Stop => self.state = NmtState::Stopped,
            NmtCommand::EnterPreOperational => self.state = NmtState::PreOperational,
            NmtCommand::ResetNode => out.event = Some(Event::ResetNode),
            NmtCommand::ResetCommunication => {
                // Communication objects back to their stored values
                // (CiA 301 §7.3.2.2.1), then boot-up into pre-operational.
                self.od
                    .set(od::HEARTBEAT_TIME, 0, u32::from(self.settings.heartbeat_ms));
                self.heartbeat.set_period(self.settings.heartbeat_ms);
                self.sdo = SdoServer::new();
                self.state = NmtState::PreOperational;
                self.heartbeat.start(now_ms);
                if let Some(f) = self.own(HEARTBEAT_BASE, &[NmtState::BootUp as u8]) {
                    let _ = out.frames.push(f);
                }
            }
        }
    }

    fn sdo_request<F: Frame>(&mut self, data: &[u8], out: &mut Reaction<F>) {
        let Self {
            od, sdo, heartbeat, ..
        } = self;
        let mut event = None;
        let resp = sdo.on_request(data, od, |od, pos, raw| {
            let (index, sub) = OBJECTS.get(pos).map_or((0, 0), |o| (o.index, o.sub));
            match index {
                od::STORE if raw == od::SAVE_SIGNATURE => {
                    event = Some(Event::Store(Settings::from_od(od)));
                    return Ok(());
                }
                od::RESTORE if raw == od::LOAD_SIGNATURE => {
                    event = Some(Event::Store(Settings::DEFAULT));
                    return Ok(());
                }
                od::STORE | od::RESTORE => return Err(SdoAbort::CannotStore),
                _ => {}
            }
            let old = od.raw_at(pos);
            od.store(pos, raw);
            if settings::is_setting(pos) {
                if let Err(e) = settings::cross_check(od) {
                    od.store(pos, old);
                    return Err(e);
                }
            }
            if index == od::HEARTBEAT_TIME {
                heartbeat.set_period(raw as u16);
            }
            if let Some(msg) = pdo::cnc_message_sub(od, index, sub) {
                event = Some(Event::Input(msg));
            }
            Ok(())
        });
        if let Some(r) = resp.and_then(|r| self.own(SDO_TX_BASE, &r)) {
            let _ = out.frames.push(r);
            out.event = event;
        }
    }

    fn rpdo<F: Frame>(&mut self, n: usize, data: &[u8], out: &mut Reaction<F>) {
        let Some(&mapping) = RPDO_MAPPING.get(n) else {
            return;
        };
        match pdo::unpack(&mut self.od, mapping, data) {
            Ok(()) => {
                let index = [od::SPINDLE, od::TOOL_POSITION][n];
                out.event = pdo::cnc_message(&self.od, index).map(Event::Input);
            }
            Err(_) => {
                let e = emcy::emcy_bytes(emcy::PDO_LENGTH, self.emcy.register(), 0, 0);
                if let Some(f) = self.emcy_frame(&e) {
                    let _ = out.frames.push(f);
                }
            }
        }
    }

    fn emcy_frame<F: Frame>(&self, data: &[u8; 8]) -> Option<F> {
        if !nmt::sends_emcy(self.state) {
            return None;
        }
        frame(self.od.get(0x1014, 0) as u16, data)
    }

    fn tpdo<F: Frame>(&self, n: usize) -> Option<F> {
        let mapping = *TPDO_MAPPING.get(n)?;
        let (bytes, len) = pdo::pack(&self.od, mapping);
        frame(self.od.get(0x1800 + n as u16, 1) as u16, bytes.get(..len)?)
    }

    /// One sample: its EMCYs (conditions that started or ended, in any
    /// state but stopped) and, in operational, its TPDOs: TPDO1, TPDO2,
    /// TPDO3 with a 4th output, TPDO4 per positional output. Ascending
    /// COB-IDs, so a later frame never displaces an earlier one.
    pub fn on_sample<F: Frame>(
        &mut self,
        report: &Report,
        info: &StatusInfo,
    ) -> heapless::Vec<F, SAMPLE_FRAMES_MAX> {
        let mut out = heapless::Vec::new();
        let emcys = self.emcy.on_sample(report.flags, report.faulty_channels);
        self.od
            .set(od::ERROR_REGISTER, 0, u32::from(self.emcy.register()));
        for e in &emcys {
            if let Some(f) = self.emcy_frame(e) {
                let _ = out.push(f);
            }
        }
        if !nmt::accepts_pdo(self.state) {
            return out;
        }
        pdo::set_report(&mut self.od, report, info);
        let ext = report.n_outputs >= 4;
        for n in [0, 1].into_iter().chain(ext.then_some(2)) {
            if let Some(f) = self.tpdo(n) {
                let _ = out.push(f);
            }
        }
        let n_out = usize::from(report.n_outputs).min(MAX_OUTPUTS);
        for (j, slope) in report.slopes_um_per_m.iter().enumerate().take(n_out) {
            if report.positional & (1 << j) == 0 {
                continue;
            }
            pdo::set_slope(&mut self.od, *slope, POSITION_REFERENCE_MM, j as u8);
            if let Some(f) = self.tpdo(3) {
                let _ = out.push(f);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests;
