//! Emergency producer (CiA 301 §7.2.7): one EMCY (0x080 + node id, 8
//! bytes) when a fault condition starts, one "error reset" (code 0x0000)
//! when one ends, with the error register (object 0x1001) in both.
//!
//! Bytes (§7.2.7.3.1): 0-1 error code (u16 LE), 2 error register, 3-7
//! manufacturer-specific: here 3-4 the STATUS flags (u16 LE) and 5-7 the
//! faulty-channel mask (u24 LE), the same bits as TPDO2, so a PLC that
//! logs only EMCYs still sees which input failed.
//!
//! | condition (STATUS flags) | error code (§7.2.7.1, table 21) | error register bits |
//! |---|---|---|
//! | a sensor fault: SensorFault, Implausible, RateOfChange, Stuck | 0x5000 device hardware | 0 generic, 7 manufacturer |
//! | a stale input: Stale (mostly an RPDO from the CNC past its deadline) | 0x8250 RPDO timeout | 0 generic, 4 communication |
//! | the model refused a sample: ModelFault | 0x6300 data set | 0 generic, 7 manufacturer |
//! | an RPDO shorter than its mapping (not processed) | 0x8210 PDO length error | sent once, not kept |

use crate::report::StatusFlags;

/// Error code: error reset or no error.
pub const RESET: u16 = 0x0000;
/// Error code: device hardware (the RTD channels).
pub const SENSOR: u16 = 0x5000;
/// Error code: RPDO timeout (an input from the CNC is stale).
pub const RPDO_TIMEOUT: u16 = 0x8250;
/// Error code: data set (the model refused the sample).
pub const MODEL: u16 = 0x6300;
/// Error code: PDO not processed due to length error.
pub const PDO_LENGTH: u16 = 0x8210;

/// Error register bit 0: generic error.
pub const REG_GENERIC: u8 = 1 << 0;
/// Error register bit 4: communication error.
pub const REG_COMMUNICATION: u8 = 1 << 4;
/// Error register bit 7: manufacturer-specific.
pub const REG_MANUFACTURER: u8 = 1 << 7;

/// The three kept conditions, in the order they are reported.
const CONDITIONS: [(u16, u16, u8); 3] = [
    (
        StatusFlags::SENSOR_FAULT
            | StatusFlags::IMPLAUSIBLE
            | StatusFlags::RATE_OF_CHANGE
            | StatusFlags::STUCK,
        SENSOR,
        REG_MANUFACTURER,
    ),
    (StatusFlags::STALE, RPDO_TIMEOUT, REG_COMMUNICATION),
    (StatusFlags::MODEL_FAULT, MODEL, REG_MANUFACTURER),
];

/// Most EMCYs one sample produces: one per condition that starts, plus one
/// reset.
pub const MAX_PER_SAMPLE: usize = CONDITIONS.len() + 1;

/// An EMCY's 8 bytes.
pub fn emcy_bytes(code: u16, register: u8, flags: u16, faulty_channels: u32) -> [u8; 8] {
    let [c0, c1] = code.to_le_bytes();
    let [f0, f1] = flags.to_le_bytes();
    let [m0, m1, m2, _] = faulty_channels.to_le_bytes();
    [c0, c1, register, f0, f1, m0, m1, m2]
}

/// Which conditions are active.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EmcyProducer {
    active: u8,
}

impl EmcyProducer {
    /// No condition active.
    pub const fn new() -> Self {
        Self { active: 0 }
    }

    /// The error register (object 0x1001) for the active conditions.
    pub fn register(&self) -> u8 {
        let mut reg = 0;
        for (i, (_, _, bits)) in CONDITIONS.iter().enumerate() {
            if self.active & (1 << i) != 0 {
                reg |= REG_GENERIC | bits;
            }
        }
        reg
    }

    /// One sample's flags: the EMCYs to send (conditions that started, in
    /// table order, then one reset if any ended).
    pub fn on_sample(
        &mut self,
        flags: StatusFlags,
        faulty_channels: u32,
    ) -> heapless::Vec<[u8; 8], MAX_PER_SAMPLE> {
        let mut now = 0u8;
        for (i, (mask, _, _)) in CONDITIONS.iter().enumerate() {
            if flags.0 & mask != 0 {
                now |= 1 << i;
            }
        }
        let started = now & !self.active;
        let ended = self.active & !now;
        self.active = now;
        let reg = self.register();
        let mut out = heapless::Vec::new();
        for (i, (_, code, _)) in CONDITIONS.iter().enumerate() {
            if started & (1 << i) != 0 {
                // Capacity holds every condition plus one reset.
                let _ = out.push(emcy_bytes(*code, reg, flags.0, faulty_channels));
            }
        }
        if ended != 0 {
            let _ = out.push(emcy_bytes(RESET, reg, flags.0, faulty_channels));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sensor_fault_and_its_reset_exact_bytes() {
        let mut e = EmcyProducer::new();
        assert!(e.on_sample(StatusFlags(0), 0).is_empty());
        // Input 2 open: SENSOR_FAULT, mask 0b100.
        let out = e.on_sample(StatusFlags(StatusFlags::SENSOR_FAULT), 0b100);
        assert_eq!(
            out.as_slice(),
            &[[0x00, 0x50, 0x81, 0x01, 0x00, 0x04, 0x00, 0x00]]
        );
        assert_eq!(e.register(), 0x81);
        // Still faulty: nothing new.
        assert!(e
            .on_sample(StatusFlags(StatusFlags::SENSOR_FAULT), 0b100)
            .is_empty());
        // The CNC's speed goes stale too: 0x8250, register adds bit 4.
        let both = StatusFlags(StatusFlags::SENSOR_FAULT | StatusFlags::STALE);
        let out = e.on_sample(both, 0x80_0004);
        assert_eq!(
            out.as_slice(),
            &[[0x50, 0x82, 0x91, 0x05, 0x00, 0x04, 0x00, 0x80]]
        );
        // The sensor recovers: a reset, the register keeps the stale bits.
        let out = e.on_sample(StatusFlags(StatusFlags::STALE), 0x80_0000);
        assert_eq!(
            out.as_slice(),
            &[[0x00, 0x00, 0x11, 0x04, 0x00, 0x00, 0x00, 0x80]]
        );
        // All clear: reset with register 0.
        let out = e.on_sample(StatusFlags(0), 0);
        assert_eq!(out.as_slice(), &[[0, 0, 0, 0, 0, 0, 0, 0]]);
        assert_eq!(e.register(), 0);
    }

    #[test]
    fn model_fault_and_implausible() {
        let mut e = EmcyProducer::new();
        let f = StatusFlags(StatusFlags::MODEL_FAULT | StatusFlags::IMPLAUSIBLE);
        let out = e.on_sample(f, 1);
        // Table order: sensor (implausible) first, then model.
        assert_eq!(
            out.as_slice(),
            &[
                [0x00, 0x50, 0x81, 0x08, 0x04, 0x01, 0x00, 0x00],
                [0x00, 0x63, 0x81, 0x08, 0x04, 0x01, 0x00, 0x00],
            ]
        );
    }
}
