//! Owns the telegram description language of `driveset encode`: one
//! telegram built from a readable description, for bench tests with a
//! terminal program. Pure: a description (and the schemas for decimal
//! values) in, the telegram's bytes out ([`encode`]); the CLI renders them.
//!
//! A description is a verb followed by `key=value` pairs (any order; quote a
//! value with spaces as `key="a b"`):
//!
//! ```text
//! --protocol lustbus   (LUSTBUS; VF1000 VALUE = 4 hex digits, MC6000/7000 = 1..8)
//!   enquiry  address=A (code=NNNNN | param=P)
//!   select   address=A (code=NNNNN | param=P) value=V
//!   reply    address=A (code=NNNNN | param=P) value=V     device's value reply
//!   ack      address=A          nak address=A              eot
//!     A: 0..31 (0 all devices, 31 broadcast)
//!     code=NNNNN: the five CODE digits as sent (00112, 20428)
//!     param=P: a parameter number, needs the family (family=vf1000|mc6000 or
//!       --family / --schema): MC -> 20ppp, VF1000 -> 0 0 d pp with device=1
//!       (device=0 for basis parameters); 81..85 and 91 -> 000pp on both
//!     V: 0x842666 = the raw value in hex; a decimal (132.15, -5) is converted
//!       exactly with the parameter's type from the schema (PT_FIXPOINT16
//!       x20, PT_INT32Q16 x65536, ...) and refused with the nearest
//!       representable values when it has no exact raw form
//! --protocol lecom     (LECOM-A/B)
//!   receive   address=NN code=C[/S]
//!   send      address=NN code=C[/S] value=V
//!   broadcast address=NN code=C[/S] value=V     NN = 00 or x0
//!     C: 46, C46 or C0046; /S a subcode (extended addressing)
//!     V: 95.2 (VD), H0900 or 0x0900 (VH), "Stext" (VS), O0102 (VO)
//! --protocol sdo       (Lenze system bus, CAN SDO expedited; the word `sdo`
//!                       may lead the description)
//!   read  node=N code=C [subindex=S]
//!   write node=N code=C [subindex=S] value=V
//!     N: 1..127; index = 24575 - code; V: decimal -> FIX32 (x10000, exact),
//!     0x... -> the 32-bit raw value (C0135 / C0150 are bit-coded)
//! ```
//!
//! Errors name the bad key or value and list the valid ones
//! ([`EncodeError`]).

use std::collections::BTreeMap;
use std::sync::Arc;

use driveset_proto::can::{
    CanFrame, CodeNumber as CanCode, Fix32, LenzeValue, NodeId, SdoRequest, SlcanCommand, Subindex,
    ValueFormat,
};
use driveset_proto::lecom::{self, CodeAddress, ControllerAddress, Hex, Value};
use driveset_proto::lustbus::{
    Address, CompatibleParameter, Dialect, Enquiry, ParameterCode, ParameterValue, Reply,
    Request as LustRequest, Select, ValueReply, ValueText,
};
use driveset_proto::text::escaped;
use driveset_schema::value::{ConvError, Repr, decimal_to_raw};
use driveset_schema::{BusProtocol, Decimal, Registry, Schema};

/// A description that is no telegram: what is wrong with it and what is
/// valid (`driveset encode` exits 2 with it).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EncodeError(pub String);

impl std::fmt::Display for EncodeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for EncodeError {}

/// An [`EncodeError`] of a formatted message.
macro_rules! fail {
    ($($t:tt)*) => {
        EncodeError(format!($($t)*))
    };
}

/// Return an [`EncodeError`] of a formatted message.
macro_rules! bail {
    ($($t:tt)*) => {
        return Err(fail!($($t)*))
    };
}

/// What to encode: the protocol, the LUSTBUS family given beside the
/// description (`--family`; for `param=` and decimal values), and the
/// description itself.
#[derive(Debug, Clone, Copy)]
pub struct Request<'a> {
    /// The bus protocol of the telegram.
    pub protocol: BusProtocol,
    /// The LUSTBUS dialect named beside the description.
    pub family: Option<Dialect>,
    /// The description: a verb and `key=value` pairs (module docs).
    pub description: &'a str,
}

/// An encoded telegram.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Telegram {
    /// A LUSTBUS or LECOM telegram: its bytes.
    Serial(Vec<u8>),
    /// A CAN SDO request: its frame, the frame's data and its slcan line.
    Sdo {
        /// The CAN frame.
        frame: CanFrame,
        /// The frame's data bytes.
        data: Vec<u8>,
        /// The frame as an slcan line (with CR).
        line: Vec<u8>,
    },
}

impl Telegram {
    /// The bytes `driveset encode --raw` writes: a serial telegram's, an
    /// SDO request's slcan line (with CR).
    pub fn raw(&self) -> &[u8] {
        match self {
            Telegram::Serial(bytes) => bytes,
            Telegram::Sdo { line, .. } => line,
        }
    }

    /// The telegram as `driveset encode` prints it: the bytes in hex and in
    /// escaped ASCII (`<EOT>@00112<ENQ>`, which `driveset decode --ascii`
    /// reads back); an SDO request's COB-ID, data and slcan line.
    pub fn text(&self) -> String {
        match self {
            Telegram::Serial(bytes) => format!(
                "hex:   {}\nascii: {}\n",
                super::hex_spaced(bytes),
                escaped(bytes)
            ),
            Telegram::Sdo { frame, data, line } => format!(
                "cob-id: 0x{:03X}\ndata:   {}\nslcan:  {}\n",
                frame.id,
                super::hex_spaced(data),
                escaped(line)
            ),
        }
    }
}

/// Encode the telegram `req` describes; `registry` holds the built-in
/// schemas a family's decimal values are converted with, `schema` the one
/// named (`--schema`), if any.
pub fn encode(
    req: &Request<'_>,
    registry: &Registry,
    schema: Option<Arc<Schema>>,
) -> Result<Telegram, EncodeError> {
    match req.protocol {
        BusProtocol::Lustbus => lustbus(req, registry, schema),
        BusProtocol::Lecom => lecom_telegram(req, registry, schema),
        BusProtocol::CanSdo => sdo(req, registry, schema),
    }
}

struct Desc {
    verb: String,
    keys: BTreeMap<String, String>,
}

fn tokenize(text: &str) -> Result<Vec<String>, EncodeError> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut quoted = false;
    let mut any = false;
    for c in text.chars() {
        match c {
            '"' => {
                quoted = !quoted;
                any = true;
            }
            c if c.is_whitespace() && !quoted => {
                if any {
                    out.push(std::mem::take(&mut cur));
                    any = false;
                }
            }
            c => {
                cur.push(c);
                any = true;
            }
        }
    }
    if quoted {
        bail!("unclosed `\"` in the description");
    }
    if any {
        out.push(cur);
    }
    Ok(out)
}

fn parse_desc(text: &str, verbs: &[&str]) -> Result<Desc, EncodeError> {
    let mut toks = tokenize(text)?.into_iter();
    let Some(verb) = toks.next() else {
        bail!("empty description; start with one of: {}", verbs.join(", "));
    };
    let verb = verb.to_ascii_lowercase();
    if !verbs.contains(&verb.as_str()) {
        bail!(
            "unknown telegram kind `{verb}`; valid: {}",
            verbs.join(", ")
        );
    }
    let mut keys = BTreeMap::new();
    for t in toks {
        let Some((k, v)) = t.split_once('=') else {
            bail!("`{t}` is not key=value (e.g. address=1)");
        };
        let k = k.to_ascii_lowercase();
        if keys.insert(k.clone(), v.to_string()).is_some() {
            bail!("{k}= is given twice");
        }
    }
    Ok(Desc { verb, keys })
}

impl Desc {
    fn check(&self, allowed: &[&str], required: &[&str]) -> Result<(), EncodeError> {
        for k in self.keys.keys() {
            if !allowed.contains(&k.as_str()) {
                bail!(
                    "unknown key `{k}` for {}; valid keys: {}",
                    self.verb,
                    allowed.join(", ")
                );
            }
        }
        for r in required {
            if !self.keys.contains_key(*r) {
                bail!("{} needs {r}=...", self.verb);
            }
        }
        Ok(())
    }
    fn get(&self, k: &str) -> Option<&str> {
        self.keys.get(k).map(String::as_str)
    }
}

fn parse_int(key: &str, v: &str, what: &str) -> Result<u32, EncodeError> {
    let r = if let Some(h) = v.strip_prefix("0x").or_else(|| v.strip_prefix("0X")) {
        u32::from_str_radix(h, 16)
    } else {
        v.parse::<u32>()
    };
    r.map_err(|_| fail!("{key}={v}: {what}"))
}

fn lustbus(
    req: &Request<'_>,
    registry: &Registry,
    schema: Option<Arc<Schema>>,
) -> Result<Telegram, EncodeError> {
    let d = parse_desc(
        req.description,
        &["enquiry", "select", "reply", "ack", "nak", "eot"],
    )?;
    let code_keys = ["address", "code", "param", "family", "device", "value"];
    match d.verb.as_str() {
        "eot" => d.check(&[], &[])?,
        "ack" | "nak" => d.check(&["address"], &["address"])?,
        "enquiry" => d.check(&code_keys[..5], &["address"])?,
        _ => d.check(&code_keys, &["address", "value"])?,
    }
    let address = match d.get("address") {
        Some(a) => {
            let rule = BusProtocol::Lustbus.wire_address_rule();
            let n = parse_int("address", a, rule)?;
            u8::try_from(n)
                .ok()
                .filter(|n| BusProtocol::Lustbus.wire_addresses().contains(n))
                .and_then(Address::new)
                .ok_or_else(|| fail!("address={a}: {rule}"))?
        }
        None => Address::ALL,
    };
    let family = match d.get("family") {
        Some(f) => Some(
            driveset_schema::Family::parse(f)
                .ok()
                .and_then(|f| f.descriptor().dialect)
                .ok_or_else(|| {
                    fail!(
                        "family={f}: valid families: {}",
                        BusProtocol::Lustbus
                            .families()
                            .map(driveset_schema::Family::name)
                            .collect::<Vec<_>>()
                            .join(", ")
                    )
                })?,
        ),
        None => req
            .family
            .or_else(|| schema.as_ref().and_then(|s| s.family.descriptor().dialect)),
    };
    let bytes = match d.verb.as_str() {
        "eot" => LustRequest::Eot.encode().as_bytes().to_vec(),
        "ack" => Reply::Ack(address).encode().as_bytes().to_vec(),
        "nak" => Reply::Nak(address).encode().as_bytes().to_vec(),
        verb => {
            let (code, family) = lust_code(&d, family)?;
            if verb == "enquiry" {
                Enquiry::new(address, code).encode().as_bytes().to_vec()
            } else {
                let schema = schema.or_else(|| {
                    family.and_then(|f| registry.get(super::lustbus::family_schema_id(f)))
                });
                let value = lust_value(d.get("value").unwrap_or(""), code, family, schema)?;
                if verb == "select" {
                    Select::new(address, code, value)
                        .encode()
                        .as_bytes()
                        .to_vec()
                } else {
                    Reply::Value(ValueReply {
                        address,
                        code,
                        value,
                    })
                    .encode()
                    .as_bytes()
                    .to_vec()
                }
            }
        }
    };
    Ok(Telegram::Serial(bytes))
}

fn lust_code(
    d: &Desc,
    family: Option<Dialect>,
) -> Result<(ParameterCode, Option<Dialect>), EncodeError> {
    match (d.get("code"), d.get("param")) {
        (Some(_), Some(_)) => bail!("give code= or param=, not both"),
        (None, None) => bail!("{} needs code=NNNNN (five CODE digits) or param=P", d.verb),
        (Some(c), None) => {
            if d.get("device").is_some() {
                bail!("device= goes with param=, not with code=");
            }
            let ok = !c.is_empty() && c.len() <= 5 && c.bytes().all(|b| b.is_ascii_digit());
            let code = ok
                .then(|| c.parse::<u32>().ok().and_then(ParameterCode::new))
                .flatten()
                .ok_or_else(|| {
                    fail!("code={c}: a CODE is up to five decimal digits, e.g. 00112 or 20428")
                })?;
            let fam = family.or_else(|| super::lustbus::family_of(code));
            Ok((code, fam))
        }
        (None, Some(p)) => {
            let n = parse_int("param", p, "a parameter number, e.g. 428")?;
            if let Some(c) = u16::try_from(n)
                .ok()
                .and_then(CompatibleParameter::from_number)
            {
                return Ok((ParameterCode::compatible(c), family));
            }
            let Some(fam) = family else {
                bail!("param={p} needs the device family: add family=vf1000 or family=mc6000");
            };
            let code = match fam {
                Dialect::Mc => u16::try_from(n).ok().and_then(ParameterCode::mc_value),
                Dialect::Vf1000 => {
                    let device = match d.get("device") {
                        None | Some("1") => 1,
                        Some("0") => 0,
                        Some(x) => bail!("device={x}: valid: 0 (basis parameter), 1 (VF1000)"),
                    };
                    u8::try_from(n)
                        .ok()
                        .and_then(|p| ParameterCode::vf_value(device, p))
                }
            };
            let code = code.ok_or_else(|| {
                // the CODE's parameter digits: the family's highest
                // parameter (VF1000 99, MC 999; its descriptor's)
                let max = driveset_schema::Family::from_dialect(fam)
                    .descriptor()
                    .max_parameter()
                    .unwrap_or_default();
                fail!("param={p}: {fam} parameters are 0..{max}")
            })?;
            Ok((code, Some(fam)))
        }
    }
}

fn lust_value(
    v: &str,
    code: ParameterCode,
    family: Option<Dialect>,
    schema: Option<Arc<Schema>>,
) -> Result<ValueText, EncodeError> {
    if let Some(h) = v.strip_prefix("0x").or_else(|| v.strip_prefix("0X")) {
        let raw = u32::from_str_radix(h, 16)
            .map_err(|_| fail!("value={v}: not a hex number (at most 8 digits)"))?;
        let text = match family {
            Some(Dialect::Vf1000) => {
                if raw > 0xFFFF {
                    bail!("value={v}: a VF1000 VALUE is 4 hex digits, at most 0xFFFF");
                }
                format!("{raw:04X}")
            }
            Some(Dialect::Mc) => format!("{raw:X}"),
            None => {
                let digits = h.trim_start_matches('0');
                if h.len() == 4 {
                    h.to_ascii_uppercase()
                } else if digits.is_empty() {
                    "0".into()
                } else {
                    digits.to_ascii_uppercase()
                }
            }
        };
        return ValueText::new(text.as_bytes()).map_err(|e| fail!("value={v}: {e}"));
    }
    let Some(family) = family else {
        bail!(
            "value={v}: give the value as raw hex (value=0x03E8), or name the family (family=vf1000|mc6000) so the parameter's type can convert a decimal"
        );
    };
    let number = super::lustbus::value_parameter(code).ok_or_else(|| {
        fail!("value={v}: CODE {code} is not a parameter value; give value=0x...")
    })?;
    let schema =
        schema.ok_or_else(|| fail!("value={v}: no schema for {family}; give value=0x..."))?;
    let Some(ty) = super::lustbus::wire_type(&schema, number) else {
        bail!(
            "value={v}: schema {} gives no type for parameter {number}; give the raw value as value=0x...",
            schema.id
        );
    };
    let vt = driveset_schema::ValueType::from_name(ty.name())
        .ok_or_else(|| fail!("value={v}: unknown type {}", ty.name()))?;
    let raw: i64 = match vt.repr() {
        Repr::Scaled(_) => {
            let dec = Decimal::parse(v).map_err(|_| {
                fail!("value={v}: not a number; write a decimal (132.15) or raw hex (0x842666)")
            })?;
            decimal_to_raw(vt, None, &dec).map_err(|e| match e {
                ConvError::Unrepresentable { step, lower, upper } => fail!(
                    "value={v}: {} ({}) has steps of {step}; {v} is not representable; nearest values: {lower} and {upper}",
                    schema.display_code(number, None),
                    ty.name()
                ),
                ConvError::OutOfRange { min, max } => fail!(
                    "value={v}: out of range for {} ({}): {min} to {max}",
                    schema.display_code(number, None),
                    ty.name()
                ),
            })?
        }
        Repr::Float => driveset_schema::value::float_text_to_raw(v).map_err(|e| match e {
            Some(_) => {
                let (min, max) = driveset_schema::value::engineering_range(vt, None);
                fail!(
                    "value={v}: outside the f32 range of {} ({}): {min} to {max}",
                    schema.display_code(number, None),
                    ty.name()
                )
            }
            None => fail!("value={v}: not a finite decimal for {}", ty.name()),
        })?,
        _ => bail!("value={v}: type {} takes raw hex (value=0x...)", ty.name()),
    };
    let pv = ParameterValue::from_raw(ty, raw as u32 & mask(ty))
        .ok_or_else(|| fail!("value={v}: does not fit {}", ty.name()))?;
    pv.encode(family).map_err(|e| fail!("value={v}: {e}"))
}

fn mask(ty: driveset_proto::lustbus::ParameterType) -> u32 {
    use driveset_proto::lustbus::ParameterType as T;
    match ty {
        T::Integer16 => 0xFFFF,
        _ => u32::MAX,
    }
}

fn lecom_code(c: &str) -> Result<CodeAddress, EncodeError> {
    let (num, sub) = match c.split_once('/') {
        Some((n, s)) => (n, Some(s)),
        None => (c, None),
    };
    let digits = num.strip_prefix(['C', 'c']).unwrap_or(num);
    let n: u16 = digits.parse().map_err(|_| {
        fail!("code={c}: write a code number like 46, C46 or C0046 (subcode: C1002/1)")
    })?;
    let s: u8 = match sub {
        Some(s) => s
            .parse()
            .map_err(|_| fail!("code={c}: subcode {s} is not 0..255"))?,
        None => 0,
    };
    Ok(CodeAddress::select(n, s))
}

/// A decimal written with an exponent (`1e-4`, `2.5E3`), as sets accept
/// it (docs/file-formats.md), as the plain decimal of the same exact number
/// (`0.0001`): the wire formats (LECOM VD, 8.E; FIX32 text) have no
/// exponent. `None` when `v` has no exponent or is not such a number.
fn without_exponent(v: &str) -> Option<String> {
    if !v.contains(['e', 'E'])
        || !v.starts_with(|c: char| c.is_ascii_digit() || matches!(c, '-' | '+' | '.'))
    {
        return None;
    }
    Decimal::parse(v).ok().map(|d| d.to_string())
}

fn lecom_value(v: &str, code: CodeAddress, schema: Option<&Schema>) -> Result<Value, EncodeError> {
    if let Some(h) = v.strip_prefix("0x").or_else(|| v.strip_prefix("0X")) {
        let raw = u32::from_str_radix(h, 16).map_err(|_| fail!("value={v}: not a hex number"))?;
        let width = schema
            .and_then(|s| s.code(u32::from(code.code())))
            .and_then(|c| c.width)
            .unwrap_or(if raw > 0xFFFF {
                4
            } else if h.len() <= 2 {
                1
            } else {
                2
            });
        let hex = match width {
            1 => u8::try_from(raw).ok().map(Hex::Byte),
            2 => u16::try_from(raw).ok().map(Hex::Word),
            _ => Some(Hex::Dword(raw)),
        };
        return hex
            .map(Value::Hex)
            .ok_or_else(|| fail!("value={v}: does not fit {width} byte(s) of VH"));
    }
    if let Some(plain) = without_exponent(v) {
        return Value::parse(plain.as_bytes()).map_err(|e| {
            fail!(
                "value={v} (= {plain}): {e}; VD has at most 6 integer digits and 4 decimals (8.E)"
            )
        });
    }
    Value::parse(v.as_bytes()).map_err(|e| {
        fail!("value={v}: {e}; valid: 95.2 (VD), H0900 or 0x0900 (VH), Stext (VS), O0102 (VO)")
    })
}

fn lecom_telegram(
    req: &Request<'_>,
    registry: &Registry,
    schema: Option<Arc<Schema>>,
) -> Result<Telegram, EncodeError> {
    if req.family.is_some() {
        bail!("--family applies to --protocol lustbus only");
    }
    let d = parse_desc(req.description, &["receive", "send", "broadcast"])?;
    if d.verb == "receive" {
        d.check(&["address", "code"], &["address", "code"])?;
    } else {
        d.check(&["address", "code", "value"], &["address", "code", "value"])?;
    }
    let a = d.get("address").unwrap_or("");
    let address = (a.len() <= 2)
        .then(|| a.parse::<u8>().ok().and_then(ControllerAddress::new))
        .flatten()
        .ok_or_else(|| {
            fail!("address={a}: LECOM addresses are 00..99 (00 and x0 broadcast / multicast)")
        })?;
    let code = lecom_code(d.get("code").unwrap_or(""))?;
    let schema = schema.or_else(|| registry.get("lenze-tmd"));
    let t = match d.verb.as_str() {
        "receive" => lecom::Telegram::Receive(
            lecom::Receive::new(address, code).map_err(|e| fail!("address={a}: {e}"))?,
        ),
        verb => {
            let value = lecom_value(d.get("value").unwrap_or(""), code, schema.as_deref())?;
            if verb == "send" {
                lecom::Telegram::Send(
                    lecom::Send::new(address, code, value)
                        .map_err(|e| fail!("address={a}: {e}"))?,
                )
            } else {
                lecom::Telegram::Broadcast(
                    lecom::Broadcast::new(address, code, value)
                        .map_err(|e| fail!("address={a}: {e}"))?,
                )
            }
        }
    };
    let bytes = t.to_bytes().map_err(|e| fail!("address={a}: {e}"))?;
    Ok(Telegram::Serial(bytes))
}

fn sdo(
    req: &Request<'_>,
    _registry: &Registry,
    schema: Option<Arc<Schema>>,
) -> Result<Telegram, EncodeError> {
    if req.family.is_some() {
        bail!("--family applies to --protocol lustbus only");
    }
    let text = req.description.trim_start();
    let text = text
        .strip_prefix("sdo ")
        .or_else(|| text.strip_prefix("SDO "))
        .unwrap_or(text);
    let d = parse_desc(text, &["read", "write"])?;
    if d.verb == "read" {
        d.check(&["node", "code", "subindex"], &["node", "code"])?;
    } else {
        d.check(
            &["node", "code", "subindex", "value"],
            &["node", "code", "value"],
        )?;
    }
    let nv = d.get("node").unwrap_or("");
    let node = parse_int("node", nv, "CAN node ids are 1..127")
        .ok()
        .and_then(|n| u8::try_from(n).ok())
        .and_then(|n| NodeId::new(n).ok())
        .ok_or_else(|| fail!("node={nv}: CAN node ids are 1..127"))?;
    let cv = d.get("code").unwrap_or("");
    let digits = cv.strip_prefix(['C', 'c']).unwrap_or(cv);
    let code = digits
        .parse::<u32>()
        .ok()
        .and_then(|n| CanCode::new(n).ok())
        .ok_or_else(|| fail!("code={cv}: Lenze codes are 0..24575 (C0011 or 11)"))?;
    let sub = match d.get("subindex") {
        Some(s) => Subindex(
            s.parse()
                .map_err(|_| fail!("subindex={s}: subindices are 0..255"))?,
        ),
        None => Subindex(0),
    };
    let req = if d.verb == "read" {
        SdoRequest::read_code(code, sub)
    } else {
        let v = d.get("value").unwrap_or("");
        let format = match schema
            .as_ref()
            .and_then(|s| s.code(u32::from(code.get())).and_then(|c| s.type_of(c)))
        {
            Some(driveset_schema::ValueType::BITCODED) => ValueFormat::BitCoded,
            Some(driveset_schema::ValueType::FIX32) => ValueFormat::Fix32,
            _ => code.value_format(),
        };
        let value = if let Some(h) = v.strip_prefix("0x").or_else(|| v.strip_prefix("0X")) {
            let raw = u32::from_str_radix(h, 16)
                .map_err(|_| fail!("value={v}: not a 32-bit hex number"))?;
            match format {
                ValueFormat::BitCoded => LenzeValue::BitCoded(raw),
                ValueFormat::Fix32 => LenzeValue::Fix32(Fix32(raw as i32)),
            }
        } else {
            if format == ValueFormat::BitCoded {
                bail!("value={v}: {code} is bit-coded; give it in hex (value=0x0001)");
            }
            let plain = without_exponent(v);
            LenzeValue::Fix32(Fix32::from_decimal_str(plain.as_deref().unwrap_or(v)).map_err(|e| {
                fail!("value={v}: {e}; FIX32 takes a decimal with up to 4 decimals, -214748.3648..214748.3647, or raw hex 0x...")
            })?)
        };
        SdoRequest::write_code(code, sub, value)
    };
    let data = req.encode();
    let frame = CanFrame::new(node.request_cob_id(), &data).map_err(|e| fail!("{e}"))?;
    let line = SlcanCommand::Transmit(frame)
        .to_bytes()
        .map_err(|e| fail!("{e}"))?;
    Ok(Telegram::Sdo {
        frame,
        data: data.to_vec(),
        line,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn req(protocol: BusProtocol, description: &str) -> Request<'_> {
        Request {
            protocol,
            family: None,
            description,
        }
    }

    /// A LUSTBUS enquiry and an SDO write, as bytes and as the frame and
    /// its slcan line.
    #[test]
    fn descriptions_become_telegrams() {
        let reg = Registry::builtin().unwrap();
        let t = encode(
            &req(BusProtocol::Lustbus, "enquiry address=0 code=00112"),
            &reg,
            None,
        )
        .unwrap();
        assert_eq!(t, Telegram::Serial(b"\x04@00112\x05".to_vec()));
        assert_eq!(t.raw(), b"\x04@00112\x05");
        assert_eq!(
            t.text(),
            "hex:   04 40 30 30 31 31 32 05\nascii: <EOT>@00112<ENQ>\n"
        );
        let t = encode(
            &req(BusProtocol::CanSdo, "sdo write node=1 code=11 value=50.0"),
            &reg,
            None,
        )
        .unwrap();
        assert_eq!(t.raw(), b"t601823F45F0020A10700\r");
        assert_eq!(
            t.text(),
            "cob-id: 0x601\ndata:   23 F4 5F 00 20 A1 07 00\nslcan:  t601823F45F0020A10700<CR>\n"
        );
        let Telegram::Sdo { frame, data, line } = t else {
            panic!("{t:?}")
        };
        assert_eq!(frame.id, 0x601);
        assert_eq!(data, [0x23, 0xF4, 0x5F, 0x00, 0x20, 0xA1, 0x07, 0x00]);
        assert_eq!(line, b"t601823F45F0020A10700\r");
    }

    /// Errors name what is wrong and what is valid.
    #[test]
    fn errors_say_what_is_valid() {
        let reg = Registry::builtin().unwrap();
        let e = encode(&req(BusProtocol::Lustbus, "selekt address=1"), &reg, None).unwrap_err();
        assert_eq!(
            e.to_string(),
            "unknown telegram kind `selekt`; valid: enquiry, select, reply, ack, nak, eot"
        );
        let mut r = req(BusProtocol::Lecom, "receive address=1 code=11");
        r.family = Some(Dialect::Mc);
        let e = encode(&r, &reg, None).unwrap_err();
        assert_eq!(e.0, "--family applies to --protocol lustbus only");
    }
}
