//! The manifest's address is the truth: a set's bus address code (role
//! `bus-address`) or line rate code (role `baud-rate`) that disagrees with
//! the drive's manifest address or its bus's rate (`set-address`,
//! `set-rate`).

use driveset_schema::{CodeKey, Location, RawValue, Role, Schema};

use super::{Bus, Drive, ManifestFinding};

/// The engineering whole number a bus code's value stands for: the number
/// its label starts with (Tmd C0125 `1 = "4800 bps ..."`), else its
/// engineering value (a VD C0009 = 2.0000 is 2).
pub(crate) fn bus_code_number(
    schema: &Schema,
    code: &driveset_schema::Code,
    raw: &RawValue,
) -> Option<i64> {
    let RawValue::Int(r) = raw else { return None };
    if let Some(label) = schema.enum_label(code, *r) {
        let digits: String = label.chars().take_while(char::is_ascii_digit).collect();
        return digits.parse().ok();
    }
    match schema.type_of(code) {
        Some(ty) => match driveset_schema::value::raw_to_decimal(ty, *r) {
            Some(d) => d.to_integer().and_then(|v| i64::try_from(v).ok()),
            None => Some(*r),
        },
        None => Some(*r),
    }
}

/// `set-address` / `set-rate`: the drive's set gives its bus address code
/// (or its line rate code) a value other than the manifest's address of the
/// drive (or its bus's rate). `None` where they agree, or where the bus has
/// no rate to compare with.
pub(crate) fn bus_code_finding(
    d: &Drive,
    key: CodeKey,
    set_loc: &Location,
    addr_loc: &Location,
    bus: Option<&Bus>,
    rate_loc: Option<&Location>,
) -> Option<ManifestFinding> {
    let schema = &d.schema;
    let code = schema.code(key.number)?;
    let raw = d.set.values.get(&key)?;
    let got = bus_code_number(schema, code, raw);
    let label = schema.display_code(key.number, key.subcode);
    let shown = driveset_schema::validate::display_value(schema, code, raw);
    match code.role()? {
        Role::BusAddress => {
            if got == Some(i64::from(d.address)) {
                return None;
            }
            let f = ManifestFinding::new(
                "set-address",
                set_loc.clone(),
                format!(
                    "set `{}` gives {label} = {shown}, but the manifest puts drive `{}` at address {} on bus `{}`",
                    d.set_text, d.name, d.address, d.bus
                ),
                format!(
                    "the manifest's address is the truth: remove {label} from the set, or give drive `{}` address {shown} in the manifest",
                    d.name
                ),
            );
            Some(f.related("the drive's address in the manifest", addr_loc.clone()))
        }
        Role::BaudRate => {
            let bus = bus?;
            if bus.rate == 0 || got == Some(i64::from(bus.rate)) {
                return None;
            }
            let f = ManifestFinding::new(
                "set-rate",
                set_loc.clone(),
                format!(
                    "set `{}` gives {label} = {shown}, but bus `{}` of drive `{}` runs at {} baud",
                    d.set_text, d.bus, d.name, bus.rate
                ),
                format!(
                    "the manifest's rate is the truth: remove {label} from the set, or give bus `{}` the set's rate in the manifest",
                    d.bus
                ),
            );
            Some(match rate_loc {
                Some(l) => f.related("the bus's rate in the manifest", l.clone()),
                None => f,
            })
        }
        _ => None,
    }
}
