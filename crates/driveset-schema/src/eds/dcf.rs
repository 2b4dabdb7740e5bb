//! Owns writing a set as a CiA 306 device configuration file (DCF): one
//! object section per code the set gives, with the set's value as
//! `ParameterValue` (CiA 306 §4.6.3, §5), for CANopen masters and
//! configuration tools. Only `lenze-can-sdo` schemas (Lenze ECS) have SDO
//! objects; password codes are written without their value.
//!
//! What a strict CiA 306 reader asks for is there: `[DeviceInfo]` with every
//! key (§4.5: from the schema's 0x1018 identity where it has one, Lenze's
//! vendor ID for Lenze codes, 0 = "not claimed" where driveset does not know
//! the device's bit rates or PDOs), `[MandatoryObjects]` listing 0x1000,
//! 0x1001 and 0x1018 with their sections (§4.6.2, CiA 301 §7.5: from the
//! schema, else the CiA 301 minimum), every written object in exactly one
//! list, each object's own `DataType` (the data sheet's, kept by `schema
//! import` in `data_type`). Values are written as they are: a `;` stays a
//! `;` (CiA 306 comments are whole lines); only a line break, which no INI
//! value can hold, becomes a space.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use crate::canonical::{RawValue, ResolvedSet};
use crate::schema::{Access, Code, Schema};
use crate::value::ValueType;

use super::import::{LENZE_INDEX_BASE, LENZE_VENDOR_ID};

/// Why a set cannot be written as a DCF.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DcfError {
    /// What is wrong.
    pub message: String,
    /// What to do.
    pub help: String,
}

/// A whole code and the set's (subcode, raw value) pairs for it.
type Whole<'a> = (&'a Code, Vec<(Option<u32>, &'a RawValue)>);

/// One SDO object of the DCF: a whole code (VAR, or ARRAY of its subcodes)
/// with the set's (subcode, raw) pairs, or single-subindex codes (RECORD
/// entries, `[[code]] subindex`) with their values.
#[derive(Default)]
struct Object<'a> {
    whole: Option<Whole<'a>>,
    parts: BTreeMap<u8, (&'a Code, Option<&'a RawValue>)>,
}

/// A CiA 306 object list section and which indexes it lists.
type ObjectList = (&'static str, fn(u16) -> bool);

/// The objects CiA 306 §4.6.2 lists as mandatory (CiA 301 §7.5: device
/// type, error register, identity).
const MANDATORY: [u16; 3] = [0x1000, 0x1001, 0x1018];

/// CiA 301 data type number of a schema type on CAN (the data sheet's own,
/// `data_type`, wins where the schema has it).
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

/// A DCF value: text to the end of the line. Nothing is changed but a line
/// break or other control character (which would end the line) -> space.
fn clean(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect()
}

fn raw_text(raw: &RawValue) -> String {
    match raw {
        RawValue::Int(i) => i.to_string(),
        RawValue::Text(t) => clean(t),
        RawValue::Octets(o) => o.iter().map(|b| format!("{b:02X}")).collect(),
    }
}

/// The SDO index of `code` (with its number), or an error.
fn index_of(schema: &Schema, code: &Code, subcode: Option<u32>) -> Result<u16, DcfError> {
    let base = schema.can_index_base.unwrap_or(LENZE_INDEX_BASE);
    let index = match code.index {
        Some(i) => Some(i),
        None => base
            .checked_sub(code.number)
            .and_then(|i| u16::try_from(i).ok()),
    };
    index.ok_or_else(|| DcfError {
        message: format!(
            "{} has no SDO index (code above the index base {base})",
            schema.display_code(code.number, subcode)
        ),
        help: "check the schema's [schema.can] index_base".into(),
    })
}

/// A code's default as raw, unless it is a password.
fn default_raw(schema: &Schema, code: &Code) -> Option<RawValue> {
    if schema.is_password(code) {
        return None;
    }
    code.default
        .as_ref()
        .and_then(|f| schema.fact_raw(code, f).ok())
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
    if !schema.family.descriptor().on_can() {
        return Err(DcfError {
            message: format!(
                "set uses schema `{}`, which is not a CANopen (lenze-can-sdo) family; a DCF describes CANopen SDO objects",
                schema.id
            ),
            help: "write a DCF from a Lenze ECS set (schema lenze-ecs or one made by `driveset schema import`); use --to toml|yaml|json for other families".into(),
        });
    }
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
        let index = index_of(schema, code, key.subcode)?;
        let obj = objects.entry(index).or_default();
        match code.subindex {
            Some(sub) => {
                obj.parts.insert(sub, (code, Some(raw)));
            }
            None => obj
                .whole
                .get_or_insert((code, Vec::new()))
                .1
                .push((key.subcode, raw)),
        }
    }
    // the mandatory objects, from the schema where it has them
    for code in &schema.codes {
        let Some(index) = code.index.filter(|i| MANDATORY.contains(i)) else {
            continue;
        };
        let obj = objects.entry(index).or_default();
        match code.subindex {
            Some(sub) => {
                obj.parts.entry(sub).or_insert((code, None));
            }
            None => {
                obj.whole.get_or_insert((code, Vec::new()));
            }
        }
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
    device_info(&mut t, schema);
    t.push_str("\n[DeviceComissioning]\n");
    if let Some(n) = node_id {
        let _ = writeln!(t, "NodeID=0x{n:02X}");
    }
    let _ = writeln!(t, "NodeName={}", name.as_deref().unwrap_or(&set.schema));
    let lists: [ObjectList; 3] = [
        ("MandatoryObjects", |i| MANDATORY.contains(&i)),
        ("OptionalObjects", |i| {
            !MANDATORY.contains(&i) && !(0x2000..=0x5FFF).contains(&i)
        }),
        ("ManufacturerObjects", |i| (0x2000..=0x5FFF).contains(&i)),
    ];
    for (section, belongs) in lists {
        let mut here: Vec<u16> = objects.keys().copied().filter(|i| belongs(*i)).collect();
        if section == "MandatoryObjects" {
            here = MANDATORY.to_vec();
        }
        let _ = writeln!(t, "\n[{section}]\nSupportedObjects={}", here.len());
        for (n, i) in here.iter().enumerate() {
            let _ = writeln!(t, "{}=0x{i:04X}", n + 1);
        }
    }
    for index in MANDATORY {
        if !objects.contains_key(&index) {
            mandatory_minimum(&mut t, index);
        }
    }
    for (index, obj) in &objects {
        write_object(&mut t, schema, *index, obj)?;
    }
    Ok(t)
}

/// `[DeviceInfo]` (CiA 306 §4.5) from what the schema knows: the identity
/// object's defaults (0x1018 sub 1..3), Lenze's vendor ID for a schema of
/// Lenze codes, the title as product name; 0 ("not claimed") for what a
/// schema does not hold (bit rates, PDOs, granularity, LSS).
fn device_info(t: &mut String, schema: &Schema) {
    let identity = |sub: u8| -> Option<i64> {
        let code = schema
            .codes
            .iter()
            .find(|c| c.index == Some(0x1018) && c.subindex == Some(sub))?;
        match default_raw(schema, code)? {
            RawValue::Int(v) => Some(v),
            _ => None,
        }
    };
    let lenze_codes = schema.codes.iter().any(|c| c.index.is_none());
    let vendor = identity(1).or(lenze_codes.then_some(LENZE_VENDOR_ID as i64));
    t.push_str("\n[DeviceInfo]\n");
    let _ = writeln!(
        t,
        "VendorName={}",
        if vendor == Some(LENZE_VENDOR_ID as i64) {
            "Lenze"
        } else {
            ""
        }
    );
    let hex = |v: Option<i64>| format!("0x{:08X}", v.unwrap_or(0));
    let _ = writeln!(t, "VendorNumber={}", hex(vendor));
    let _ = writeln!(t, "ProductName={}", clean(&schema.title));
    let _ = writeln!(t, "ProductNumber={}", hex(identity(2)));
    let _ = writeln!(t, "RevisionNumber={}", hex(identity(3)));
    t.push_str("OrderCode=\n");
    t.push_str(
        "; bit rates, PDOs, granularity, LSS: not in the schema, so 0 (not claimed); the data sheet says them\n",
    );
    for rate in [10, 20, 50, 125, 250, 500, 800, 1000] {
        let _ = writeln!(t, "BaudRate_{rate}=0");
    }
    t.push_str(
        "SimpleBootUpMaster=0\nSimpleBootUpSlave=0\nGranularity=0\nDynamicChannelsSupported=0\nGroupMessaging=0\nNrOfRXPDO=0\nNrOfTXPDO=0\nLSS_Supported=0\n",
    );
}

/// A mandatory object the schema does not hold: CiA 301's minimum (§7.5.2:
/// 0x1000 device type and 0x1001 error register read-only, 0x1018 identity
/// with sub 1 vendor-ID), no value.
fn mandatory_minimum(t: &mut String, index: u16) {
    match index {
        0x1000 => t.push_str(
            "\n[1000]\nParameterName=Device type\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nPDOMapping=0\n",
        ),
        0x1001 => t.push_str(
            "\n[1001]\nParameterName=Error register\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nPDOMapping=0\n",
        ),
        _ => t.push_str(
            "\n[1018]\nParameterName=Identity object\nObjectType=0x9\nSubNumber=2\n\
             \n[1018sub0]\nParameterName=Highest sub-index supported\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=1\nPDOMapping=0\n\
             \n[1018sub1]\nParameterName=Vendor-ID\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nPDOMapping=0\n",
        ),
    }
}

/// The `DataType` of a code: the data sheet's (`data_type`), else its type's.
fn code_data_type(schema: &Schema, code: &Code) -> Result<u16, DcfError> {
    let ty = schema.type_of(code);
    code.data_type
        .or_else(|| ty.and_then(data_type))
        .ok_or_else(|| DcfError {
            message: format!(
                "{}: type {} has no CANopen data type",
                schema.display_code(code.number, None),
                ty.map_or("?", ValueType::name)
            ),
            help: "give the code a CAN type in the schema (FIX32, BITCODED, VS, VO, UNSIGNED8..INTEGER32)".into(),
        })
}

/// One variable section: `[IIII]` or `[IIIIsubS]`.
fn write_var(
    t: &mut String,
    schema: &Schema,
    section: &str,
    pname: &str,
    code: &Code,
    raw: Option<&RawValue>,
) -> Result<(), DcfError> {
    let dt = code_data_type(schema, code)?;
    let access = if code.access == Some(Access::Ro) {
        "ro"
    } else {
        "rw"
    };
    let _ = writeln!(
        t,
        "\n[{section}]\nParameterName={}\nObjectType=0x7\nDataType=0x{dt:04X}\nAccessType={access}",
        clean(pname)
    );
    let secret = schema.is_password(code);
    if !secret {
        for (k, f) in [
            ("DefaultValue", &code.default),
            ("LowLimit", &code.min),
            ("HighLimit", &code.max),
        ] {
            if let Some(raw) = f.as_ref().and_then(|f| schema.fact_raw(code, f).ok()) {
                let _ = writeln!(t, "{k}={}", raw_text(&raw));
            }
        }
    }
    t.push_str("PDOMapping=0\n");
    match raw {
        Some(_) if secret => t.push_str("; ParameterValue not written: the code is a password\n"),
        Some(raw) => {
            let _ = writeln!(t, "ParameterValue={}", raw_text(raw));
        }
        None => {}
    }
    Ok(())
}

fn write_object(
    t: &mut String,
    schema: &Schema,
    index: u16,
    obj: &Object<'_>,
) -> Result<(), DcfError> {
    if let Some((code, values)) = &obj.whole {
        let pname = code.title.as_deref().unwrap_or(&code.name);
        let subs: Vec<(u32, &RawValue)> = values
            .iter()
            .filter_map(|(s, r)| s.map(|s| (s, *r)))
            .filter(|(s, _)| *s <= 255)
            .collect();
        if code.subcodes.is_none() {
            let raw = values.first().map(|v| v.1);
            return write_var(t, schema, &format!("{index:04X}"), pname, code, raw);
        }
        let top = code
            .subcodes
            .unwrap_or(0)
            .max(subs.iter().map(|s| s.0).max().unwrap_or(0));
        let _ = writeln!(
            t,
            "\n[{index:04X}]\nParameterName={}\nObjectType=0x8\nSubNumber={}",
            clean(pname),
            subs.len() + 1
        );
        let _ = writeln!(
            t,
            "\n[{index:04X}sub0]\nParameterName=Highest sub-index supported\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue={top}\nPDOMapping=0"
        );
        for (s, raw) in subs {
            write_var(
                t,
                schema,
                &format!("{index:04X}sub{s:X}"),
                &format!("{pname} {s}"),
                code,
                Some(raw),
            )?;
        }
        return Ok(());
    }
    // single-subindex codes: a RECORD of the entries the schema knows
    let top = schema
        .codes
        .iter()
        .filter(|c| c.index == Some(index))
        .filter_map(|c| c.subindex)
        .max()
        .unwrap_or(0);
    let name = match index {
        0x1018 => "Identity object".to_string(),
        _ => {
            // the common part of the entries' titles ("Identity: Vendor-ID")
            let first = obj.parts.values().next().map(|(c, _)| c);
            first
                .and_then(|c| c.title.as_deref())
                .and_then(|t| t.split_once(": ").map(|p| p.0.to_string()))
                .unwrap_or_else(|| format!("Object 0x{index:04X}"))
        }
    };
    // CiA 301 makes 0x1018 a RECORD; entries of one DataType are an ARRAY
    let types: Vec<u16> = obj
        .parts
        .values()
        .map(|(c, _)| code_data_type(schema, c))
        .collect::<Result<_, _>>()?;
    let array = index != 0x1018 && types.windows(2).all(|w| w[0] == w[1]);
    let _ = writeln!(
        t,
        "\n[{index:04X}]\nParameterName={}\nObjectType={}\nSubNumber={}",
        clean(&name),
        if array { "0x8" } else { "0x9" },
        obj.parts.len() + 1
    );
    let _ = writeln!(
        t,
        "\n[{index:04X}sub0]\nParameterName=Highest sub-index supported\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue={top}\nPDOMapping=0"
    );
    for (sub, (code, raw)) in &obj.parts {
        let pname = code.title.as_deref().unwrap_or(&code.name);
        let pname = pname.split_once(": ").map_or(pname, |p| p.1);
        write_var(
            t,
            schema,
            &format!("{index:04X}sub{sub:X}"),
            pname,
            code,
            *raw,
        )?;
    }
    Ok(())
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
            t.contains("\n[6040]\nParameterName=W; x\nObjectType=0x7\nDataType=0x0003\nAccessType=rw\nPDOMapping=0\nParameterValue=-2\n"),
            "{t}"
        );
        assert!(
            t.contains("\n[OptionalObjects]\nSupportedObjects=1\n1=0x6040\n"),
            "{t}"
        );
        assert!(!t.contains("NodeID="), "{t}");
    }

    #[test]
    fn device_data_types_records_device_info_and_mandatory_objects() {
        let text = "[schema]\nid = \"t\"\ntitle = \"Axis\"\nprotocol = \"lenze-can-sdo\"\ncode_style = \"lenze\"\n\
             [[code]]\nindex = 0x2001\nname = \"torque\"\ntitle = \"Block torque\"\nspec = \"s\"\ntype = \"UNSIGNED16\"\nmin = \"0\"\nmax = \"1000\"\n\
             [[code]]\nnumber = 11\nname = \"u32\"\ntitle = \"U32\"\nspec = \"s\"\ntype = \"FIX32\"\ndata_type = 0x0007\n\
             [[code]]\nindex = 0x1018\nsubindex = 1\nname = \"vendor\"\ntitle = \"Identity: Vendor-ID\"\nspec = \"s\"\ntype = \"UNSIGNED32\"\ndefault = \"1234\"\naccess = \"ro\"\n\
             [[code]]\nindex = 0x1018\nsubindex = 2\nname = \"product\"\ntitle = \"Identity: Product code\"\nspec = \"s\"\ntype = \"UNSIGNED32\"\ndefault = \"0x42\"\naccess = \"ro\"\n\
             [[code]]\nindex = 0x6000\nsubindex = 3\nname = \"b\"\ntitle = \"Rec: b\"\nspec = \"s\"\ntype = \"UNSIGNED8\"\n";
        let s = Registry::new()
            .add_source(SourceFile::new("t.toml", text))
            .unwrap();
        let mut set = ResolvedSet::new(&s);
        set.insert(CodeKey::new(0x1_2001), RawValue::Int(500));
        set.insert(CodeKey::new(11), RawValue::Int(70000));
        set.insert(
            CodeKey::new(crate::schema::index_number(0x6000, Some(3))),
            RawValue::Int(7),
        );
        let t = write_dcf(&set, &s, None, "t.dcf", Some(3)).unwrap();
        // its own DataType: UNSIGNED16 stays 0x0006, the UNSIGNED32 the
        // data sheet gave a FIX32 code stays 0x0007
        assert!(t.contains("\n[2001]\nParameterName=Block torque\nObjectType=0x7\nDataType=0x0006\nAccessType=rw\nLowLimit=0\nHighLimit=1000\nPDOMapping=0\nParameterValue=500\n"), "{t}");
        assert!(
            t.contains("\n[5FF4]\nParameterName=U32\nObjectType=0x7\nDataType=0x0007\n"),
            "{t}"
        );
        // a record of single-subindex codes
        assert!(t.contains("\n[6000]\nParameterName=Rec\nObjectType=0x8\nSubNumber=2\n\n[6000sub0]\nParameterName=Highest sub-index supported\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=3\nPDOMapping=0\n\n[6000sub3]\nParameterName=b\nObjectType=0x7\nDataType=0x0005\nAccessType=rw\nPDOMapping=0\nParameterValue=7\n"), "{t}");
        // [DeviceInfo] from the identity object; every mandatory object listed and written
        assert!(t.contains("\n[DeviceInfo]\nVendorName=\nVendorNumber=0x000004D2\nProductName=Axis\nProductNumber=0x00000042\nRevisionNumber=0x00000000\nOrderCode=\n"), "{t}");
        assert!(
            t.contains("\n[MandatoryObjects]\nSupportedObjects=3\n1=0x1000\n2=0x1001\n3=0x1018\n"),
            "{t}"
        );
        assert!(t.contains("\n[1000]\nParameterName=Device type\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nPDOMapping=0\n"), "{t}");
        assert!(t.contains("\n[1018]\nParameterName=Identity object\nObjectType=0x9\nSubNumber=3\n\n[1018sub0]\nParameterName=Highest sub-index supported\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=2\nPDOMapping=0\n\n[1018sub1]\nParameterName=Vendor-ID\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue=1234\nPDOMapping=0\n\n[1018sub2]\nParameterName=Product code\n"), "{t}");
        assert!(
            t.contains("\n[OptionalObjects]\nSupportedObjects=1\n1=0x6000\n"),
            "{t}"
        );
        assert!(
            t.contains("\n[ManufacturerObjects]\nSupportedObjects=2\n1=0x2001\n2=0x5FF4\n"),
            "{t}"
        );
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
