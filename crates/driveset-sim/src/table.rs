//! The parameter table a simulated drive holds: every code of its schema
//! with raw minimum, maximum, factory value, access and storage facts, and
//! the write checks the family models share. Built from a schema (a real one
//! from `schemas/`, or a fixture schema marked fictional that extends it).

use std::collections::BTreeMap;
use std::sync::Arc;

use driveset_schema::ValueType;
use driveset_schema::canonical::{CodeKey, RawValue, ResolvedSet};
use driveset_schema::schema::{Access, Code, Schema, StorageKind};

/// One parameter (code, or code/subcode) of a simulated drive.
#[derive(Debug, Clone, PartialEq)]
pub struct Param {
    /// Code and subcode.
    pub key: CodeKey,
    /// Short name from the schema.
    pub name: String,
    /// Data type, if the schema knows it.
    pub ty: Option<ValueType>,
    /// Raw minimum: the schema's `min`, else the type's raw range.
    pub min: Option<i64>,
    /// Raw maximum: the schema's `max`, else the type's raw range.
    pub max: Option<i64>,
    /// Factory value. Where the schema gives no default the simulator
    /// starts at the minimum (or 0, or empty text): a simulator choice, not
    /// a device fact.
    pub factory: RawValue,
    /// Access right.
    pub access: Access,
    /// LUSTBUS storage kind, if known.
    pub kind: Option<StorageKind>,
    /// Byte width (EEPROM pacing), if known; else derived from the type.
    pub width: Option<u8>,
    /// MC6000: taken by an SLOAD dataset download.
    pub card_writeable: bool,
    /// Reading the code clears it (85-SIOF/SERR).
    pub read_clears: bool,
    /// Enumerated raw values, when the schema lists them.
    pub enum_values: Vec<i64>,
}

impl Param {
    /// Whether the code may be written at all (not read-only).
    pub fn writable(&self) -> bool {
        self.access != Access::Ro && self.kind != Some(StorageKind::RamActual)
    }

    /// Whether the code keeps its value over a power cycle (EEPROM, or not
    /// a LUSTBUS code at all: Lenze drives store their codes).
    pub fn persistent(&self) -> bool {
        !matches!(
            self.kind,
            Some(StorageKind::RamActual) | Some(StorageKind::RamControl)
        )
    }

    /// The value's byte width: the schema's `width`, else the type's.
    pub fn byte_width(&self) -> u8 {
        if let Some(w) = self.width {
            return w;
        }
        match self.ty {
            Some(ValueType::PT_USIGN8) | Some(ValueType::PT_BINARY8) => 1,
            Some(ValueType::PT_USIGN16)
            | Some(ValueType::PT_INTEGER16)
            | Some(ValueType::PT_FIXPOINT16)
            | Some(ValueType::PT_PASSWORD)
            | Some(ValueType::PT_VF_ERROR) => 2,
            _ => 4,
        }
    }

    /// Check a raw integer against the type range and the schema's min/max.
    pub fn check_range(&self, raw: i64) -> Result<(), Refusal> {
        if let (Some(lo), Some(hi)) = (self.min, self.max)
            && (raw < lo || raw > hi)
        {
            return Err(Refusal::OutOfRange {
                raw,
                min: lo,
                max: hi,
            });
        }
        Ok(())
    }
}

/// Why a drive refuses a write.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Refusal {
    /// The code does not exist on this drive.
    #[error("no such code")]
    NoSuchCode,
    /// The code is read-only (or an actual value).
    #[error("read-only code")]
    ReadOnly,
    /// The value is outside the code's range.
    #[error("value {raw} outside {min}..={max}")]
    OutOfRange {
        /// Offered raw value.
        raw: i64,
        /// Raw minimum.
        min: i64,
        /// Raw maximum.
        max: i64,
    },
    /// The value has the wrong shape (text for a number ...).
    #[error("wrong value type")]
    WrongType,
    /// The code cannot be changed in the drive's current state (running).
    #[error("not permitted while running")]
    NotNow,
}

/// Every parameter of a simulated drive, from its schema.
#[derive(Debug, Clone)]
pub struct ParamTable {
    schema: Arc<Schema>,
    params: BTreeMap<CodeKey, Param>,
}

impl ParamTable {
    /// Build the table from a schema. Facts that do not convert (a schema
    /// that `driveset schema check` would reject) are an error naming the code.
    pub fn from_schema(schema: Arc<Schema>) -> Result<Self, String> {
        let mut params = BTreeMap::new();
        for code in &schema.codes {
            let keys: Vec<CodeKey> = match code.subcodes {
                Some(n) if n > 0 => (1..=n).map(|s| CodeKey::sub(code.number, s)).collect(),
                _ => vec![CodeKey::new(code.number)],
            };
            let proto = param_for(&schema, code)?;
            for key in keys {
                let mut p = proto.clone();
                p.key = key;
                params.insert(key, p);
            }
        }
        Ok(ParamTable { schema, params })
    }

    /// The numbers of the schema's codes whose values are secrets.
    pub fn secret_codes(&self) -> Vec<u32> {
        let s = &self.schema;
        s.codes
            .iter()
            .filter(|c| s.is_password(c))
            .map(|c| c.number)
            .collect()
    }

    /// The schema the table was built from.
    pub fn schema(&self) -> &Arc<Schema> {
        &self.schema
    }

    /// One parameter.
    pub fn get(&self, key: CodeKey) -> Option<&Param> {
        self.params.get(&key)
    }

    /// Add `p` (a parameter a twin's drive described that the schema does
    /// not have, `crate::twin`); an existing one is kept.
    pub fn adopt(&mut self, p: Param) {
        self.params.entry(p.key).or_insert(p);
    }

    /// All parameters in code order.
    pub fn iter(&self) -> impl Iterator<Item = &Param> {
        self.params.values()
    }

    /// Number of parameters.
    pub fn len(&self) -> usize {
        self.params.len()
    }

    /// Whether the table is empty.
    pub fn is_empty(&self) -> bool {
        self.params.is_empty()
    }

    /// The factory state: every parameter at its factory value.
    pub fn factory_state(&self) -> BTreeMap<CodeKey, RawValue> {
        self.params
            .values()
            .map(|p| (p.key, p.factory.clone()))
            .collect()
    }

    /// A [`ResolvedSet`] of this table's schema holding `values`.
    pub fn resolved(&self, values: &BTreeMap<CodeKey, RawValue>) -> ResolvedSet {
        let mut set = ResolvedSet::new(&self.schema);
        for (k, v) in values {
            set.insert(*k, v.clone());
        }
        set
    }

    /// The checks every family applies to a write of `raw` to `key`
    /// (existence, read-only, range); family-specific refusals (running,
    /// EEPROM busy) are the model's.
    pub fn check_write(&self, key: CodeKey, raw: &RawValue) -> Result<&Param, Refusal> {
        let p = self.params.get(&key).ok_or(Refusal::NoSuchCode)?;
        if !p.writable() {
            return Err(Refusal::ReadOnly);
        }
        match raw {
            RawValue::Int(v) => {
                if matches!(p.ty, Some(ValueType::VS) | Some(ValueType::VO)) {
                    return Err(Refusal::WrongType);
                }
                p.check_range(*v)?;
            }
            RawValue::Text(_) if p.ty != Some(ValueType::VS) => return Err(Refusal::WrongType),
            RawValue::Octets(_) if p.ty != Some(ValueType::VO) => return Err(Refusal::WrongType),
            _ => {}
        }
        Ok(p)
    }
}

fn param_for(schema: &Schema, code: &Code) -> Result<Param, String> {
    let ty = schema.type_of(code);
    let fact = |f: &Option<driveset_schema::schema::Fact>| -> Result<Option<RawValue>, String> {
        match f {
            Some(f) => schema
                .fact_raw(code, f)
                .map(Some)
                .map_err(|e| format!("{}: {e}", schema.display_code(code.number, None))),
            None => Ok(None),
        }
    };
    let int = |v: Option<RawValue>| match v {
        Some(RawValue::Int(i)) => Some(i),
        _ => None,
    };
    let type_range = ty.and_then(|t| t.raw_range(code.width));
    let min = int(fact(&code.min)?).or(type_range.map(|r| r.0));
    let max = int(fact(&code.max)?).or(type_range.map(|r| r.1));
    let factory = match fact(&code.default)? {
        Some(v) => v,
        None => match ty {
            Some(ValueType::VS) => RawValue::Text(String::new()),
            Some(ValueType::VO) => RawValue::Octets(Vec::new()),
            _ => RawValue::Int(min.map_or(0, |m| m.max(0).min(max.unwrap_or(i64::MAX)))),
        },
    };
    let enum_values = code
        .values
        .as_ref()
        .and_then(|src| schema.enum_of(src))
        .map(|e| e.entries.iter().map(|(v, _, _)| *v).collect())
        .unwrap_or_default();
    Ok(Param {
        key: CodeKey::new(code.number),
        name: code.name.clone(),
        ty,
        min,
        max,
        factory,
        access: code.access.unwrap_or_default(),
        kind: code.kind,
        width: code.width,
        card_writeable: code.card_writeable == Some(true),
        read_clears: code.read_clears == Some(true),
        enum_values,
    })
}
