//! Parsing one table of a schema file: a `[[code]]` with its bit fields
//! and values, a `[[rule]]`, an `[enum.NAME]` table (docs/file-formats.md,
//! "Schema files").

use crate::doc::{Document, Node, NodeKind};
use crate::error::{InputError, InputErrorKind};
use crate::role::{BitRole, Role};

use super::reader::Reader;
use super::{
    Access, BitField, Code, EnumDef, EnumSource, Rule, StorageKind, index_number, parse_int_text,
};

pub(super) fn parse_enum_table(
    doc: &Document,
    node: &Node,
    what: &str,
) -> Result<EnumDef, InputError> {
    let NodeKind::Table(entries) = &node.kind else {
        return Err(doc.error(
            &node.span,
            format!("{what} must be a table of value = \"label\""),
            "write e.g. `0 = \"Off\"`",
        ));
    };
    let mut def = EnumDef {
        entries: Vec::new(),
        loc: Some(doc.loc(&node.span)),
    };
    for e in entries {
        let v = parse_int_text(&e.key)
            .and_then(|v| i64::try_from(v).ok())
            .ok_or_else(|| {
                doc.error(
                    &e.key_span,
                    format!("enumeration key `{}` in {what} is not an integer", e.key),
                    "enumeration keys are raw values, e.g. `0 = \"Off\"`",
                )
            })?;
        let NodeKind::Str(label) = &e.value.kind else {
            return Err(doc.error(
                &e.value.span,
                format!("label of {} in {what} must be a string", e.key),
                "write e.g. `0 = \"Off\"`",
            ));
        };
        def.entries.push((v, label.clone(), doc.loc(&e.key_span)));
    }
    Ok(def)
}

pub(super) fn parse_values(
    r: &mut Reader<'_>,
    what: &str,
) -> Result<Option<EnumSource>, InputError> {
    let inline = r.take("values");
    let reference = r.string("values_ref")?;
    match (inline, reference) {
        (Some(e), Some(_)) => Err(r.doc.error(
            &e.key_span,
            format!("{what} has both `values` and `values_ref`"),
            "keep one of them",
        )),
        (Some(e), None) => Ok(Some(EnumSource::Inline(parse_enum_table(
            r.doc, &e.value, what,
        )?))),
        (None, Some((name, loc))) => Ok(Some(EnumSource::Ref { name, loc })),
        (None, None) => Ok(None),
    }
}

pub(super) fn parse_code(doc: &Document, node: &Node) -> Result<Code, InputError> {
    let mut r = Reader::new(doc, node, "[[code]]")?;
    let index = r.uint::<u16>("index")?;
    let subindex = r.uint::<u8>("subindex")?;
    if let (Some((_, l)), None) = (&subindex, &index) {
        return Err(InputError::new(
            InputErrorKind::Structure,
            l.clone(),
            "`subindex` without `index`",
            "add the object's `index` (docs/file-formats.md, \"CiA 301 objects\")",
        ));
    }
    let sub = subindex.as_ref().map(|s| s.0);
    let (number, loc) = match (r.uint::<u32>("number")?, &index) {
        (Some((n, l)), Some((i, _))) if n != index_number(*i, sub) => {
            return Err(InputError::new(
                InputErrorKind::Structure,
                l,
                match sub {
                    None => format!(
                        "code with `index` = 0x{i:04X} has number {n}, not {} (65536 + index)",
                        index_number(*i, None)
                    ),
                    Some(s) => format!(
                        "code with `index` = 0x{i:04X}, `subindex` = {s} has number {n}, not {} (16777216 + index x 256 + subindex)",
                        index_number(*i, sub)
                    ),
                },
                "leave `number` out or write the number `index` gives (docs/file-formats.md, \"CiA 301 objects\")",
            ));
        }
        (Some(nl), _) => nl,
        (None, Some((i, l))) => (index_number(*i, sub), l.clone()),
        (None, None) => {
            return Err(doc.error(&node.span, "[[code]] has no `number`", "add `number = ...`"));
        }
    };
    let index = index.map(|i| i.0);
    let what = format!("code {number}");
    r.what = what.clone();
    let name = r.string("name")?;
    let type_name = r.string("type")?;
    let access = match r.string("access")? {
        None => None,
        Some((a, l)) => Some(match a.as_str() {
            "rw" => Access::Rw,
            "ro" => Access::Ro,
            "standstill" => Access::Standstill,
            _ => {
                return Err(InputError::new(
                    InputErrorKind::Structure,
                    l,
                    format!("unknown access `{a}` in {what}"),
                    "use rw, ro or standstill",
                ));
            }
        }),
    };
    let kind = match r.string("kind")? {
        None => None,
        Some((k, l)) => Some(match k.as_str() {
            "ram-actual" => StorageKind::RamActual,
            "ram-control" => StorageKind::RamControl,
            "eeprom" => StorageKind::Eeprom,
            "fsel-isel" => StorageKind::FselIsel,
            _ => {
                return Err(InputError::new(
                    InputErrorKind::Structure,
                    l,
                    format!("unknown kind `{k}` in {what}"),
                    "use ram-actual, ram-control, eeprom or fsel-isel",
                ));
            }
        }),
    };
    let values = parse_values(&mut r, &what)?;
    if let Some(e) = r.take("password") {
        return Err(doc.error(
            &e.key_span,
            format!("`password` in {what} is now a role"),
            "write `role = \"password\"` instead",
        ));
    }
    let (role, role_loc) = match r.string("role")? {
        None => (None, None),
        Some((t, l)) => match Role::parse(&t) {
            Some(x) => (Some(x), Some(l)),
            None => {
                let help = if t == "identify" {
                    "identify codes are listed in `[schema.identify] codes`, not by a role key"
                        .to_string()
                } else {
                    format!(
                        "use one of: {}",
                        Role::ALL
                            .into_iter()
                            .filter(|r| *r != Role::Identify)
                            .map(Role::as_str)
                            .collect::<Vec<_>>()
                            .join(", ")
                    )
                };
                return Err(InputError::new(
                    InputErrorKind::Structure,
                    l,
                    format!("unknown role `{t}` in {what}"),
                    help,
                ));
            }
        },
    };
    let stopped = match r.take("stopped") {
        None => Vec::new(),
        Some(e) => match &e.value.kind {
            NodeKind::Array(items) => items
                .iter()
                .map(|n| match &n.kind {
                    NodeKind::Num(t) => parse_int_text(t)
                        .and_then(|v| i64::try_from(v).ok())
                        .ok_or_else(|| r.wrong(e, "an array of integers (raw values)")),
                    _ => Err(r.wrong(e, "an array of integers (raw values)")),
                })
                .collect::<Result<Vec<_>, _>>()?,
            _ => return Err(r.wrong(e, "an array of integers (raw values)")),
        },
    };
    let mut bits = Vec::new();
    if let Some(e) = r.take("bits") {
        let NodeKind::Array(items) = &e.value.kind else {
            return Err(r.wrong(e, "an array of tables ([[code.bits]])"));
        };
        for item in items {
            let mut br = Reader::new(doc, item, format!("a bit field of {what}"))?;
            let (bname, bloc) = br.required_string("name")?;
            br.what = format!("bit field {bname} of {what}");
            let title = br.string("title")?.map(|t| t.0);
            let Some(be) = br.take("bits") else {
                return Err(doc.error(
                    &item.span,
                    format!("bit field {bname} of {what} has no `bits`"),
                    "add `bits = [lsb, msb]`",
                ));
            };
            let pair: Option<Vec<u32>> = match &be.value.kind {
                NodeKind::Array(v) if v.len() == 2 => v
                    .iter()
                    .map(|n| match &n.kind {
                        NodeKind::Num(t) => parse_int_text(t).and_then(|x| u32::try_from(x).ok()),
                        _ => None,
                    })
                    .collect(),
                _ => None,
            };
            let Some([lsb, msb]) = pair.as_deref().and_then(|p| <[u32; 2]>::try_from(p).ok())
            else {
                return Err(br.wrong(be, "[lsb, msb] (two non-negative integers)"));
            };
            let bits_loc = doc.loc(&be.value.span);
            let values = parse_values(&mut br, &format!("bit field {bname}"))?;
            let (brole, brole_loc) = match br.string("role")? {
                None => (None, None),
                Some((t, l)) => match BitRole::parse(&t) {
                    Some(r) => (Some(r), Some(l)),
                    None => {
                        return Err(InputError::new(
                            InputErrorKind::Structure,
                            l,
                            format!("unknown role `{t}` of bit field {bname} of {what}"),
                            format!(
                                "use one of: {}",
                                BitRole::ALL.map(BitRole::as_str).join(", ")
                            ),
                        ));
                    }
                },
            };
            br.finish()?;
            bits.push(BitField {
                name: bname,
                title,
                lsb,
                msb,
                values,
                loc: bloc,
                bits_loc,
                role: brole,
                role_loc: brole_loc,
            });
        }
    }
    let code = Code {
        number,
        name_loc: name.as_ref().map(|n| n.1.clone()),
        name: name.map(|n| n.0).unwrap_or_default(),
        aliases: r.string_list("aliases")?,
        title: r.string("title")?.map(|t| t.0),
        spec: r.string("spec")?.map(|t| t.0),
        type_name,
        unit: r.string("unit")?.map(|t| t.0),
        unit_aliases: r
            .string_list("unit_aliases")?
            .into_iter()
            .map(|t| t.0)
            .collect(),
        min: r.fact("min")?,
        max: r.fact("max")?,
        default: r.fact("default")?,
        access,
        lecom_only: r.boolean("lecom_only")?,
        subcodes: r.uint::<u32>("subcodes")?.map(|t| t.0),
        index,
        subindex: sub,
        data_type: r.uint::<u16>("data_type")?.map(|t| t.0),
        note: r.string("note")?.map(|t| t.0),
        kind,
        basis: r.boolean("basis")?,
        width: r.uint::<u8>("width")?.map(|t| t.0),
        card_writeable: r.boolean("card_writeable")?,
        role,
        role_loc,
        stopped,
        read_clears: r.boolean("read_clears")?,
        compatible: r.boolean("compatible")?,
        values_partial: r.boolean("values_partial")?,
        values,
        bits,
        loc,
        resolved_type: None,
        bounds: std::sync::OnceLock::new(),
    };
    r.finish()?;
    Ok(code)
}

pub(super) fn parse_rule(doc: &Document, node: &Node) -> Result<Rule, InputError> {
    let mut r = Reader::new(doc, node, "[[rule]]")?;
    let (kind, kloc) = r.required_string("kind")?;
    let loc = kloc.clone();
    let message = r.required_string("message")?.0;
    let _spec = r.string("spec")?;
    let _note = r.string("note")?;
    let rule = match kind.as_str() {
        "distinct-fields" => {
            let code = r
                .uint::<u32>("code")?
                .ok_or_else(|| doc.error(&node.span, "rule has no `code`", "add `code = ...`"))?
                .0;
            let fields = r.string_list("fields")?.into_iter().map(|f| f.0).collect();
            Rule::DistinctFields {
                code,
                fields,
                message,
                loc,
            }
        }
        "less-or-equal" => {
            let left = r
                .uint::<u32>("left")?
                .ok_or_else(|| doc.error(&node.span, "rule has no `left`", "add `left = ...`"))?
                .0;
            let right = r
                .uint::<u32>("right")?
                .ok_or_else(|| doc.error(&node.span, "rule has no `right`", "add `right = ...`"))?
                .0;
            Rule::LessOrEqual {
                left,
                right,
                message,
                loc,
            }
        }
        other => {
            return Err(InputError::new(
                InputErrorKind::Structure,
                kloc,
                format!("unknown rule kind `{other}`"),
                "use distinct-fields or less-or-equal",
            ));
        }
    };
    r.finish()?;
    Ok(rule)
}
