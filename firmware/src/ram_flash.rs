//! NOR flash in RAM for tests of the upload path, here, in host-tools and
//! in the stack bench (feature `ram-flash`, and `test-support` for
//! [`HeapFlash`], on the heap; never on the board).
//!
//! Behaves as the STM32's flash does where it matters: erase sets 0xFF, a
//! write can only clear bits (writing a 1 over a 0 is an error, as it would
//! silently fail on chip), the contents are readable in place
//! ([`MappedFlash`]), and an optional byte budget cuts the power mid-write.
//! The bytes live in any buffer: a `Vec` on the host, a static array where
//! there is no heap (`firmware/qemu-bench`'s `stack`).

use embedded_storage::nor_flash::{
    check_erase, check_read, check_write, ErrorType, NorFlash, NorFlashErrorKind, ReadNorFlash,
};

use crate::upload::MappedFlash;

/// See the module docs. `WRITE_SIZE` 4 (stricter than the F446's 1, so
/// alignment bugs show), `ERASE_SIZE` 4 KiB.
#[derive(Clone, Debug)]
pub struct RamFlash<B> {
    data: B,
    /// Bytes that may still be written before the "power cut" (`None`: no cut).
    pub budget: Option<usize>,
    /// Erase operations so far.
    pub erases: usize,
}

#[cfg(any(test, feature = "test-support"))]
extern crate alloc;

/// The flash on the heap (`test-support`): what host tests use.
#[cfg(any(test, feature = "test-support"))]
pub type HeapFlash = RamFlash<alloc::vec::Vec<u8>>;

#[cfg(any(test, feature = "test-support"))]
impl HeapFlash {
    /// `len` erased bytes, on the heap.
    pub fn new(len: usize) -> Self {
        Self::over(alloc::vec![0xFF; len])
    }
}

impl<B: AsRef<[u8]> + AsMut<[u8]>> RamFlash<B> {
    /// Flash over `data`, as it is (fill it with 0xFF for an erased one).
    pub fn over(data: B) -> Self {
        Self {
            data,
            budget: None,
            erases: 0,
        }
    }

    /// The contents.
    pub fn bytes(&self) -> &[u8] {
        self.data.as_ref()
    }

    /// The contents, writable without flash rules (to damage them in tests).
    pub fn bytes_mut(&mut self) -> &mut [u8] {
        self.data.as_mut()
    }
}

impl<B> ErrorType for RamFlash<B> {
    type Error = NorFlashErrorKind;
}

impl<B: AsRef<[u8]> + AsMut<[u8]>> ReadNorFlash for RamFlash<B> {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        check_read(self, offset, bytes.len())?;
        let from = offset as usize;
        let src = self
            .bytes()
            .get(from..from + bytes.len())
            .ok_or(NorFlashErrorKind::OutOfBounds)?;
        bytes.copy_from_slice(src);
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.bytes().len()
    }
}

impl<B: AsRef<[u8]> + AsMut<[u8]>> NorFlash for RamFlash<B> {
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = 4096;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        check_erase(self, from, to)?;
        self.erases += 1;
        self.bytes_mut()
            .get_mut(from as usize..to as usize)
            .ok_or(NorFlashErrorKind::OutOfBounds)?
            .fill(0xFF);
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        check_write(self, offset, bytes.len())?;
        let budget = &mut self.budget;
        let cells = self
            .data
            .as_mut()
            .get_mut(offset as usize..)
            .ok_or(NorFlashErrorKind::OutOfBounds)?;
        for (cell, b) in cells.iter_mut().zip(bytes) {
            if let Some(left) = budget {
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

impl<B: AsRef<[u8]> + AsMut<[u8]>> MappedFlash for RamFlash<B> {
    fn mapped(&self) -> &[u8] {
        self.bytes()
    }
}
