//! NMT slave state machine and heartbeat producer (CiA 301 §7.2.8, §7.3.2).
//!
//! States and what each accepts and sends (CiA 301 §7.3.2.2, table 47):
//!
//! | state | SDO | PDO (TPDOs out, RPDOs in) | EMCY | heartbeat | NMT |
//! |---|---|---|---|---|---|
//! | pre-operational (0x7F) | yes | no | yes | yes | yes |
//! | operational (0x05) | yes | yes | yes | yes | yes |
//! | stopped (0x04) | no | no | no | yes | yes |
//!
//! After power-on or reset node the hub sends its boot-up message (0x700 +
//! node id, one byte 0x00, §7.2.8.3.2.1) and enters pre-operational, or
//! operational at once if object 0x2008 ("start without NMT master",
//! default 1) says so: most CNCs that read the hub have no NMT master, and
//! the hub did send its frames without one before it spoke CANopen. After
//! reset communication the hub always waits in pre-operational: the NMT
//! master that sent it is there to start it.

use crate::can_frames::NmtState;

/// NMT command specifiers (CiA 301 §7.2.8.3.1, frame 0x000: `[cs, node]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum NmtCommand {
    /// 0x01 start remote node: operational.
    Start,
    /// 0x02 stop remote node: stopped.
    Stop,
    /// 0x80 enter pre-operational.
    EnterPreOperational,
    /// 0x81 reset node: application and communication reset.
    ResetNode,
    /// 0x82 reset communication.
    ResetCommunication,
}

impl NmtCommand {
    /// The command in an NMT frame's data, if it is addressed to `node_id`
    /// (or to all nodes, 0) and well formed (2 bytes, known specifier).
    pub fn parse(data: &[u8], node_id: u8) -> Option<Self> {
        let [cs, node] = *data else {
            return None;
        };
        if node != 0 && node != node_id {
            return None;
        }
        Some(match cs {
            0x01 => Self::Start,
            0x02 => Self::Stop,
            0x80 => Self::EnterPreOperational,
            0x81 => Self::ResetNode,
            0x82 => Self::ResetCommunication,
            _ => return None,
        })
    }
}

/// What the NMT state allows (table in the module docs).
pub const fn accepts_sdo(state: NmtState) -> bool {
    matches!(state, NmtState::PreOperational | NmtState::Operational)
}

/// Whether PDOs are sent and received.
pub const fn accepts_pdo(state: NmtState) -> bool {
    matches!(state, NmtState::Operational)
}

/// Whether EMCY messages are sent.
pub const fn sends_emcy(state: NmtState) -> bool {
    accepts_sdo(state)
}

/// The heartbeat producer (object 0x1017, §7.2.8.3.2.2): the NMT state
/// every `period_ms` (0: off), the first one a period after boot-up.
/// A new period takes effect at once: the next heartbeat is due at the next
/// poll, then every new period.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HeartbeatProducer {
    period_ms: u16,
    next_ms: Option<u32>,
}

impl HeartbeatProducer {
    /// Not started: [`HeartbeatProducer::start`] at boot-up.
    pub const fn new(period_ms: u16) -> Self {
        Self {
            period_ms,
            next_ms: None,
        }
    }

    /// The period, ms.
    pub const fn period_ms(&self) -> u16 {
        self.period_ms
    }

    /// Boot-up was sent at `now_ms`: the first heartbeat is a period later.
    pub fn start(&mut self, now_ms: u32) {
        self.next_ms = Some(now_ms.wrapping_add(u32::from(self.period_ms)));
    }

    /// A new period (an SDO write of 0x1017).
    pub fn set_period(&mut self, period_ms: u16) {
        self.period_ms = period_ms;
        self.next_ms = None;
    }

    /// Whether a heartbeat is due at `now_ms` (and if so, schedules the next).
    pub fn poll(&mut self, now_ms: u32) -> bool {
        if self.period_ms == 0 {
            return false;
        }
        if let Some(next) = self.next_ms {
            // Due when now is at or past `next`, modulo 2^32.
            if (now_ms.wrapping_sub(next) as i32) < 0 {
                return false;
            }
        }
        self.next_ms = Some(now_ms.wrapping_add(u32::from(self.period_ms)));
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_for_this_node_or_all() {
        assert_eq!(NmtCommand::parse(&[0x01, 0x01], 1), Some(NmtCommand::Start));
        assert_eq!(NmtCommand::parse(&[0x02, 0x00], 1), Some(NmtCommand::Stop));
        assert_eq!(
            NmtCommand::parse(&[0x80, 0x01], 1),
            Some(NmtCommand::EnterPreOperational)
        );
        assert_eq!(
            NmtCommand::parse(&[0x81, 0x00], 1),
            Some(NmtCommand::ResetNode)
        );
        assert_eq!(
            NmtCommand::parse(&[0x82, 0x01], 1),
            Some(NmtCommand::ResetCommunication)
        );
        // Another node, an unknown specifier, a wrong length.
        assert_eq!(NmtCommand::parse(&[0x01, 0x02], 1), None);
        assert_eq!(NmtCommand::parse(&[0x03, 0x01], 1), None);
        assert_eq!(NmtCommand::parse(&[0x01], 1), None);
        assert_eq!(NmtCommand::parse(&[0x01, 0x01, 0x00], 1), None);
    }

    #[test]
    fn heartbeat_every_period_after_boot() {
        let mut hb = HeartbeatProducer::new(1000);
        hb.start(500);
        assert!(!hb.poll(500));
        assert!(!hb.poll(1499));
        assert!(hb.poll(1500));
        assert!(!hb.poll(2499));
        // Late poll: sent, next one a period after it.
        assert!(hb.poll(2600));
        assert!(!hb.poll(3599));
        assert!(hb.poll(3600));
        // Across the u32 wrap.
        hb.start(u32::MAX - 100);
        assert!(!hb.poll(u32::MAX));
        assert!(hb.poll(899));
        // 0 disables; a new period is due at once.
        hb.set_period(0);
        assert!(!hb.poll(10_000));
        hb.set_period(250);
        assert!(hb.poll(10_000));
        assert!(!hb.poll(10_249));
        assert!(hb.poll(10_250));
    }
}
