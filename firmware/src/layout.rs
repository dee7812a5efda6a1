//! Memory map of the STM32F446RE as the firmware uses it.
//!
//! These constants mirror `memory.x` at the workspace root, which is what the
//! linker actually uses. The two are kept in step three ways: the compile-time
//! checks at the bottom of this file (regions tile the flash on sector
//! boundaries), `ASSERT`s in `memory.x` itself, and a start-up check on the
//! board that the `_model_a_start`/`_model_b_start` linker symbols equal
//! [`MODEL_A`]/[`MODEL_B`].
//!
//! Flash is erased a whole sector at a time, so the A/B model slots are whole
//! sectors of their own: a new model blob is erased and written into the
//! inactive slot while the active one keeps being used, then the firmware
//! switches slots. The F446 has one flash bank, so the CPU stalls on flash
//! reads while a sector is being erased (128 KiB: 1-2 s at x32, 2-4 s at
//! the x8 stm32f4xx-hal uses; DS10693 "Flash memory programming"): the
//! erase must run in a low-priority task with the watchdog in mind
//! (`board::FLASH_SECTOR_ERASE_MAX_MS`, `board::IWDG_TIMEOUT_MS`).

/// One contiguous address range (a `MEMORY` region of `memory.x`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Region {
    /// Region name as spelt in `memory.x`.
    pub name: &'static str,
    /// First address.
    pub origin: u32,
    /// Length in bytes.
    pub len: u32,
    /// What the region holds and why it is laid out this way.
    pub purpose: &'static str,
}

impl Region {
    /// One past the last byte.
    pub const fn end(&self) -> u32 {
        self.origin + self.len
    }

    /// Whether `addr` lies inside the region.
    pub const fn contains(&self, addr: u32) -> bool {
        addr >= self.origin && addr < self.end()
    }
}

/// KiB in bytes.
const KIB: u32 = 1024;

/// Start of the main flash (RM0390, "Flash module organization").
pub const FLASH_BASE: u32 = 0x0800_0000;

/// Flash sector sizes in bytes, sector 0 first (RM0390, "Flash module organization").
pub const FLASH_SECTOR_SIZES: [u32; 8] = [
    16 * KIB,
    16 * KIB,
    16 * KIB,
    16 * KIB,
    64 * KIB,
    128 * KIB,
    128 * KIB,
    128 * KIB,
];

/// Total flash: 512 KiB on the STM32F446RE (the "E" in RE; DS10693 "Device summary").
pub const FLASH_TOTAL: u32 = 512 * KIB;

/// Start address of flash sector `n`.
pub const fn sector_start(n: usize) -> u32 {
    let mut addr = FLASH_BASE;
    let mut i = 0;
    while i < n {
        addr += FLASH_SECTOR_SIZES[i];
        i += 1;
    }
    addr
}

/// Firmware image: sectors 0-4 (128 KiB; the firmware is about 80 KiB).
pub const FLASH: Region = Region {
    name: "FLASH",
    origin: FLASH_BASE,
    len: 128 * KIB,
    purpose: "sectors 0-4: vector table, code, rodata",
};

/// CANopen settings (`canopen::store`): sector 5, so saving them never
/// erases code or a model.
pub const SETTINGS: Region = Region {
    name: "SETTINGS",
    origin: 0x0802_0000,
    len: 128 * KIB,
    purpose: "sector 5: CANopen settings log (SDO 0x1010 save)",
};

/// Model slot A: sector 6.
pub const MODEL_A: Region = Region {
    name: "MODEL_A",
    origin: 0x0804_0000,
    len: 128 * KIB,
    purpose: "sector 6: model blob slot A",
};

/// Model slot B: sector 7.
pub const MODEL_B: Region = Region {
    name: "MODEL_B",
    origin: 0x0806_0000,
    len: 128 * KIB,
    purpose: "sector 7: model blob slot B",
};

/// SRAM1 (112 KiB) + SRAM2 (16 KiB), contiguous (RM0390, "Memory map").
pub const RAM: Region = Region {
    name: "RAM",
    origin: 0x2000_0000,
    len: 128 * KIB,
    purpose: "SRAM1+SRAM2: data, bss, stack",
};

/// All regions of `memory.x`, in address order.
pub const REGIONS: [Region; 5] = [FLASH, SETTINGS, MODEL_A, MODEL_B, RAM];

// Compile-time checks: a wrong edit fails the build on host and target alike.
const _: () = {
    assert!(sector_start(8) == FLASH_BASE + FLASH_TOTAL);
    assert!(FLASH.origin == sector_start(0) && FLASH.end() == sector_start(5));
    assert!(SETTINGS.origin == sector_start(5) && SETTINGS.end() == sector_start(6));
    assert!(MODEL_A.origin == sector_start(6) && MODEL_A.end() == sector_start(7));
    assert!(MODEL_B.origin == sector_start(7) && MODEL_B.end() == sector_start(8));
    assert!(MODEL_A.len == MODEL_B.len);
};
