//! A MAX31865 in software: the register file of the chip behind an
//! `embedded_hal::spi::SpiDevice`, so that `replay` drives the firmware's
//! own driver (`max31865`) with the codes a real converter would return for
//! a run's temperatures.
//!
//! It models what the driver relies on (MAX31865 datasheet, "Registers"):
//! the first byte of a transaction is the address (bit 7 set for a write),
//! further bytes auto-increment it; the configuration's 1-shot and
//! fault-status-clear bits clear themselves, and a fault-detection cycle
//! completes at once; the RTD LSB's bit 0 flags a fault whose cause is in
//! the fault-status register. Conversion timing is not modelled: the code
//! set last is the one read.
//!
//! Clones share one register file: the driver owns one handle, `replay`
//! keeps another to set each sample's code.

use core::convert::Infallible;
use embedded_hal::spi::{ErrorType, Operation, SpiDevice};
use std::cell::RefCell;
use std::rc::Rc;

/// Register addresses and bits (datasheet names).
const CONFIG: usize = 0x00;
const RTD_MSB: usize = 0x01;
const RTD_LSB: usize = 0x02;
const FAULT_STATUS: usize = 0x07;
const WRITE: u8 = 0x80;
const CFG_ONE_SHOT: u8 = 1 << 5;
const CFG_FAULT_CYCLE_MASK: u8 = 0b0000_1100;
const CFG_FAULT_CLEAR: u8 = 1 << 1;

/// One simulated converter (a handle to its register file).
#[derive(Clone, Debug, Default)]
pub struct VirtualMax31865 {
    regs: Rc<RefCell<[u8; 8]>>,
}

impl VirtualMax31865 {
    /// A chip at power-up (every register 0).
    pub fn new() -> Self {
        Self::default()
    }

    /// Makes the next reads return the 15-bit `code` with no fault.
    pub fn set_code(&self, code: u16) {
        let word = (code & 0x7FFF) << 1;
        let [msb, lsb] = word.to_be_bytes();
        let mut regs = self.regs.borrow_mut();
        regs[RTD_MSB] = msb;
        regs[RTD_LSB] = lsb;
        regs[FAULT_STATUS] = 0;
    }

    /// Makes the next reads flag a fault with fault-status byte `status`
    /// (e.g. 0x80: RTD above the high threshold, as an open RTD reads).
    pub fn set_fault(&self, status: u8) {
        let mut regs = self.regs.borrow_mut();
        regs[RTD_LSB] |= 1;
        regs[FAULT_STATUS] = status;
    }

    fn read(&self, address: usize) -> u8 {
        self.regs.borrow().get(address).copied().unwrap_or(0)
    }

    fn write(&self, address: usize, value: u8) {
        let mut regs = self.regs.borrow_mut();
        if address == CONFIG {
            // Self-clearing bits; the fault-detection cycle ends at once.
            if value & CFG_FAULT_CLEAR != 0 {
                regs[FAULT_STATUS] = 0;
                regs[RTD_LSB] &= !1;
            }
            regs[CONFIG] = value & !(CFG_ONE_SHOT | CFG_FAULT_CLEAR | CFG_FAULT_CYCLE_MASK);
        } else if !matches!(address, RTD_MSB | RTD_LSB | FAULT_STATUS) {
            if let Some(reg) = regs.get_mut(address) {
                *reg = value;
            }
        }
    }
}

impl ErrorType for VirtualMax31865 {
    type Error = Infallible;
}

impl SpiDevice for VirtualMax31865 {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), Infallible> {
        // None until the address byte has been clocked in.
        let mut at: Option<(bool, usize)> = None;
        let mut take = |chip: &Self, mosi: u8| -> u8 {
            match &mut at {
                None => {
                    at = Some((mosi & WRITE != 0, usize::from(mosi & 0x07)));
                    0xFF
                }
                Some((write, addr)) => {
                    let miso = chip.read(*addr);
                    if *write {
                        chip.write(*addr, mosi);
                    }
                    *addr = (*addr + 1) % 8;
                    miso
                }
            }
        };
        for op in operations.iter_mut() {
            match op {
                Operation::Write(bytes) => {
                    for &b in bytes.iter() {
                        take(self, b);
                    }
                }
                Operation::Read(buf) => {
                    for b in buf.iter_mut() {
                        *b = take(self, 0);
                    }
                }
                Operation::Transfer(read, write) => {
                    for i in 0..read.len().max(write.len()) {
                        let miso = take(self, write.get(i).copied().unwrap_or(0));
                        if let Some(r) = read.get_mut(i) {
                            *r = miso;
                        }
                    }
                }
                Operation::TransferInPlace(buf) => {
                    for b in buf.iter_mut() {
                        *b = take(self, *b);
                    }
                }
                Operation::DelayNs(_) => {}
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use max31865::{Config, Filter, Max31865, Mode, Wires};

    #[test]
    fn the_driver_reads_back_what_was_set() {
        let chip = VirtualMax31865::new();
        chip.set_code(8192);
        let cfg = Config::new(Wires::Four, Filter::Hz50, Mode::Auto);
        // Init verifies the configuration by reading it back: the register
        // file must hold what the driver wrote.
        let mut rtd = Max31865::new(chip, cfg).expect("init verifies");
        assert_eq!(rtd.read_code().unwrap().value(), 8192);
    }

    #[test]
    fn a_fault_reaches_the_driver_and_clears() {
        let chip = VirtualMax31865::new();
        let cfg = Config::new(Wires::Three, Filter::Hz60, Mode::Auto);
        let mut rtd = Max31865::new(chip.clone(), cfg).unwrap();
        chip.set_code(100);
        chip.set_fault(0x80);
        match rtd.read_code() {
            Err(max31865::Error::Fault(f)) => assert!(f.rtd_high_threshold()),
            other => panic!("expected a high-threshold fault, got {other:?}"),
        }
        rtd.clear_fault().unwrap();
        assert_eq!(rtd.read_code().unwrap().value(), 100);
    }
}
