//! NOR flash in RAM for tests of the upload path, here and in host-tools
//! (feature `test-support`; never on the board).
//!
//! Behaves as the STM32's flash does where it matters: erase sets 0xFF, a
//! write can only clear bits (writing a 1 over a 0 is an error, as it would
//! silently fail on chip), the contents are readable in place
//! ([`MappedFlash`]), and an optional byte budget cuts the power mid-write.

extern crate alloc;

use alloc::vec;
use alloc::vec::Vec;
use embedded_storage::nor_flash::{
    check_erase, check_read, check_write, ErrorType, NorFlash, NorFlashErrorKind, ReadNorFlash,
};

use crate::upload::MappedFlash;

/// See the module docs. `WRITE_SIZE` 4 (stricter than the F446's 1, so
/// alignment bugs show), `ERASE_SIZE` 4 KiB.
#[derive(Clone, Debug)]
pub struct RamFlash {
    data: Vec<u8>,
    /// Bytes that may still be written before the "power cut" (`None`: no cut).
    pub budget: Option<usize>,
    /// Erase operations so far.
    pub erases: usize,
}

impl RamFlash {
    /// `len` erased bytes.
    pub fn new(len: usize) -> Self {
        Self {
            data: vec![0xFF; len],
            budget: None,
            erases: 0,
        }
    }

    /// The contents.
    pub fn bytes(&self) -> &[u8] {
        &self.data
    }

    /// The contents, writable without flash rules (to damage them in tests).
    pub fn bytes_mut(&mut self) -> &mut [u8] {
        &mut self.data
    }
}

impl ErrorType for RamFlash {
    type Error = NorFlashErrorKind;
}

impl ReadNorFlash for RamFlash {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        check_read(self, offset, bytes.len())?;
        let from = offset as usize;
        let src = self
            .data
            .get(from..from + bytes.len())
            .ok_or(NorFlashErrorKind::OutOfBounds)?;
        bytes.copy_from_slice(src);
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.data.len()
    }
}

impl NorFlash for RamFlash {
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = 4096;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        check_erase(self, from, to)?;
        self.erases += 1;
        self.data
            .get_mut(from as usize..to as usize)
            .ok_or(NorFlashErrorKind::OutOfBounds)?
            .fill(0xFF);
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        check_write(self, offset, bytes.len())?;
        let cells = self
            .data
            .get_mut(offset as usize..)
            .ok_or(NorFlashErrorKind::OutOfBounds)?;
        for (cell, b) in cells.iter_mut().zip(bytes) {
            if let Some(left) = &mut self.budget {
                if *left == 0 {
                    return Err(NorFlashErrorKind::Other); // power cut
                }
                *left -= 1;
            }
            if b & !*cell != 0 {
                return Err(NorFlashErrorKind::Other); // 0 -> 1 without erase
            }
            *cell &= b;
        }
        Ok(())
    }
}

impl MappedFlash for RamFlash {
    fn mapped(&self) -> &[u8] {
        &self.data
    }
}
