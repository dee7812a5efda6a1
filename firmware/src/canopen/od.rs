//! The object dictionary (CiA 301 §7.4): every object the hub exposes, as
//! one static, sorted table of typed entries, plus the values of those that
//! can change.
//!
//! Why a static table: the dictionary is fixed at build time (the EDS,
//! `firmware/thermcomp.eds`, describes exactly this table and a test checks
//! both ways), so names, types, access and limits live in flash and only
//! the current values take RAM: one `u32` per entry (about 350 bytes),
//! instead of a map of tagged values.
//!
//! Every value fits 32 bits except the three `VISIBLE_STRING`s (0x1008,
//! 0x1009, 0x100A), which are constants in flash and read by segmented
//! SDO upload. Values are stored as their little-endian bits (`REAL32` as
//! `f32::to_bits`, `INTEGER16` sign-extended), so a PDO or an SDO upload
//! takes the first `size` bytes of `to_le_bytes()`.
//!
//! Ranges: an entry with a [`Limit`] refuses an SDO download outside it
//! (CiA 301 §7.2.4.3.17: abort 0x0609_0031 too high, 0x0609_0032 too low,
//! 0x0609_0030 for a NaN). Checks across entries (ramp no faster than the
//! slew limit, plausibility min below max) are the node's
//! (`canopen::node`), which knows the other values.

use super::abort::SdoAbort;

/// CiA 301 §7.1 basic data types, by their object-dictionary index
/// (table 44), the number written as `DataType=` in the EDS.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum DataType {
    /// INTEGER16.
    Integer16,
    /// INTEGER32.
    Integer32,
    /// UNSIGNED8.
    Unsigned8,
    /// UNSIGNED16.
    Unsigned16,
    /// UNSIGNED24 (the 24-bit faulty-channel mask of STATUS).
    Unsigned24,
    /// UNSIGNED32.
    Unsigned32,
    /// REAL32 (IEEE 754 single).
    Real32,
    /// VISIBLE_STRING (constants only).
    VisibleString,
}

impl DataType {
    /// The data type's index (CiA 301 table 44), as in the EDS.
    pub const fn code(self) -> u16 {
        match self {
            Self::Integer16 => 0x0003,
            Self::Integer32 => 0x0004,
            Self::Unsigned8 => 0x0005,
            Self::Unsigned16 => 0x0006,
            Self::Unsigned24 => 0x0016,
            Self::Unsigned32 => 0x0007,
            Self::Real32 => 0x0008,
            Self::VisibleString => 0x0009,
        }
    }

    /// Size in bytes; 0 for a string (its length is the constant's).
    pub const fn size(self) -> usize {
        match self {
            Self::Unsigned8 => 1,
            Self::Integer16 | Self::Unsigned16 => 2,
            Self::Unsigned24 => 3,
            Self::Integer32 | Self::Unsigned32 | Self::Real32 => 4,
            Self::VisibleString => 0,
        }
    }
}

/// Access from the bus (CiA 306 §4.6.3 `AccessType`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    /// Read-only, never changes.
    Const,
    /// Read-only, the hub updates it (process values, error register).
    Ro,
    /// Read and write.
    Rw,
    /// Read and write, and written by an RPDO (the CNC's inputs).
    Rww,
}

impl Access {
    /// Whether an SDO download may write it.
    pub const fn writable(self) -> bool {
        matches!(self, Self::Rw | Self::Rww)
    }

    /// The EDS spelling.
    pub const fn eds(self) -> &'static str {
        match self {
            Self::Const => "const",
            Self::Ro => "ro",
            Self::Rw => "rw",
            Self::Rww => "rww",
        }
    }
}

/// The values an SDO download may write.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Limit {
    /// Any value of the type.
    Any,
    /// Unsigned, inclusive.
    U(u32, u32),
    /// REAL32, inclusive (NaN refused).
    F(f32, f32),
}

/// The default value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Default {
    /// Numeric, as its little-endian bits.
    Raw(u32),
    /// The node id plus this (a COB-ID; `$NODEID+0x...` in the EDS).
    NodeId(u32),
    /// A string constant.
    Text(&'static str),
}

/// One dictionary entry (index, subindex).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Object {
    /// Object index.
    pub index: u16,
    /// Subindex (0 for a VAR).
    pub sub: u8,
    /// Parameter name (the EDS `ParameterName`; host builds only).
    pub name: Name,
    /// Data type.
    pub ty: DataType,
    /// Access.
    pub access: Access,
    /// Whether a PDO may map it (the EDS `PDOMapping`).
    pub pdo: bool,
    /// Default value.
    pub default: Default,
    /// Values a download may write.
    pub limit: Limit,
}

/// An entry's name, for the EDS and host tools. On the board it is empty
/// (zero bytes): the names are about 2.5 KiB of text the firmware never
/// reads, and the EDS test runs on the host.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Name {
    #[cfg(not(target_os = "none"))]
    text: &'static str,
}

impl Name {
    /// A name (dropped at compile time on the board).
    pub const fn new(text: &'static str) -> Self {
        #[cfg(target_os = "none")]
        let _ = text;
        Self {
            #[cfg(not(target_os = "none"))]
            text,
        }
    }

    /// The name.
    #[cfg(not(target_os = "none"))]
    pub const fn as_str(&self) -> &'static str {
        self.text
    }
}

/// An object with subindices (ARRAY or RECORD, CiA 301 §7.4.3): its name
/// and kind for the EDS. Objects not listed here are VARs at subindex 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Group {
    /// Object index.
    pub index: u16,
    /// Object name.
    pub name: &'static str,
    /// `ObjectType` in the EDS: 0x8 ARRAY, 0x9 RECORD.
    pub object_type: u8,
}

/// An entry; PDO-mappable exactly when the hub (`Ro`: process values,
/// error register) or an RPDO (`Rww`) updates it.
const fn var(
    index: u16,
    sub: u8,
    name: &'static str,
    ty: DataType,
    access: Access,
    default: Default,
    limit: Limit,
) -> Object {
    Object {
        index,
        sub,
        name: Name::new(name),
        ty,
        access,
        pdo: matches!(access, Access::Ro | Access::Rww),
        default,
        limit,
    }
}

const fn konst(index: u16, sub: u8, name: &'static str, ty: DataType, value: u32) -> Object {
    var(
        index,
        sub,
        name,
        ty,
        Access::Const,
        Default::Raw(value),
        Limit::Any,
    )
}

const fn count(index: u16, n: u8) -> Object {
    konst(
        index,
        0,
        "Highest sub-index supported",
        DataType::Unsigned8,
        n as u32,
    )
}

const fn cob(index: u16, sub: u8, name: &'static str, base: u32) -> Object {
    var(
        index,
        sub,
        name,
        U32,
        Access::Const,
        Default::NodeId(base),
        Limit::Any,
    )
}

const fn map(index: u16, sub: u8, entry: u32) -> Object {
    let names = [
        "",
        "Mapping entry 1",
        "Mapping entry 2",
        "Mapping entry 3",
        "Mapping entry 4",
        "Mapping entry 5",
    ];
    konst(index, sub, names[sub as usize], U32, entry)
}

const fn real(index: u16, sub: u8, name: &'static str, default: f32, min: f32, max: f32) -> Object {
    var(
        index,
        sub,
        name,
        DataType::Real32,
        Access::Rw,
        Default::Raw(default.to_bits()),
        Limit::F(min, max),
    )
}

const fn process(index: u16, sub: u8, name: &'static str, ty: DataType) -> Object {
    var(
        index,
        sub,
        name,
        ty,
        Access::Ro,
        Default::Raw(0),
        Limit::Any,
    )
}

const fn cnc(index: u16, sub: u8, name: &'static str, ty: DataType, not_available: u32) -> Object {
    var(
        index,
        sub,
        name,
        ty,
        Access::Rww,
        Default::Raw(not_available),
        Limit::Any,
    )
}

use DataType::{Unsigned16 as U16, Unsigned32 as U32, Unsigned8 as U8};

/// A PDO mapping entry (CiA 301 §7.4.8.2, 0x1600/0x1A00): index in bits
/// 31-16, subindex in 15-8, length in bits in 7-0.
pub const fn mapping(index: u16, sub: u8, bits: u8) -> u32 {
    (index as u32) << 16 | (sub as u32) << 8 | bits as u32
}

/// "Save" in ASCII as a little-endian u32: written to 0x1010:01 it stores
/// the parameters (CiA 301 §7.5.2.13).
pub const SAVE_SIGNATURE: u32 = u32::from_le_bytes(*b"save");
/// "load": written to 0x1011:01 it restores the defaults (CiA 301 §7.5.2.14).
pub const LOAD_SIGNATURE: u32 = u32::from_le_bytes(*b"load");

/// Transmission type 254 (0xFE): event-driven, manufacturer-specific
/// (CiA 301 §7.5.2.35): the hub sends its TPDOs once per sample.
pub const EVENT_DRIVEN: u32 = 0xFE;

/// Manufacturer device name (0x1008).
pub const DEVICE_NAME: &str = "thermcomp hub";
/// Manufacturer hardware version (0x1009).
pub const HARDWARE_VERSION: &str = "NUCLEO-F446RE";
/// Manufacturer software version (0x100A): the dictionary's version, which
/// changes with this table and the EDS (not with every firmware release).
pub const SOFTWARE_VERSION: &str = "thermcomp OD 1";

// Process values (manufacturer area, CiA 301 §7.4.1: 0x2000-0x5FFF).
/// Offsets, 0.1 um (ARRAY, subindex = model output 1..4).
pub const OFFSETS: u16 = 0x2100;
/// Hub state code (`report::HubState::code`).
pub const HUB_STATE: u16 = 0x2101;
/// Rolling counter (low byte of the sample counter).
pub const COUNTER: u16 = 0x2102;
/// Status flags (`report::StatusFlags`).
pub const STATUS_FLAGS: u16 = 0x2103;
/// Faulty-channel mask (24 bits).
pub const FAULTY_CHANNELS: u16 = 0x2104;
/// Model shape: bits 0-4 input count, 5-7 output count.
pub const MODEL_SHAPE: u16 = 0x2105;
/// Consecutive refused samples.
pub const CONSECUTIVE_FAULTS: u16 = 0x2106;
/// Slope of one positional output (RECORD: slope, reference, output).
pub const SLOPE: u16 = 0x2107;
/// The CNC's spindle (RECORD: speed 0.01 rpm, power 0.01 kW).
pub const SPINDLE: u16 = 0x2200;
/// The CNC's tool and position (RECORD: tool length, axis position, 0.001 mm).
pub const TOOL_POSITION: u16 = 0x2201;

// Settings (stored by 0x1010, applied at the next reset).
/// Clamp per output, um (ARRAY 1..4).
pub const CLAMP: u16 = 0x2000;
/// Slew limit per output, um/s (ARRAY 1..4).
pub const SLEW: u16 = 0x2001;
/// Hold time, s.
pub const HOLD_TIME: u16 = 0x2002;
/// Ramp-to-zero rate, um/s.
pub const RAMP_RATE: u16 = 0x2003;
/// Recovery time, s.
pub const RECOVER_TIME: u16 = 0x2004;
/// Plausibility window, deg C (RECORD: min, max).
pub const PLAUSIBLE: u16 = 0x2005;
/// Node id.
pub const NODE_ID: u16 = 0x2006;
/// CNC input timeout (RPDO deadline), ms.
pub const CNC_TIMEOUT: u16 = 0x2007;
/// Start operational without an NMT master (1) or wait for one (0).
pub const AUTO_START: u16 = 0x2008;

/// Producer heartbeat time, ms (CiA 301 §7.5.2.31).
pub const HEARTBEAT_TIME: u16 = 0x1017;
/// Error register (CiA 301 §7.5.2.2).
pub const ERROR_REGISTER: u16 = 0x1001;
/// Store parameters (CiA 301 §7.5.2.13).
pub const STORE: u16 = 0x1010;
/// Restore default parameters (CiA 301 §7.5.2.14).
pub const RESTORE: u16 = 0x1011;

/// Largest offset the 0.1 um INTEGER16 carries, um: a clamp beyond it
/// would let the frame saturate before the clamp acts.
const MAX_CLAMP_UM: f32 = 3276.7;
/// Longest hold/recovery time accepted, s (a day: anything longer is a typo).
const MAX_TIME_S: f32 = 86_400.0;
/// Fastest slew/ramp accepted, um/s: 1 mm per second is a crash, not a
/// thermal correction.
const MAX_RATE_UM_PER_S: f32 = 1000.0;
/// Slowest slew/ramp accepted, um/s (zero would freeze the offsets).
const MIN_RATE_UM_PER_S: f32 = 0.001;
/// PT100 range the converter reads, deg C (IEC 60751: -200..850).
const PT100_MIN_C: f32 = -200.0;
/// See [`PT100_MIN_C`].
const PT100_MAX_C: f32 = 850.0;

/// The objects with subindices.
pub const GROUPS: &[Group] = &[
    Group {
        index: STORE,
        name: "Store parameters",
        object_type: 8,
    },
    Group {
        index: RESTORE,
        name: "Restore default parameters",
        object_type: 8,
    },
    Group {
        index: 0x1018,
        name: "Identity object",
        object_type: 9,
    },
    Group {
        index: 0x1200,
        name: "SDO server parameter",
        object_type: 9,
    },
    Group {
        index: 0x1400,
        name: "RPDO1 communication parameter",
        object_type: 9,
    },
    Group {
        index: 0x1401,
        name: "RPDO2 communication parameter",
        object_type: 9,
    },
    Group {
        index: 0x1600,
        name: "RPDO1 mapping parameter",
        object_type: 9,
    },
    Group {
        index: 0x1601,
        name: "RPDO2 mapping parameter",
        object_type: 9,
    },
    Group {
        index: 0x1800,
        name: "TPDO1 communication parameter",
        object_type: 9,
    },
    Group {
        index: 0x1801,
        name: "TPDO2 communication parameter",
        object_type: 9,
    },
    Group {
        index: 0x1802,
        name: "TPDO3 communication parameter",
        object_type: 9,
    },
    Group {
        index: 0x1803,
        name: "TPDO4 communication parameter",
        object_type: 9,
    },
    Group {
        index: 0x1A00,
        name: "TPDO1 mapping parameter",
        object_type: 9,
    },
    Group {
        index: 0x1A01,
        name: "TPDO2 mapping parameter",
        object_type: 9,
    },
    Group {
        index: 0x1A02,
        name: "TPDO3 mapping parameter",
        object_type: 9,
    },
    Group {
        index: 0x1A03,
        name: "TPDO4 mapping parameter",
        object_type: 9,
    },
    Group {
        index: CLAMP,
        name: "Clamp um",
        object_type: 8,
    },
    Group {
        index: SLEW,
        name: "Slew limit um per s",
        object_type: 8,
    },
    Group {
        index: PLAUSIBLE,
        name: "Plausible temperature window",
        object_type: 9,
    },
    Group {
        index: OFFSETS,
        name: "Offsets",
        object_type: 8,
    },
    Group {
        index: SLOPE,
        name: "Slope",
        object_type: 9,
    },
    Group {
        index: SPINDLE,
        name: "CNC spindle",
        object_type: 9,
    },
    Group {
        index: TOOL_POSITION,
        name: "CNC tool and position",
        object_type: 9,
    },
];

/// Every entry, sorted by (index, subindex).
pub const OBJECTS: &[Object] = &[
    konst(0x1000, 0, "Device type", U32, 0),
    process(ERROR_REGISTER, 0, "Error register", U8),
    var(
        0x1008,
        0,
        "Manufacturer device name",
        DataType::VisibleString,
        Access::Const,
        Default::Text(DEVICE_NAME),
        Limit::Any,
    ),
    var(
        0x1009,
        0,
        "Manufacturer hardware version",
        DataType::VisibleString,
        Access::Const,
        Default::Text(HARDWARE_VERSION),
        Limit::Any,
    ),
    var(
        0x100A,
        0,
        "Manufacturer software version",
        DataType::VisibleString,
        Access::Const,
        Default::Text(SOFTWARE_VERSION),
        Limit::Any,
    ),
    count(STORE, 1),
    var(
        STORE,
        1,
        "Save all parameters",
        U32,
        Access::Rw,
        Default::Raw(1),
        Limit::Any,
    ),
    count(RESTORE, 1),
    var(
        RESTORE,
        1,
        "Restore all default parameters",
        U32,
        Access::Rw,
        Default::Raw(1),
        Limit::Any,
    ),
    cob(0x1014, 0, "COB-ID EMCY", 0x80),
    var(
        HEARTBEAT_TIME,
        0,
        "Producer heartbeat time",
        U16,
        Access::Rw,
        Default::Raw(1000),
        Limit::Any,
    ),
    count(0x1018, 4),
    konst(0x1018, 1, "Vendor-ID", U32, 0),
    konst(0x1018, 2, "Product code", U32, 0x5443_0001),
    konst(0x1018, 3, "Revision number", U32, 0x0001_0000),
    konst(0x1018, 4, "Serial number", U32, 0),
    count(0x1200, 2),
    cob(0x1200, 1, "COB-ID client to server", 0x600),
    cob(0x1200, 2, "COB-ID server to client", 0x580),
    count(0x1400, 2),
    cob(0x1400, 1, "COB-ID used by RPDO", 0x200),
    konst(0x1400, 2, "Transmission type", U8, EVENT_DRIVEN),
    count(0x1401, 2),
    cob(0x1401, 1, "COB-ID used by RPDO", 0x300),
    konst(0x1401, 2, "Transmission type", U8, EVENT_DRIVEN),
    count(0x1600, 3),
    map(0x1600, 1, mapping(SPINDLE, 1, 32)),
    map(0x1600, 2, mapping(SPINDLE, 2, 16)),
    // Dummy UNSIGNED16 (CiA 301 §7.4.8.2: index 0x0006): bytes 6-7 ignored.
    map(0x1600, 3, mapping(0x0006, 0, 16)),
    count(0x1601, 2),
    map(0x1601, 1, mapping(TOOL_POSITION, 1, 32)),
    map(0x1601, 2, mapping(TOOL_POSITION, 2, 32)),
    count(0x1800, 5),
    cob(0x1800, 1, "COB-ID used by TPDO", 0x180),
    konst(0x1800, 2, "Transmission type", U8, EVENT_DRIVEN),
    konst(0x1800, 3, "Inhibit time", U16, 0),
    konst(0x1800, 5, "Event timer", U16, 0),
    count(0x1801, 5),
    cob(0x1801, 1, "COB-ID used by TPDO", 0x280),
    konst(0x1801, 2, "Transmission type", U8, EVENT_DRIVEN),
    konst(0x1801, 3, "Inhibit time", U16, 0),
    konst(0x1801, 5, "Event timer", U16, 0),
    count(0x1802, 5),
    cob(0x1802, 1, "COB-ID used by TPDO", 0x380),
    konst(0x1802, 2, "Transmission type", U8, EVENT_DRIVEN),
    konst(0x1802, 3, "Inhibit time", U16, 0),
    konst(0x1802, 5, "Event timer", U16, 0),
    count(0x1803, 5),
    cob(0x1803, 1, "COB-ID used by TPDO", 0x480),
    konst(0x1803, 2, "Transmission type", U8, EVENT_DRIVEN),
    konst(0x1803, 3, "Inhibit time", U16, 0),
    konst(0x1803, 5, "Event timer", U16, 0),
    count(0x1A00, 5),
    map(0x1A00, 1, mapping(OFFSETS, 1, 16)),
    map(0x1A00, 2, mapping(OFFSETS, 2, 16)),
    map(0x1A00, 3, mapping(OFFSETS, 3, 16)),
    map(0x1A00, 4, mapping(HUB_STATE, 0, 8)),
    map(0x1A00, 5, mapping(COUNTER, 0, 8)),
    count(0x1A01, 5),
    map(0x1A01, 1, mapping(STATUS_FLAGS, 0, 16)),
    map(0x1A01, 2, mapping(FAULTY_CHANNELS, 0, 24)),
    map(0x1A01, 3, mapping(MODEL_SHAPE, 0, 8)),
    map(0x1A01, 4, mapping(CONSECUTIVE_FAULTS, 0, 8)),
    map(0x1A01, 5, mapping(COUNTER, 0, 8)),
    count(0x1A02, 4),
    map(0x1A02, 1, mapping(OFFSETS, 4, 16)),
    // Dummy UNSIGNED32 (index 0x0007): bytes 2-5 zero.
    map(0x1A02, 2, mapping(0x0007, 0, 32)),
    map(0x1A02, 3, mapping(HUB_STATE, 0, 8)),
    map(0x1A02, 4, mapping(COUNTER, 0, 8)),
    count(0x1A03, 4),
    map(0x1A03, 1, mapping(SLOPE, 1, 32)),
    map(0x1A03, 2, mapping(SLOPE, 2, 16)),
    map(0x1A03, 3, mapping(SLOPE, 3, 8)),
    map(0x1A03, 4, mapping(COUNTER, 0, 8)),
    count(CLAMP, 4),
    real(CLAMP, 1, "Output 1", 500.0, 0.1, MAX_CLAMP_UM),
    real(CLAMP, 2, "Output 2", 500.0, 0.1, MAX_CLAMP_UM),
    real(CLAMP, 3, "Output 3", 500.0, 0.1, MAX_CLAMP_UM),
    real(CLAMP, 4, "Output 4", 500.0, 0.1, MAX_CLAMP_UM),
    count(SLEW, 4),
    real(
        SLEW,
        1,
        "Output 1",
        2.0,
        MIN_RATE_UM_PER_S,
        MAX_RATE_UM_PER_S,
    ),
    real(
        SLEW,
        2,
        "Output 2",
        2.0,
        MIN_RATE_UM_PER_S,
        MAX_RATE_UM_PER_S,
    ),
    real(
        SLEW,
        3,
        "Output 3",
        2.0,
        MIN_RATE_UM_PER_S,
        MAX_RATE_UM_PER_S,
    ),
    real(
        SLEW,
        4,
        "Output 4",
        2.0,
        MIN_RATE_UM_PER_S,
        MAX_RATE_UM_PER_S,
    ),
    real(HOLD_TIME, 0, "Hold time s", 60.0, 0.0, MAX_TIME_S),
    real(
        RAMP_RATE,
        0,
        "Ramp rate um per s",
        1.0,
        MIN_RATE_UM_PER_S,
        MAX_RATE_UM_PER_S,
    ),
    real(RECOVER_TIME, 0, "Recovery time s", 10.0, 0.0, MAX_TIME_S),
    count(PLAUSIBLE, 2),
    real(
        PLAUSIBLE,
        1,
        "Minimum deg C",
        -20.0,
        PT100_MIN_C,
        PT100_MAX_C,
    ),
    real(
        PLAUSIBLE,
        2,
        "Maximum deg C",
        120.0,
        PT100_MIN_C,
        PT100_MAX_C,
    ),
    var(
        NODE_ID,
        0,
        "Node id",
        U8,
        Access::Rw,
        Default::Raw(1),
        Limit::U(1, 127),
    ),
    var(
        CNC_TIMEOUT,
        0,
        "CNC input timeout ms",
        U32,
        Access::Rw,
        Default::Raw(crate::board::CNC_INPUT_TIMEOUT_MS),
        Limit::U(crate::board::CNC_INPUT_TIMEOUT_MIN_MS, 600_000),
    ),
    var(
        AUTO_START,
        0,
        "Start without NMT master",
        U8,
        Access::Rw,
        Default::Raw(1),
        Limit::U(0, 1),
    ),
    count(OFFSETS, 4),
    process(OFFSETS, 1, "Output 1 0.1um", DataType::Integer16),
    process(OFFSETS, 2, "Output 2 0.1um", DataType::Integer16),
    process(OFFSETS, 3, "Output 3 0.1um", DataType::Integer16),
    process(OFFSETS, 4, "Output 4 0.1um", DataType::Integer16),
    process(HUB_STATE, 0, "Hub state", U8),
    process(COUNTER, 0, "Counter", U8),
    process(STATUS_FLAGS, 0, "Status flags", U16),
    process(FAULTY_CHANNELS, 0, "Faulty channels", DataType::Unsigned24),
    process(MODEL_SHAPE, 0, "Model shape", U8),
    process(CONSECUTIVE_FAULTS, 0, "Consecutive faults", U8),
    count(SLOPE, 3),
    process(SLOPE, 1, "Slope 0.001um per m", DataType::Integer32),
    process(SLOPE, 2, "Reference position mm", DataType::Integer16),
    process(SLOPE, 3, "Slope output", U8),
    count(SPINDLE, 2),
    cnc(
        SPINDLE,
        1,
        "Spindle speed 0.01rpm",
        DataType::Integer32,
        0x7FFF_FFFF,
    ),
    cnc(
        SPINDLE,
        2,
        "Spindle power 0.01kW",
        DataType::Integer16,
        0x7FFF,
    ),
    count(TOOL_POSITION, 2),
    cnc(
        TOOL_POSITION,
        1,
        "Tool length 0.001mm",
        DataType::Integer32,
        0x7FFF_FFFF,
    ),
    cnc(
        TOOL_POSITION,
        2,
        "Axis position 0.001mm",
        DataType::Integer32,
        0x7FFF_FFFF,
    ),
];

/// Entries in [`OBJECTS`].
pub const LEN: usize = OBJECTS.len();

const _: () = {
    // Sorted and unique, so lookups can bisect.
    let mut i = 1;
    while i < LEN {
        let (a, b) = (&OBJECTS[i - 1], &OBJECTS[i]);
        assert!(a.index < b.index || (a.index == b.index && a.sub < b.sub));
        i += 1;
    }
};

/// Where an (index, subindex) is in [`OBJECTS`]: abort 0x0602_0000 if the
/// index does not exist, 0x0609_0011 if only the subindex does not.
pub fn find(index: u16, sub: u8) -> Result<usize, SdoAbort> {
    OBJECTS
        .binary_search_by(|o| (o.index, o.sub).cmp(&(index, sub)))
        .map_err(|_| {
            if OBJECTS.iter().any(|o| o.index == index) {
                SdoAbort::NoSubindex
            } else {
                SdoAbort::NoObject
            }
        })
}

/// The current value of every entry (strings: unused), as little-endian bits.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Dictionary {
    raw: [u32; LEN],
    node_id: u8,
}

impl Dictionary {
    /// Every entry at its default, COB-IDs for `node_id` (1..=127; the
    /// caller validated it, `Settings`).
    pub fn new(node_id: u8) -> Self {
        let mut raw = [0u32; LEN];
        for (r, o) in raw.iter_mut().zip(OBJECTS) {
            *r = default_raw(o, node_id);
        }
        Self { raw, node_id }
    }

    /// The node id the COB-IDs were made for.
    pub fn node_id(&self) -> u8 {
        self.node_id
    }

    /// The raw value at a position of [`OBJECTS`] (0 past the end).
    pub fn raw_at(&self, pos: usize) -> u32 {
        self.raw.get(pos).copied().unwrap_or(0)
    }

    /// The raw value of (index, sub); 0 if there is no such entry.
    pub fn get(&self, index: u16, sub: u8) -> u32 {
        find(index, sub).map_or(0, |p| self.raw_at(p))
    }

    /// A REAL32 entry's value.
    pub fn get_f32(&self, index: u16, sub: u8) -> f32 {
        f32::from_bits(self.get(index, sub))
    }

    /// Sets (index, sub) from the device side (process values, error
    /// register): no access or range check. Nothing if there is no such entry.
    pub fn set(&mut self, index: u16, sub: u8, raw: u32) {
        if let Ok(p) = find(index, sub) {
            if let Some(r) = self.raw.get_mut(p) {
                *r = raw;
            }
        }
    }

    /// The entry's value as the bytes an SDO upload or a PDO carries.
    pub fn bytes(&self, pos: usize) -> Value {
        match OBJECTS.get(pos) {
            Some(Object {
                default: Default::Text(s),
                ..
            }) => Value::Text(s.as_bytes()),
            Some(o) => Value::Number(self.raw_at(pos).to_le_bytes(), o.ty.size()),
            None => Value::Number([0; 4], 0),
        }
    }

    /// Checks an SDO download of `data` into the entry at `pos` (access,
    /// length, range) and returns the raw value to store. Nothing changes.
    pub fn check_write(&self, pos: usize, data: &[u8]) -> Result<u32, SdoAbort> {
        let o = OBJECTS.get(pos).ok_or(SdoAbort::NoObject)?;
        if !o.access.writable() {
            return Err(SdoAbort::ReadOnly);
        }
        let size = o.ty.size();
        if data.len() != size {
            return Err(if data.len() > size {
                SdoAbort::LengthTooHigh
            } else {
                SdoAbort::LengthTooLow
            });
        }
        let mut b = [0u8; 4];
        b.get_mut(..size)
            .ok_or(SdoAbort::General)?
            .copy_from_slice(data);
        let mut raw = u32::from_le_bytes(b);
        if o.ty == DataType::Integer16 {
            // Keep INTEGER16 sign-extended, as the device side stores it.
            raw = i32::from(i16::from_le_bytes([b[0], b[1]])) as u32;
        }
        match o.limit {
            Limit::Any => {}
            Limit::U(min, max) => {
                if raw < min {
                    return Err(SdoAbort::ValueTooLow);
                }
                if raw > max {
                    return Err(SdoAbort::ValueTooHigh);
                }
            }
            Limit::F(min, max) => {
                let v = f32::from_bits(raw);
                if v.is_nan() {
                    return Err(SdoAbort::InvalidValue);
                }
                if v < min {
                    return Err(SdoAbort::ValueTooLow);
                }
                if v > max {
                    return Err(SdoAbort::ValueTooHigh);
                }
            }
        }
        Ok(raw)
    }

    /// Stores a value [`Dictionary::check_write`] accepted.
    pub fn store(&mut self, pos: usize, raw: u32) {
        if let Some(r) = self.raw.get_mut(pos) {
            *r = raw;
        }
    }
}

/// An entry's default for `node_id`, as stored.
pub fn default_raw(o: &Object, node_id: u8) -> u32 {
    match o.default {
        Default::Raw(v) => v,
        Default::NodeId(base) => base + u32::from(node_id),
        Default::Text(_) => 0,
    }
}

/// An entry's value on the wire.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Value {
    /// A number: its little-endian bytes and how many of them count.
    Number([u8; 4], usize),
    /// A string constant.
    Text(&'static [u8]),
}

impl Value {
    /// The bytes.
    pub fn as_bytes(&self) -> &[u8] {
        match self {
            Self::Number(b, n) => b.get(..*n).unwrap_or(&[]),
            Self::Text(s) => s,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lookups_and_aborts() {
        assert_eq!(
            OBJECTS[find(0x1017, 0).unwrap()].name.as_str(),
            "Producer heartbeat time"
        );
        assert_eq!(find(0x1017, 1), Err(SdoAbort::NoSubindex));
        assert_eq!(find(0x1800, 4), Err(SdoAbort::NoSubindex)); // reserved
        assert_eq!(find(0x1234, 0), Err(SdoAbort::NoObject));
        let d = Dictionary::new(5);
        assert_eq!(d.get(0x1800, 1), 0x185);
        assert_eq!(d.get(0x1200, 2), 0x585);
        assert_eq!(d.get(0x1014, 0), 0x85);
        assert_eq!(d.get_f32(CLAMP, 3), 500.0);
        assert_eq!(d.get(SPINDLE, 2), 0x7FFF);
    }

    #[test]
    fn writes_are_checked() {
        let d = Dictionary::new(1);
        let hb = find(HEARTBEAT_TIME, 0).unwrap();
        assert_eq!(d.check_write(hb, &[0xF4, 0x01]), Ok(500));
        assert_eq!(d.check_write(hb, &[0xF4]), Err(SdoAbort::LengthTooLow));
        assert_eq!(d.check_write(hb, &[0, 0, 0]), Err(SdoAbort::LengthTooHigh));
        let ty = find(0x1000, 0).unwrap();
        assert_eq!(d.check_write(ty, &[0; 4]), Err(SdoAbort::ReadOnly));
        let node = find(NODE_ID, 0).unwrap();
        assert_eq!(d.check_write(node, &[0]), Err(SdoAbort::ValueTooLow));
        assert_eq!(d.check_write(node, &[128]), Err(SdoAbort::ValueTooHigh));
        assert_eq!(d.check_write(node, &[127]), Ok(127));
        let clamp = find(CLAMP, 1).unwrap();
        assert_eq!(
            d.check_write(clamp, &3276.8f32.to_le_bytes()),
            Err(SdoAbort::ValueTooHigh)
        );
        assert_eq!(
            d.check_write(clamp, &0.0f32.to_le_bytes()),
            Err(SdoAbort::ValueTooLow)
        );
        assert_eq!(
            d.check_write(clamp, &f32::NAN.to_le_bytes()),
            Err(SdoAbort::InvalidValue)
        );
        let speed = find(SPINDLE, 2).unwrap();
        // INTEGER16 -2 kept sign-extended.
        assert_eq!(d.check_write(speed, &[0xFE, 0xFF]), Ok(0xFFFF_FFFE));
    }
}
