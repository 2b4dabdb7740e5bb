//! Owns writing a set as a CiA 306 device configuration file (DCF): one
//! object section per code the set gives, with the set's value as
//! `ParameterValue` (CiA 306 §4.6.3, §5), for CANopen masters and
//! configuration tools. Only `lenze-can-sdo` schemas (Lenze ECS) have SDO
//! objects; password codes are written without their value.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use crate::canonical::{RawValue, ResolvedSet};
use crate::family::Family;
use crate::schema::{Access, Code, Schema};
use crate::value::ValueType;

use super::import::LENZE_INDEX_BASE;

/// Why a set cannot be written as a DCF.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DcfError {
    /// What is wrong.
    pub message: String,
    /// What to do.
    pub help: String,
}

/// One object: its code and the set's (subcode, raw value) pairs.
type Object<'a> = (&'a Code, Vec<(Option<u32>, &'a RawValue)>);

/// A CiA 306 object list section and which indexes it lists.
type ObjectList = (&'static str, fn(u16) -> bool);

/// CiA 301 data type number of a schema type on CAN.
pub(crate) fn data_type(ty: ValueType) -> Option<u16> {
    Some(match ty {
        ValueType::FIX32 | ValueType::INTEGER32 => 0x0004,
        ValueType::BITCODED | ValueType::UNSIGNED32 => 0x0007,
        ValueType::UNSIGNED8 => 0x0005,
        ValueType::UNSIGNED16 => 0x0006,
        ValueType::INTEGER8 => 0x0002,
        ValueType::INTEGER16 => 0x0003,
        ValueType::VS => 0x0009,
        ValueType::VO => 0x000A,
        _ => return None,
    })
}

/// A DCF value: text to the end of the line, so no `;` and no line breaks.
fn clean(s: &str) -> String {
    s.chars()
        .map(|c| match c {
            ';' => ',',
            c if c.is_control() => ' ',
            c => c,
        })
        .collect()
}

fn raw_text(raw: &RawValue) -> String {
    match raw {
        RawValue::Int(i) => i.to_string(),
        RawValue::Text(t) => clean(t),
        RawValue::Octets(o) => o.iter().map(|b| format!("{b:02X}")).collect(),
    }
}

/// Write `set` (of `schema`) as a DCF. `file_name` goes into `[FileInfo]`;
/// `node_id` into `[DeviceComissioning]` when given.
pub fn write_dcf(
    set: &ResolvedSet,
    schema: &Schema,
    title: Option<&str>,
    file_name: &str,
    node_id: Option<u8>,
) -> Result<String, DcfError> {
    if schema.family != Family::Ecs {
        return Err(DcfError {
            message: format!(
                "set uses schema `{}`, which is not a CANopen (lenze-can-sdo) family; a DCF describes CANopen SDO objects",
                schema.id
            ),
            help: "write a DCF from a Lenze ECS set (schema lenze-ecs or one made by `driveset schema import`); use --to toml|yaml|json for other families".into(),
        });
    }
    let base = schema.can_index_base.unwrap_or(LENZE_INDEX_BASE);
    // index -> (code, [(subcode, raw)])
    let mut objects: BTreeMap<u16, Object<'_>> = BTreeMap::new();
    for (key, raw) in &set.values {
        let Some(code) = schema.code(key.number) else {
            return Err(DcfError {
                message: format!(
                    "the schema has no code {}",
                    schema.display_code(key.number, key.subcode)
                ),
                help: "validate the set first (driveset validate)".into(),
            });
        };
        let index = match code.index {
            Some(i) => Some(i),
            None => base
                .checked_sub(key.number)
                .and_then(|i| u16::try_from(i).ok()),
        };
        let Some(index) = index else {
            return Err(DcfError {
                message: format!(
                    "{} has no SDO index (code above the index base {base})",
                    schema.display_code(key.number, key.subcode)
                ),
                help: "check the schema's [schema.can] index_base".into(),
            });
        };
        objects
            .entry(index)
            .or_insert((code, Vec::new()))
            .1
            .push((key.subcode, raw));
    }
    let name = title.map(clean);
    let mut t = String::new();
    let _ = writeln!(
        t,
        "; Device configuration file (CiA 306) written by `driveset show --to dcf`\n\
         ; from a set of schema {}. ParameterValue is the set's raw value: FIX32 codes\n\
         ; value x 10000, C0135 / C0150 bit-coded (lenze-system-bus-can-sdo.txt, p. 454).",
        schema.id
    );
    t.push_str("\n[FileInfo]\n");
    let _ = writeln!(t, "FileName={}", clean(file_name));
    t.push_str("FileVersion=1\nFileRevision=0\nEDSVersion=4.0\n");
    let _ = writeln!(
        t,
        "Description={}",
        clean(name.as_deref().unwrap_or(&schema.title))
    );
    t.push_str("CreatedBy=driveset\n");
    t.push_str("\n[DeviceInfo]\n");
    let _ = writeln!(t, "ProductName={}", clean(&schema.title));
    t.push_str("\n[DeviceComissioning]\n");
    if let Some(n) = node_id {
        let _ = writeln!(t, "NodeID=0x{n:02X}");
    }
    let _ = writeln!(t, "NodeName={}", name.as_deref().unwrap_or(&set.schema));
    let lists: [ObjectList; 3] = [
        ("MandatoryObjects", |i| {
            matches!(i, 0x1000 | 0x1001 | 0x1018)
        }),
        ("OptionalObjects", |i| {
            !matches!(i, 0x1000 | 0x1001 | 0x1018) && !(0x2000..=0x5FFF).contains(&i)
        }),
        ("ManufacturerObjects", |i| (0x2000..=0x5FFF).contains(&i)),
    ];
    for (section, belongs) in lists {
        let here: Vec<u16> = objects.keys().copied().filter(|i| belongs(*i)).collect();
        let _ = writeln!(t, "\n[{section}]\nSupportedObjects={}", here.len());
        for (n, i) in here.iter().enumerate() {
            let _ = writeln!(t, "{}=0x{i:04X}", n + 1);
        }
    }
    for (index, (code, values)) in &objects {
        let ty = schema.type_of(code);
        let Some(dt) = ty.and_then(data_type) else {
            return Err(DcfError {
                message: format!(
                    "{}: type {} has no CANopen data type",
                    schema.display_code(code.number, None),
                    ty.map_or("?", ValueType::name)
                ),
                help: "give the code a CAN type in the schema (FIX32, BITCODED, VS, VO, UNSIGNED8..INTEGER32)".into(),
            });
        };
        let pname = clean(code.title.as_deref().unwrap_or(&code.name));
        let access = if code.access == Some(Access::Ro) {
            "ro"
        } else {
            "rw"
        };
        let secret = schema.is_password(code);
        let facts = |t: &mut String| {
            if secret {
                return;
            }
            for (k, f) in [
                ("DefaultValue", &code.default),
                ("LowLimit", &code.min),
                ("HighLimit", &code.max),
            ] {
                if let Some(raw) = f.as_ref().and_then(|f| schema.fact_raw(code, f).ok()) {
                    let _ = writeln!(t, "{k}={}", raw_text(&raw));
                }
            }
        };
        let value_line = |t: &mut String, raw: &RawValue| {
            if secret {
                t.push_str("; ParameterValue not written: the code is a password\n");
            } else {
                let _ = writeln!(t, "ParameterValue={}", raw_text(raw));
            }
        };
        let subs: Vec<(u32, &RawValue)> = values
            .iter()
            .filter_map(|(s, r)| s.map(|s| (s, *r)))
            .filter(|(s, _)| *s <= 255)
            .collect();
        if subs.is_empty() {
            let raw = values.first().map(|v| v.1);
            let _ = writeln!(
                t,
                "\n[{index:04X}]\nParameterName={pname}\nObjectType=0x7\nDataType=0x{dt:04X}\nAccessType={access}"
            );
            facts(&mut t);
            t.push_str("PDOMapping=0\n");
            if let Some(raw) = raw {
                value_line(&mut t, raw);
            }
            continue;
        }
        let top = code
            .subcodes
            .unwrap_or(0)
            .max(subs.iter().map(|s| s.0).max().unwrap_or(0));
        let _ = writeln!(
            t,
            "\n[{index:04X}]\nParameterName={pname}\nObjectType=0x8\nSubNumber={}",
            subs.len() + 1
        );
        let _ = writeln!(
            t,
            "\n[{index:04X}sub0]\nParameterName=Highest sub-index supported\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue={top}\nPDOMapping=0"
        );
        for (s, raw) in subs {
            let _ = writeln!(
                t,
                "\n[{index:04X}sub{s:X}]\nParameterName={pname} {s}\nObjectType=0x7\nDataType=0x{dt:04X}\nAccessType={access}"
            );
            facts(&mut t);
            t.push_str("PDOMapping=0\n");
            value_line(&mut t, raw);
        }
    }
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::canonical::CodeKey;
    use crate::error::SourceFile;
    use crate::schema::Registry;

    fn schema(protocol: &str) -> std::sync::Arc<Schema> {
        let text = format!(
            "[schema]\nid = \"t\"\ntitle = \"T\"\nprotocol = \"{protocol}\"\ncode_style = \"lenze\"\n\
             [[code]]\nnumber = 5001\nname = \"pin\"\ntitle = \"PIN\"\nspec = \"s\"\ntype = \"FIX32\"\nrole = \"password\"\ndefault = \"1\"\n\
             [[code]]\nindex = 0x6040\nname = \"w\"\ntitle = \"W; x\"\nspec = \"s\"\ntype = \"INTEGER16\"\n"
        );
        Registry::new()
            .add_source(SourceFile::new("t.toml", text))
            .unwrap()
    }

    #[test]
    fn passwords_are_not_written_and_cia_objects_use_their_index() {
        let s = schema("lenze-can-sdo");
        let mut set = ResolvedSet::new(&s);
        set.insert(CodeKey::new(5001), RawValue::Int(12340000));
        set.insert(CodeKey::new(0x1_6040), RawValue::Int(-2));
        let t = write_dcf(&set, &s, None, "t.dcf", None).unwrap();
        assert!(!t.contains("12340000"), "{t}");
        assert!(!t.contains("DefaultValue=10000"), "{t}");
        assert!(
            t.contains("\n[4C76]\nParameterName=PIN\nObjectType=0x7\nDataType=0x0004\nAccessType=rw\nPDOMapping=0\n; ParameterValue not written: the code is a password\n"),
            "{t}"
        );
        assert!(
            t.contains("\n[6040]\nParameterName=W, x\nObjectType=0x7\nDataType=0x0003\nAccessType=rw\nPDOMapping=0\nParameterValue=-2\n"),
            "{t}"
        );
        assert!(
            t.contains("\n[OptionalObjects]\nSupportedObjects=1\n1=0x6040\n"),
            "{t}"
        );
        assert!(!t.contains("NodeID="), "{t}");
    }

    #[test]
    fn other_families_are_refused() {
        let s = schema("lecom");
        let set = ResolvedSet::new(&s);
        let e = write_dcf(&set, &s, None, "t.dcf", None).unwrap_err();
        assert_eq!(
            e.message,
            "set uses schema `t`, which is not a CANopen (lenze-can-sdo) family; a DCF describes CANopen SDO objects"
        );
    }
}
