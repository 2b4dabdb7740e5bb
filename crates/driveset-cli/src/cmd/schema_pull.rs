//! `driveset schema pull --port P --address A --family vf1000|mc6000
//! [--params 1-99 | LIST] -o FILE`: build a schema file from a LUSTBUS
//! drive's own parameter descriptions (LUSTBUS section 11: VF1000 specifier
//! 1, 26 characters; MC6000/7000 specifier 3) and, on MC6000/7000, the
//! value substitution texts (SELECT 108-STEXT = index, ENQUIRY 61ppp) of
//! parameters the description marks ShowText and the unit strings (107-UNIT).
//!
//! Every parameter of the range is asked for its description; a NAK means
//! "no such parameter" and is skipped. The file follows docs/file-formats.md
//! and passes `driveset schema check`; each code says
//! `spec = "pulled from <port> address <a>"`. Nothing but the RAM selector
//! 108-STEXT is written, and it is set back to what it held.

// EngineError is large by design; it is built on the failure path only.
#![allow(clippy::result_large_err)]

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::PathBuf;

use driveset_engine::client::LustbusClient;
use driveset_link::{ByteLink, Link};
use driveset_proto::lustbus::description::{
    Attributes, McDescription, McExtended, McKind, UNIT, VfDescription, VfStorage,
    decode_substitution_text,
};
use driveset_proto::lustbus::{ParameterCode, ParameterType};
use driveset_schema::ValueType;
use driveset_schema::value::raw_to_engineering;
use serde_json::json;

use super::identify::BusFormat;
use crate::EXIT_OK;
use crate::output;
use crate::port::{self, Fail};

/// `--family` of `schema pull`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum PullFamily {
    /// Lust SMARTDRIVE VF1000 (descriptions only; parameters 1..99).
    Vf1000,
    /// Lust MASTERCONTROL MC6000/7000 (descriptions, units, substitution texts; 1..999).
    Mc6000,
}

/// Arguments of `driveset schema pull`.
#[derive(clap::Args)]
#[command(after_help = "\
Asks every parameter of the range for its description (a NAK: no such
parameter, skipped) and writes a schema file: name, type, unit, min, max,
factory default, storage kind, width, read-only for actual values,
CardWriteable (MC activity area), and on MC6000/7000 the value substitution
texts of ShowText parameters as [code.values]. Only the RAM selector
108-STEXT is written (and set back afterwards).

Exit codes: 0 written, 2 usage or input error, 3 bus or device failure.

Examples:
  driveset schema pull --port sim://mc6000?addresses=1 --address 1 --family mc6000 --params 1-200 -o pulled-mc.toml
  driveset schema pull --port /dev/ttyUSB0 --address 2 --family vf1000 -o vf1000-live.toml")]
pub struct Args {
    /// The port.
    #[arg(long)]
    pub port: String,
    /// Bus address (1..30).
    #[arg(long)]
    pub address: u8,
    /// The drive family (decides the description format).
    #[arg(long, value_enum)]
    pub family: PullFamily,
    /// Parameters to ask for: ranges and numbers, e.g. `1-99` or `1,5,100-120`
    /// (default VF1000 1-99, MC6000/7000 1-999).
    #[arg(long, value_name = "LIST")]
    pub params: Option<String>,
    /// The schema file to write.
    #[arg(short = 'o', long = "output", value_name = "FILE")]
    pub output: PathBuf,
    /// The schema id to write (default `pulled-<family>-<address>`).
    #[arg(long)]
    pub id: Option<String>,
    /// Output format of the report on stdout.
    #[arg(long, value_enum, default_value = "human")]
    pub format: BusFormat,
}

/// Run `driveset schema pull`.
pub fn run(args: Args) -> anyhow::Result<u8> {
    port::finish(schema_pull(&args))
}

/// `1-99`, `1,5,100-120` -> sorted unique numbers.
pub fn parse_params(text: &str, max: u32) -> Result<Vec<u32>, String> {
    let mut out = BTreeSet::new();
    for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (a, b) = match part.split_once('-') {
            Some((a, b)) => (a.trim(), b.trim()),
            None => (part, part),
        };
        let num = |s: &str| {
            s.parse::<u32>()
                .map_err(|_| format!("`{part}` in --params is not a number or a range like 1-99"))
        };
        let (a, b) = (num(a)?, num(b)?);
        if a > b || b > max {
            return Err(format!(
                "`{part}` in --params: ranges go up, within 0..={max} for this family"
            ));
        }
        out.extend(a..=b);
    }
    if out.is_empty() {
        return Err("--params names no parameter".into());
    }
    Ok(out.into_iter().collect())
}

fn q(s: &str) -> String {
    serde_json::to_string(s).unwrap_or_else(|_| "\"\"".into())
}

/// The raw integer of a description bound (signed types sign-extended).
fn signed(ty: ParameterType, raw: u32) -> i64 {
    match ty {
        ParameterType::Integer16 => i64::from(raw as u16 as i16),
        ParameterType::Int32Q16 => i64::from(raw as i32),
        _ => i64::from(raw),
    }
}

fn width_of(ty: ParameterType) -> u8 {
    match ty {
        ParameterType::Usign8 | ParameterType::Binary8 => 1,
        ParameterType::Int32Q16 | ParameterType::FloatIeee | ParameterType::McError => 4,
        _ => 2,
    }
}

/// One pulled code.
struct Pulled {
    number: u32,
    name: String,
    ty: ParameterType,
    unit: Option<String>,
    kind: &'static str,
    basis: Option<bool>,
    card_writeable: Option<bool>,
    min: i64,
    max: i64,
    default: i64,
    texts: BTreeMap<i64, String>,
}

fn schema_pull(args: &Args) -> Result<u8, Fail> {
    let (schema_id, family_name, max_param) = match args.family {
        PullFamily::Vf1000 => ("lust-vf1000", "vf1000", 99),
        PullFamily::Mc6000 => ("lust-mc6000", "mc6000", 999),
    };
    let params = parse_params(
        args.params
            .as_deref()
            .unwrap_or(if max_param == 99 { "1-99" } else { "1-999" }),
        max_param,
    )
    .map_err(Fail::input)?;
    let registry = port::registry(&[])?;
    let schema = registry
        .get(schema_id)
        .ok_or_else(|| Fail::input(format!("built-in schema {schema_id} is missing")))?;
    let opened = port::open_port(&args.port)?;
    port::check_fit(&opened, &schema, Some(args.address), false)?;
    let port_name = opened.name.clone();
    let link: Box<dyn ByteLink> = match opened.link {
        Link::Bytes(l) => l,
        Link::Frames(_) => {
            return Err(Fail::input(format!(
                "{port_name} is a CAN port; schema pull reads LUSTBUS descriptions"
            )));
        }
    };
    let mut client = LustbusClient::new(link, schema.clone(), args.address)?;
    let mc = args.family == PullFamily::Mc6000;
    let source = format!("pulled from {port_name} address {}", args.address);

    let mut codes: Vec<Pulled> = Vec::new();
    let mut absent = 0usize;
    let mut undecodable: Vec<String> = Vec::new();
    let mut units: BTreeMap<u8, Option<String>> = BTreeMap::new();
    let mut stext_old: Option<u8> = None;
    let mut texts_read = 0usize;
    for &p in &params {
        let code = if mc {
            u16::try_from(p)
                .ok()
                .and_then(ParameterCode::mc_description)
        } else {
            u8::try_from(p)
                .ok()
                .and_then(|n| ParameterCode::vf_description(1, n))
        };
        let Some(code) = code else { continue };
        let Some(text) = client.enquire_code(code, if mc { 52 } else { 26 })? else {
            absent += 1;
            continue;
        };
        if mc {
            let d = match McDescription::decode(text.as_bytes()) {
                Ok(d) => d,
                Err(e) => {
                    undecodable.push(format!("{p}: {e}"));
                    continue;
                }
            };
            let ext = match d.extended {
                McExtended::Decoded(e) => Some(e),
                _ => None,
            };
            let mut texts = BTreeMap::new();
            let show_text = ext.is_some_and(|e| e.attributes.0 & Attributes::SHOW_TEXT.0 != 0);
            if show_text && d.ty == ParameterType::Usign8 {
                if stext_old.is_none() {
                    stext_old = Some(read_stext(&mut client)?);
                }
                let lo = signed(d.ty, d.min).clamp(0, 255);
                let hi = signed(d.ty, d.max).clamp(0, 255);
                let mut seen = BTreeSet::new();
                for i in lo..=hi {
                    if let Some(t) = substitution_text(&mut client, p, i as u8)?
                        && !t.is_empty()
                        && seen.insert(t.clone())
                    {
                        texts.insert(i, t);
                        texts_read += 1;
                    }
                }
            }
            let unit = if d.unit == 0 {
                None
            } else {
                if let std::collections::btree_map::Entry::Vacant(slot) = units.entry(d.unit) {
                    if stext_old.is_none() {
                        stext_old = Some(read_stext(&mut client)?);
                    }
                    let t = substitution_text(&mut client, u32::from(UNIT), d.unit)?;
                    slot.insert(t.filter(|t| !t.is_empty()));
                }
                units.get(&d.unit).cloned().flatten()
            };
            codes.push(Pulled {
                number: p,
                name: d.name.as_str().to_string(),
                ty: d.ty,
                unit,
                kind: match d.kind {
                    McKind::RamActual => "ram-actual",
                    McKind::RamControl => "ram-control",
                    McKind::Eeprom => "eeprom",
                },
                basis: None,
                card_writeable: ext
                    .and_then(|e| e.activity_area())
                    .map(|a| a.card_exchange()),
                min: signed(d.ty, d.min),
                max: signed(d.ty, d.max),
                default: signed(d.ty, d.default),
                texts,
            });
        } else {
            let d = match VfDescription::decode(text.as_bytes()) {
                Ok(d) => d,
                Err(e) => {
                    undecodable.push(format!("{p}: {e}"));
                    continue;
                }
            };
            let unit = d.unit.as_str().trim().to_string();
            codes.push(Pulled {
                number: p,
                name: d.name.as_str().trim().to_string(),
                ty: d.ty,
                unit: (!unit.is_empty()).then_some(unit),
                kind: match d.kind.storage {
                    VfStorage::RamActual => "ram-actual",
                    VfStorage::RamControl => "ram-control",
                    VfStorage::Eeprom => "eeprom",
                    VfStorage::FselIsel => "fsel-isel",
                },
                basis: Some(!d.kind.inverter_specific),
                card_writeable: None,
                min: signed(d.ty, u32::from(d.min)),
                max: signed(d.ty, u32::from(d.max)),
                default: signed(d.ty, u32::from(d.default)),
                texts: BTreeMap::new(),
            });
        }
    }
    if let Some(old) = stext_old {
        client.select_stext(old)?;
    }
    driveset_engine::client::DriveClient::finish(&mut client)?;

    let id = args
        .id
        .clone()
        .unwrap_or_else(|| format!("pulled-{family_name}-{}", args.address));
    let text = render(args, &id, &source, &codes, mc);
    if let Some(dir) = args.output.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .map_err(|e| Fail::input(format!("cannot create {}: {e}", dir.display())))?;
    }
    std::fs::write(&args.output, text)
        .map_err(|e| Fail::input(format!("cannot write {}: {e}", args.output.display())))?;

    match args.format {
        BusFormat::Json => output::emit(&format!(
            "{}\n",
            serde_json::to_string_pretty(&json!({
                "port": port_name,
                "address": args.address,
                "family": family_name,
                "file": args.output.display().to_string(),
                "id": id,
                "codes": codes.len(),
                "absent": absent,
                "substitution_texts": texts_read,
                "undecodable": undecodable,
            }))
            .unwrap_or_default()
        )),
        BusFormat::Human => {
            let mut out = String::new();
            let _ = writeln!(
                out,
                "pulled {} parameter descriptions ({} substitution texts) from {port_name} address {} into {} (schema id {id})",
                codes.len(),
                texts_read,
                args.address,
                args.output.display()
            );
            let _ = writeln!(
                out,
                "{} of {} parameters asked for are not on the drive (NAK)",
                absent,
                params.len()
            );
            for u in &undecodable {
                let _ = writeln!(out, "skipped, description does not decode: {u}");
            }
            output::emit(&out);
        }
    }
    Ok(EXIT_OK)
}

/// What 108-STEXT holds now (to set it back).
fn read_stext(client: &mut LustbusClient) -> Result<u8, Fail> {
    let code = ParameterCode::mc_value(driveset_proto::lustbus::description::STEXT)
        .unwrap_or(ParameterCode::POSMOD);
    let v = client.enquire_code(code, 8)?;
    Ok(v.and_then(|t| {
        std::str::from_utf8(t.as_bytes())
            .ok()
            .and_then(|s| u32::from_str_radix(s, 16).ok())
    })
    .and_then(|n| u8::try_from(n).ok())
    .unwrap_or(0))
}

/// Substitution text `index` of parameter `p` (section 11.3), `None` on NAK.
fn substitution_text(
    client: &mut LustbusClient,
    p: u32,
    index: u8,
) -> Result<Option<String>, Fail> {
    client.select_stext(index)?;
    let Some(code) = u16::try_from(p)
        .ok()
        .and_then(ParameterCode::substitution_text)
    else {
        return Ok(None);
    };
    Ok(client.enquire_code(code, 100)?.and_then(|t| {
        decode_substitution_text(t.as_bytes())
            .ok()
            .map(str::to_string)
    }))
}

fn render(args: &Args, id: &str, source: &str, codes: &[Pulled], mc: bool) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# Schema pulled by `driveset schema pull` from the drive's own parameter\n# descriptions (LUSTBUS section 11){}.\n# {source}: {} parameters.\n",
        if mc {
            " and substitution texts (11.3)"
        } else {
            ""
        },
        codes.len()
    );
    let _ = writeln!(out, "[schema]");
    let _ = writeln!(out, "id = {}", q(id));
    let _ = writeln!(
        out,
        "title = {}",
        q(&format!(
            "{} parameters {source}",
            if mc { "MC6000/7000" } else { "VF1000" }
        ))
    );
    let _ = writeln!(
        out,
        "protocol = {}",
        q(if mc { "lustbus-mc" } else { "lustbus-vf1000" })
    );
    let _ = writeln!(out, "code_style = \"lust\"");
    let _ = writeln!(out, "spec = {}", q(source));
    if codes.iter().any(|c| c.number == 91) {
        let _ = writeln!(out, "\n[schema.identify]\ncodes = [91]");
    }
    let mut names = BTreeSet::new();
    for c in codes {
        let mut name: String = c
            .name
            .chars()
            .filter(|ch| ch.is_ascii_alphanumeric() || *ch == '_' || *ch == '-')
            .collect();
        if name.is_empty()
            || name.chars().all(|ch| ch.is_ascii_digit())
            || name.starts_with(['C', 'c']) && name[1..].chars().all(|ch| ch.is_ascii_digit())
        {
            name = format!("P{}", c.number);
        }
        if !names.insert(name.clone()) {
            name = format!("{name}_{}", c.number);
            names.insert(name.clone());
        }
        let _ = writeln!(out, "\n[[code]]");
        let _ = writeln!(out, "number = {}", c.number);
        let _ = writeln!(out, "name = {}", q(&name));
        let _ = writeln!(out, "title = {}", q(&c.name));
        let _ = writeln!(out, "spec = {}", q(source));
        let _ = writeln!(out, "type = {}", q(c.ty.name()));
        if let Some(u) = &c.unit {
            let _ = writeln!(out, "unit = {}", q(u));
        }
        let vt = ValueType::from_name(c.ty.name());
        let bounded = !matches!(
            c.ty,
            ParameterType::Password | ParameterType::VfError | ParameterType::McError
        );
        if let (Some(vt), true) = (vt, bounded) {
            let e = |raw: i64| q(&raw_to_engineering(vt, raw));
            if c.min <= c.max && (c.min, c.max) != (0, 0) {
                let _ = writeln!(out, "min = {}", e(c.min));
                let _ = writeln!(out, "max = {}", e(c.max));
            }
            if c.kind != "ram-actual"
                && (c.min > c.max
                    || (c.min..=c.max).contains(&c.default)
                    || (c.min, c.max) == (0, 0))
            {
                let _ = writeln!(out, "default = {}", e(c.default));
            }
        }
        if c.kind == "ram-actual" {
            let _ = writeln!(out, "access = \"ro\"");
        }
        let _ = writeln!(out, "kind = {}", q(c.kind));
        if let Some(b) = c.basis {
            let _ = writeln!(out, "basis = {b}");
        }
        let _ = writeln!(out, "width = {}", width_of(c.ty));
        if let Some(cw) = c.card_writeable {
            let _ = writeln!(out, "card_writeable = {cw}");
        }
        if c.ty == ParameterType::Password {
            let _ = writeln!(out, "role = \"password\"");
        }
        if matches!(c.number, 81..=85 | 91) {
            let _ = writeln!(out, "compatible = true");
        }
        if c.number == 85 {
            let _ = writeln!(out, "read_clears = true");
        }
        if !c.texts.is_empty() {
            let _ = writeln!(out, "\n[code.values]");
            for (k, v) in &c.texts {
                let _ = writeln!(out, "{k} = {}", q(v));
            }
        }
    }
    let _ = args;
    out
}

#[cfg(test)]
mod tests {
    use super::parse_params;

    #[test]
    fn params_lists_and_ranges() {
        assert_eq!(parse_params("1-3, 7,5", 99).unwrap(), vec![1, 2, 3, 5, 7]);
        assert!(parse_params("5-1", 99).is_err());
        assert!(parse_params("1-100", 99).is_err());
        assert!(parse_params("x", 99).is_err());
    }
}
