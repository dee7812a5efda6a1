//! `firmware/thermcomp.eds` against the dictionary, both ways: every
//! entry of the EDS is in [`od::OBJECTS`] with the same data type, access,
//! PDO mapping and default, and every entry of the table is in the EDS.
//! `UPDATE_EDS=1 cargo test -p firmware --lib eds` rewrites the file from
//! the table (then read it: the test parses what it wrote).

use super::od::{self, Access, Default, Object, GROUPS, OBJECTS};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::string::{String, ToString};
use std::vec::Vec;
use std::{format, println};

const PATH: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/thermcomp.eds");

fn default_text(o: &Object) -> String {
    match o.default {
        Default::Text(s) => s.to_string(),
        Default::NodeId(base) => format!("$NODEID+0x{base:X}"),
        Default::Raw(v) => match o.ty {
            od::DataType::Real32 => format!("{}", f32::from_bits(v)),
            od::DataType::Integer16 => format!("{}", v as i32 as i16),
            od::DataType::Integer32 => format!("{}", v as i32),
            _ if v > 9 => format!("0x{v:X}"),
            _ => format!("{v}"),
        },
    }
}

fn entry_text(out: &mut String, section: &str, o: &Object) {
    let _ = write!(
        out,
        "[{section}]\nParameterName={}\nObjectType=0x7\nDataType=0x{:04X}\nAccessType={}\nDefaultValue={}\nPDOMapping={}\n",
        o.name.as_str(),
        o.ty.code(),
        o.access.eds(),
        default_text(o),
        u8::from(o.pdo)
    );
    if let od::Limit::U(lo, hi) = o.limit {
        let _ = write!(out, "LowLimit={lo}\nHighLimit={hi}\n");
    }
    if let od::Limit::F(lo, hi) = o.limit {
        let _ = write!(out, "LowLimit={lo}\nHighLimit={hi}\n");
    }
    out.push('\n');
}

/// The EDS for the table (CiA 306 v1.3 §4).
fn generate() -> String {
    let mut out = String::new();
    out.push_str(
        "; CiA 306 electronic data sheet of the thermcomp sensor hub (CiA 301 v4.2).\n\
         ; Generated from firmware/src/canopen/od.rs (UPDATE_EDS=1 cargo test -p firmware --lib eds);\n\
         ; the test canopen::eds_tests checks this file against that table, both ways.\n\n",
    );
    out.push_str(
        "[FileInfo]\nFileName=thermcomp.eds\nFileVersion=1\nFileRevision=0\nEDSVersion=4.0\n\
         Description=thermcomp thermal-error compensation hub\nCreatedBy=thermcomp\n\n\
         [DeviceInfo]\nVendorName=thermcomp\nVendorNumber=0x0\nProductName=thermcomp hub\n\
         ProductNumber=0x54430001\nRevisionNumber=0x10000\nOrderCode=\n\
         BaudRate_10=0\nBaudRate_20=0\nBaudRate_50=0\nBaudRate_125=0\nBaudRate_250=0\n\
         BaudRate_500=1\nBaudRate_800=0\nBaudRate_1000=0\nSimpleBootUpMaster=0\n\
         SimpleBootUpSlave=1\nGranularity=0\nDynamicChannelsSupported=0\nGroupMessaging=0\n\
         NrOfRXPDO=2\nNrOfTXPDO=4\nLSS_Supported=0\n\n\
         [DummyUsage]\nDummy0001=0\nDummy0002=0\nDummy0003=0\nDummy0004=0\nDummy0005=0\n\
         Dummy0006=1\nDummy0007=1\n\n",
    );
    let mut indices: Vec<u16> = OBJECTS.iter().map(|o| o.index).collect();
    indices.dedup();
    // CiA 306 §4.5.2: 0x1000, 0x1001 and 0x1018 are mandatory (CiA 301).
    let mandatory = [0x1000u16, 0x1001, 0x1018];
    let section = |pick: &dyn Fn(u16) -> bool, name: &str, out: &mut String| {
        let list: Vec<u16> = indices.iter().copied().filter(|i| pick(*i)).collect();
        let _ = writeln!(out, "[{name}]\nSupportedObjects={}", list.len());
        for (k, i) in list.iter().enumerate() {
            let _ = writeln!(out, "{}=0x{i:04X}", k + 1);
        }
        out.push('\n');
    };
    section(&|i| mandatory.contains(&i), "MandatoryObjects", &mut out);
    section(
        &|i| i < 0x2000 && !mandatory.contains(&i),
        "OptionalObjects",
        &mut out,
    );
    section(&|i| i >= 0x2000, "ManufacturerObjects", &mut out);
    for index in indices {
        let subs: Vec<&Object> = OBJECTS.iter().filter(|o| o.index == index).collect();
        match GROUPS.iter().find(|g| g.index == index) {
            None => entry_text(&mut out, &format!("{index:04X}"), subs[0]),
            Some(g) => {
                let _ = write!(
                    out,
                    "[{index:04X}]\nParameterName={}\nObjectType=0x{:X}\nSubNumber={}\n\n",
                    g.name,
                    g.object_type,
                    subs.len()
                );
                for o in subs {
                    entry_text(&mut out, &format!("{index:04X}sub{:X}", o.sub), o);
                }
            }
        }
    }
    out
}

/// A minimal INI reader: section -> key -> value (comments `;`).
fn parse_ini(text: &str) -> BTreeMap<String, BTreeMap<String, String>> {
    let mut out: BTreeMap<String, BTreeMap<String, String>> = BTreeMap::new();
    let mut current = String::new();
    for line in text.lines().map(str::trim) {
        if line.is_empty() || line.starts_with(';') {
            continue;
        }
        if let Some(s) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            current = s.to_ascii_uppercase();
            out.entry(current.clone()).or_default();
        } else if let Some((k, v)) = line.split_once('=') {
            out.entry(current.clone())
                .or_default()
                .insert(k.trim().to_ascii_lowercase(), v.trim().to_string());
        }
    }
    out
}

fn number(s: &str) -> Option<i64> {
    let s = s.trim();
    let (neg, s) = s.strip_prefix('-').map_or((false, s), |r| (true, r));
    let v = match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(h) => i64::from_str_radix(h, 16).ok()?,
        None => s.parse().ok()?,
    };
    Some(if neg { -v } else { v })
}

/// Whether the EDS default text means the entry's default.
fn same_default(o: &Object, text: &str) -> bool {
    match o.default {
        Default::Text(s) => s == text,
        Default::NodeId(base) => text
            .strip_prefix("$NODEID+")
            .and_then(number)
            .is_some_and(|v| v == i64::from(base)),
        Default::Raw(v) => match o.ty {
            od::DataType::Real32 => text.parse::<f32>().is_ok_and(|x| x.to_bits() == v),
            od::DataType::Integer16 | od::DataType::Integer32 => {
                number(text) == Some(i64::from(v as i32))
            }
            _ => number(text) == Some(i64::from(v)),
        },
    }
}

#[test]
fn eds_matches_the_dictionary_both_ways() {
    if std::env::var_os("UPDATE_EDS").is_some() {
        std::fs::write(PATH, generate()).unwrap();
        println!("rewrote {PATH}");
    }
    let text = std::fs::read_to_string(PATH).expect("firmware/thermcomp.eds");
    let ini = parse_ini(&text);
    // EDS -> table: every object section names a table entry, same fields.
    let mut seen = 0;
    for (name, keys) in &ini {
        let (index, sub) = match name.split_once("SUB") {
            Some((i, s)) => (i, Some(s)),
            None => (name.as_str(), None),
        };
        let Ok(index) = u16::from_str_radix(index, 16) else {
            continue; // FileInfo, DeviceInfo, ...
        };
        let ot = keys.get("objecttype").and_then(|v| number(v)).unwrap_or(7);
        if sub.is_none() && ot != 7 {
            let g = GROUPS.iter().find(|g| g.index == index);
            assert!(g.is_some(), "[{name}] is a group the table lacks");
            let g = g.unwrap();
            assert_eq!(i64::from(g.object_type), ot, "[{name}] ObjectType");
            assert_eq!(keys.get("parametername").unwrap(), g.name, "[{name}]");
            let subs = OBJECTS.iter().filter(|o| o.index == index).count();
            assert_eq!(
                keys.get("subnumber").and_then(|v| number(v)),
                Some(subs as i64),
                "[{name}] SubNumber"
            );
            continue;
        }
        let sub = sub
            .map_or(Some(0), |s| u8::from_str_radix(s, 16).ok())
            .unwrap();
        let pos = od::find(index, sub).unwrap_or_else(|e| panic!("[{name}] not in od: {e}"));
        let o = &OBJECTS[pos];
        let get = |k: &str| keys.get(k).unwrap_or_else(|| panic!("[{name}] lacks {k}"));
        assert_eq!(get("parametername"), o.name.as_str(), "[{name}]");
        assert_eq!(
            number(get("datatype")),
            Some(i64::from(o.ty.code())),
            "[{name}] DataType"
        );
        assert_eq!(
            get("accesstype").to_ascii_lowercase(),
            o.access.eds(),
            "[{name}] AccessType"
        );
        assert_eq!(
            number(get("pdomapping")),
            Some(i64::from(o.pdo)),
            "[{name}] PDOMapping"
        );
        assert!(
            same_default(o, get("defaultvalue")),
            "[{name}] DefaultValue {}",
            get("defaultvalue")
        );
        seen += 1;
    }
    // Table -> EDS: every entry was seen, and is listed.
    assert_eq!(seen, OBJECTS.len(), "the EDS lacks table entries");
    for o in OBJECTS {
        let grouped = GROUPS.iter().any(|g| g.index == o.index);
        let section = if grouped {
            format!("{:04X}SUB{:X}", o.index, o.sub)
        } else {
            format!("{:04X}", o.index)
        };
        assert!(ini.contains_key(&section), "[{section}] missing");
        assert!(
            ["MANDATORYOBJECTS", "OPTIONALOBJECTS", "MANUFACTUREROBJECTS"]
                .iter()
                .any(|s| ini[*s]
                    .values()
                    .any(|v| number(v) == Some(i64::from(o.index)))),
            "0x{:04X} not listed",
            o.index
        );
    }
    // Writable entries with a range carry it as LowLimit/HighLimit.
    for o in OBJECTS.iter().filter(|o| o.access == Access::Rw) {
        let section = if GROUPS.iter().any(|g| g.index == o.index) {
            format!("{:04X}SUB{:X}", o.index, o.sub)
        } else {
            format!("{:04X}", o.index)
        };
        let keys = &ini[&section];
        match o.limit {
            od::Limit::Any => assert!(!keys.contains_key("lowlimit"), "[{section}]"),
            od::Limit::U(lo, hi) => {
                assert_eq!(
                    number(&keys["lowlimit"]),
                    Some(i64::from(lo)),
                    "[{section}]"
                );
                assert_eq!(
                    number(&keys["highlimit"]),
                    Some(i64::from(hi)),
                    "[{section}]"
                );
            }
            od::Limit::F(lo, hi) => {
                assert_eq!(
                    keys["lowlimit"].parse::<f32>().ok(),
                    Some(lo),
                    "[{section}]"
                );
                assert_eq!(
                    keys["highlimit"].parse::<f32>().ok(),
                    Some(hi),
                    "[{section}]"
                );
            }
        }
    }
}
