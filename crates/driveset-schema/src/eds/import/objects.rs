//! Classifying an EDS object for the import (CiA 306 sections, CiA 301
//! §7.4): where it sits ([`Area`]: a Lenze code, a CiA 301 object kept by
//! index, or skipped with why), its data type and access, and whether the
//! data sheet is Lenze's (`VendorNumber` 0x3B, `VendorName`).

use crate::eds::reader::{self, EdsFile, Section, parse_int};
use crate::value::ValueType;

use super::{Ctx, LENZE_INDEX_BASE};

/// CiA 301 data types (CiA 301 §7.4.7.1, Table 44) by number.
pub(super) fn data_type_name(dt: u16) -> String {
    let n = match dt {
        0x0001 => "BOOLEAN",
        0x0002 => "INTEGER8",
        0x0003 => "INTEGER16",
        0x0004 => "INTEGER32",
        0x0005 => "UNSIGNED8",
        0x0006 => "UNSIGNED16",
        0x0007 => "UNSIGNED32",
        0x0008 => "REAL32",
        0x0009 => "VISIBLE_STRING",
        0x000A => "OCTET_STRING",
        0x000B => "UNICODE_STRING",
        0x000C => "TIME_OF_DAY",
        0x000D => "TIME_DIFFERENCE",
        0x000F => "DOMAIN",
        0x0010 => "INTEGER24",
        0x0011 => "REAL64",
        0x0012 => "INTEGER40",
        0x0013 => "INTEGER48",
        0x0014 => "INTEGER56",
        0x0015 => "INTEGER64",
        0x0016 => "UNSIGNED24",
        0x0018 => "UNSIGNED40",
        0x0019 => "UNSIGNED48",
        0x001A => "UNSIGNED56",
        0x001B => "UNSIGNED64",
        _ => return format!("0x{dt:04X}"),
    };
    format!("{n} (0x{dt:04X})")
}

/// The CiA 301 type a CiA object keeps (BOOLEAN travels as one byte).
pub(super) fn cia_type(dt: u16) -> Option<ValueType> {
    Some(match dt {
        0x0001 | 0x0005 => ValueType::UNSIGNED8,
        0x0002 => ValueType::INTEGER8,
        0x0003 => ValueType::INTEGER16,
        0x0004 => ValueType::INTEGER32,
        0x0006 => ValueType::UNSIGNED16,
        0x0007 => ValueType::UNSIGNED32,
        0x0009 => ValueType::VS,
        0x000A => ValueType::VO,
        _ => return None,
    })
}

/// CiA 306 AccessType.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Acc {
    Ro,
    Wo,
    Rw,
    Const,
}

/// One variable: a VAR / DOMAIN object or one subindex.
#[derive(Debug, Clone)]
pub(super) struct Var<'a> {
    pub(super) sub: u8,
    /// Where its keys are (the main section for CompactSubObj entries).
    pub(super) section: &'a Section,
}

impl Var<'_> {
    pub(super) fn key(&self, k: &str) -> Option<&reader::Entry> {
        self.section.get(k)
    }
    pub(super) fn line(&self) -> usize {
        self.section.line
    }
}

pub(super) fn obj_text(index: u16, sub: Option<u8>) -> String {
    match sub {
        Some(s) => format!("0x{index:04X}sub{s}"),
        None => format!("0x{index:04X}"),
    }
}

/// Where an object sits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Area {
    /// Lenze code = 24575 - index.
    Lenze(u32),
    /// CiA 301 object kept by index.
    Cia,
    /// Skipped, with why.
    Skip(&'static str),
}

/// Lenze's CiA vendor ID (the CiA vendor-ID list: 0x0000003B, Lenze SE).
pub const LENZE_VENDOR_ID: i128 = 0x3B;

/// Highest Lenze code number (codes are C0000..C9999, four digits).
pub(super) const LENZE_CODE_MAX: u32 = 9999;

pub(super) fn area(index: u16, lenze: bool) -> Area {
    match index {
        0x0000..=0x0FFF => {
            Area::Skip("data type definition area (CiA 301 §7.4.3), not a parameter")
        }
        0x1010 => Area::Skip(
            "store parameters without a writable sub 1 (save all parameters): no store step; skipped",
        ),
        0x1011 => {
            Area::Skip("restore default parameters: a command (signature write), not a setting")
        }
        0x1200..=0x12FF => Area::Skip(
            "SDO channel parameter: bus configuration ($NODEID COB-IDs), not a drive setting",
        ),
        0x1400..=0x1BFF => Area::Skip(
            "PDO communication / mapping parameter: configured by the CANopen master, not a drive setting",
        ),
        0x2000..=0x5FFF if lenze && LENZE_INDEX_BASE - u32::from(index) <= LENZE_CODE_MAX => {
            Area::Lenze(LENZE_INDEX_BASE - u32::from(index))
        }
        _ => Area::Cia,
    }
}

/// Whether the data sheet is Lenze's (its manufacturer objects are Lenze
/// codes), and the lint that says what decided: `VendorNumber` (Lenze's
/// CiA vendor ID 0x3B) first, else `VendorName` naming Lenze.
pub(super) fn lenze_vendor(file: &EdsFile, cx: &mut Ctx) -> bool {
    let info = file.section("DeviceInfo");
    let number = info.and_then(|s| s.get("VendorNumber"));
    let name = info.and_then(|s| s.get("VendorName"));
    let number_value = number
        .and_then(|e| parse_int(&e.value))
        .filter(|v| !v.plus_node_id);
    let name_says = name.is_some_and(|e| e.value.to_ascii_lowercase().contains("lenze"));
    let line = |e: Option<&reader::Entry>| e.map_or(0, |e| e.line);
    match (number_value, name_says) {
        (Some(v), _) if v.value == LENZE_VENDOR_ID => {
            cx.lint(
                line(number),
                String::new(),
                format!(
                    "VendorNumber {} is Lenze's CiA vendor ID (0x3B): objects 0x38F0..0x5FFF are Lenze codes C9999..C0000 (code = 24575 - index, FIX32 value x 10000), 0x2000..0x38EF kept by index with their own types",
                    number.map_or("", |e| e.value.as_str())
                ),
            );
            true
        }
        (Some(v), true) => {
            cx.lint(
                line(number),
                String::new(),
                format!(
                    "VendorNumber 0x{:08X} is not Lenze's (0x3B) though VendorName `{}` names Lenze: the VendorNumber decides; manufacturer objects kept by index with their own CiA types (no x 10000 scaling)",
                    v.value,
                    name.map_or("", |e| e.value.as_str())
                ),
            );
            false
        }
        (None, true) => {
            cx.lint(
                line(name),
                String::new(),
                format!(
                    "VendorName `{}` names Lenze (no VendorNumber to tell): objects 0x38F0..0x5FFF are Lenze codes C9999..C0000 (code = 24575 - index, FIX32 value x 10000), 0x2000..0x38EF kept by index with their own types",
                    name.map_or("", |e| e.value.as_str())
                ),
            );
            true
        }
        (v, false) => {
            cx.lint(
                line(number.or(name)),
                String::new(),
                format!(
                    "not a Lenze data sheet (VendorNumber {}, VendorName {}): manufacturer objects 0x2000..0x5FFF kept by index with their own CiA types (no x 10000 scaling)",
                    v.map_or_else(|| "not given".to_string(), |v| format!("0x{:08X}", v.value)),
                    name.map_or_else(|| "not given".to_string(), |e| format!("`{}`", e.value))
                ),
            );
            false
        }
    }
}

pub(super) fn value_type(ar: Area, bitcoded: bool, dt: u16) -> Option<ValueType> {
    match ar {
        Area::Lenze(_) if bitcoded => match dt {
            0x0002..=0x0007 => Some(ValueType::BITCODED),
            _ => None,
        },
        Area::Lenze(_) => match dt {
            0x0004 | 0x0007 => Some(ValueType::FIX32),
            0x0009 => Some(ValueType::VS),
            0x000A => Some(ValueType::VO),
            _ => None,
        },
        Area::Cia => cia_type(dt),
        Area::Skip(_) => None,
    }
}
