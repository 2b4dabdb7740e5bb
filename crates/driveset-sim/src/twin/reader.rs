//! Reads a twin file's TOML table into a [`Twin`](super::Twin): every key
//! checked, errors naming the file and the key (docs/twins.md).

use super::*;

pub(super) struct Reader<'a> {
    pub(super) path: &'a Path,
    pub(super) table: &'a toml::Table,
}

impl Reader<'_> {
    pub(super) fn bad(&self, key: &str, reason: impl Into<String>) -> TwinError {
        TwinError::Field {
            path: self.path.to_path_buf(),
            key: key.to_string(),
            reason: reason.into(),
        }
    }

    pub(super) fn string(&self, key: &str) -> Result<String, TwinError> {
        match self.table.get(key) {
            Some(toml::Value::String(s)) => Ok(s.clone()),
            Some(_) => Err(self.bad(key, "must be a string")),
            None => Err(self.bad(key, "missing")),
        }
    }

    pub(super) fn section(&self, name: &str) -> Result<Option<&toml::Table>, TwinError> {
        match self.table.get(name) {
            Some(toml::Value::Table(t)) => Ok(Some(t)),
            Some(_) => Err(self.bad(&format!("[{name}]"), "must be a table")),
            None => Ok(None),
        }
    }

    pub(super) fn int_in(
        &self,
        t: Option<&toml::Table>,
        sec: &str,
        key: &str,
    ) -> Result<Option<i64>, TwinError> {
        match t.and_then(|t| t.get(key)) {
            Some(toml::Value::Integer(i)) => Ok(Some(*i)),
            Some(_) => Err(self.bad(&format!("[{sec}] {key}"), "must be a whole number")),
            None => Ok(None),
        }
    }

    pub(super) fn str_in(
        &self,
        t: Option<&toml::Table>,
        sec: &str,
        key: &str,
    ) -> Result<Option<String>, TwinError> {
        match t.and_then(|t| t.get(key)) {
            Some(toml::Value::String(s)) => Ok(Some(s.clone())),
            Some(_) => Err(self.bad(&format!("[{sec}] {key}"), "must be a string")),
            None => Ok(None),
        }
    }

    pub(super) fn key(&self, sec: &str, k: &str) -> Result<CodeKey, TwinError> {
        parse_key(k).ok_or_else(|| {
            self.bad(
                &format!("[{sec}] \"{k}\""),
                "not a code: write the code number, or NUMBER.SUBCODE",
            )
        })
    }

    pub(super) fn keys(
        &self,
        t: Option<&toml::Table>,
        key: &str,
    ) -> Result<Vec<CodeKey>, TwinError> {
        let Some(v) = t.and_then(|t| t.get(key)) else {
            return Ok(Vec::new());
        };
        let toml::Value::Array(items) = v else {
            return Err(self.bad(&format!("[codes] {key}"), "must be a list of codes"));
        };
        items
            .iter()
            .map(|i| match i {
                toml::Value::String(s) => self.key("codes", s),
                _ => Err(self.bad(&format!("[codes] {key}"), "must be a list of code strings")),
            })
            .collect()
    }

    /// The characters a drive sent, as a twin file holds them.
    fn wire(&self, at: &str, v: &toml::Value) -> Result<Vec<u8>, TwinError> {
        match v {
            toml::Value::String(s) => wire_bytes(s)
                .ok_or_else(|| self.bad(at, "holds a character a drive cannot send (not 7-bit)")),
            _ => Err(self.bad(at, "must be a string (the characters the drive sent)")),
        }
    }

    pub(super) fn twin(&self) -> Result<Twin, TwinError> {
        let format = self.string("format")?;
        let first = format == TWIN_FORMAT_1;
        if format != TWIN_FORMAT && !first {
            return Err(self.bad(
                "format",
                format!("`{format}` is not `{TWIN_FORMAT}`; capture the drive again"),
            ));
        }
        let family_name = self.string("family")?;
        let family = Family::parse(&family_name).map_err(|e| self.bad("family", e))?;
        if first && family.bus() == driveset_schema::BusProtocol::Lustbus {
            return Err(self.bad(
                "format",
                format!(
                    "a `{TWIN_FORMAT_1}` twin of a {} holds neither the drive's parameter descriptions nor its substitution texts, so it cannot answer as the drive did; capture the drive again with `driveset twin capture` (docs/twins.md)",
                    family.name()
                ),
            ));
        }
        let address = match self.table.get("address") {
            Some(toml::Value::Integer(a)) => u8::try_from(*a)
                .map_err(|_| self.bad("address", format!("{a} is not a bus address")))?,
            Some(_) => return Err(self.bad("address", "must be a whole number")),
            None => return Err(self.bad("address", "missing")),
        };
        crate::open::check_address(family, address)
            .map_err(|e| self.bad("address", e.to_string()))?;
        let mut twin = Twin::new(family, address, &self.string("schema")?);
        twin.path = self.path.to_path_buf();
        twin.driveset = self.string("driveset")?;
        twin.captured = self.string("captured")?;
        twin.source = self.string("source").unwrap_or_default();
        if let Some(t) = self.section("identity")? {
            for (k, v) in t {
                match v {
                    toml::Value::String(s) => twin.identity.push((k.clone(), s.clone())),
                    _ => return Err(self.bad(&format!("[identity] {k}"), "must be a string")),
                }
            }
        }
        let state = self.section("state")?;
        twin.running = match state.and_then(|t| t.get("running")) {
            Some(toml::Value::Boolean(b)) => Some(*b),
            Some(_) => return Err(self.bad("[state] running", "must be true or false")),
            None => None,
        };
        twin.c0001 =
            match self.int_in(state, "state", "c0001")? {
                Some(c) => Some(u8::try_from(c).ok().filter(|c| *c <= 11).ok_or_else(|| {
                    self.bad("[state] c0001", "C0001 takes 0..=11 (Table 1; §4e)")
                })?),
                None => None,
            };
        twin.sload = self.int_in(state, "state", "sload")?;
        twin.layout =
            match self.str_in(state, "state", "layout")? {
                Some(l) => Some(McLayout::from_name(&l).ok_or_else(|| {
                    self.bad("[state] layout", "use 52, 43, 42 or 34 (errata L22)")
                })?),
                None => None,
            };
        twin.types = match self.str_in(state, "state", "types")? {
            Some(t) => Some(McTypeChars::parse(&t).map_err(|e| self.bad("[state] types", e))?),
            None => None,
        };
        let timing = self.section("timing")?;
        twin.rate = match self.int_in(timing, "timing", "rate")? {
            Some(r) => Some(
                u32::try_from(r)
                    .ok()
                    .filter(|r| *r > 0)
                    .ok_or_else(|| self.bad("[timing] rate", "not a line rate"))?,
            ),
            None => None,
        };
        let us = |key: &str| -> Result<Option<Duration>, TwinError> {
            match self.int_in(timing, "timing", key)? {
                Some(v) => u64::try_from(v)
                    .map(|v| Some(Duration::from_micros(v)))
                    .map_err(|_| self.bad(&format!("[timing] {key}"), "must not be negative")),
                None => Ok(None),
            }
        };
        twin.reaction = match (us("reaction_min_us")?, us("reaction_max_us")?) {
            (Some(lo), Some(hi)) if lo <= hi => Some((lo, hi)),
            (Some(_), Some(_)) => {
                return Err(self.bad("[timing] reaction_min_us", "is above reaction_max_us"));
            }
            (None, None) => None,
            _ => {
                return Err(self.bad(
                    "[timing]",
                    "give both reaction_min_us and reaction_max_us, or neither",
                ));
            }
        };
        if let Some(t) = self.section("values")? {
            for (k, v) in t {
                let key = self.key("values", k)?;
                let raw = match v {
                    toml::Value::Integer(i) => RawValue::Int(*i),
                    toml::Value::String(s) => RawValue::Text(s.clone()),
                    toml::Value::Table(h) => match h.get("hex") {
                        Some(toml::Value::String(x)) => {
                            RawValue::Octets(unhex(x).ok_or_else(|| {
                                self.bad(&format!("[values] \"{k}\" hex"), "not hex digits")
                            })?)
                        }
                        _ => {
                            return Err(self.bad(
                                &format!("[values] \"{k}\""),
                                "a table value must be { hex = \"...\" }",
                            ));
                        }
                    },
                    _ => {
                        return Err(self.bad(
                            &format!("[values] \"{k}\""),
                            "must be a whole number, a string or { hex = \"...\" }",
                        ));
                    }
                };
                twin.values.insert(key, raw);
            }
        }
        if let Some(t) = self.section("refused")? {
            for (k, v) in t {
                let key = self.key("refused", k)?;
                let at = format!("[refused] \"{k}\"");
                let (why, answer) = match v {
                    // A file of the first version: the answer as the
                    // reason's raw part names it.
                    toml::Value::String(s) => (s.clone(), answer_in_reason(s)),
                    toml::Value::Table(t) => {
                        let why = match t.get("reason") {
                            Some(toml::Value::String(s)) => s.clone(),
                            _ => return Err(self.bad(&at, "reason must be a string")),
                        };
                        let answer = match t.get("answer") {
                            Some(toml::Value::String(a)) => Some(ReadRefusal::parse(a).ok_or_else(|| {
                                self.bad(&at, format!("answer `{a}`: use NAK, NAK SIOF 80H, EOT or SDO abort 0x06010001"))
                            })?),
                            None => None,
                            Some(_) => return Err(self.bad(&at, "answer must be a string")),
                        };
                        (why, answer)
                    }
                    _ => {
                        return Err(self.bad(
                            &at,
                            "must be a string or { answer = \"...\", reason = \"...\" }",
                        ));
                    }
                };
                twin.refused.insert(key, why);
                if let Some(a) = answer {
                    twin.refusals.insert(key, a);
                }
            }
        }
        let codes = self.section("codes")?;
        twin.secrets = self.keys(codes, "secrets")?;
        twin.unknown = self.keys(codes, "unknown")?;
        twin.unread = self.keys(codes, "unread")?;
        if first {
            // the first version listed the codes not read on purpose (and
            // those without a type) as unknown, and served them
            twin.unread = std::mem::take(&mut twin.unknown);
        }
        if let Some(t) = self.section("descriptions")? {
            let mut out = BTreeMap::new();
            for (k, v) in t {
                let at = format!("[descriptions] \"{k}\"");
                let n: u32 = k
                    .parse()
                    .map_err(|_| self.bad(&at, "not a parameter number"))?;
                out.insert(n, self.wire(&at, v)?);
            }
            twin.descriptions = Some(out);
        }
        if let Some(t) = self.section("texts")? {
            for (k, v) in t {
                let at = format!("[texts] \"{k}\"");
                let key = k
                    .split_once('.')
                    .and_then(|(n, i)| Some((n.parse::<u32>().ok()?, i.parse::<u8>().ok()?)))
                    .ok_or_else(|| {
                        self.bad(&at, "not PARAMETER.INDEX (the 108-STEXT index 0..=255)")
                    })?;
                twin.texts.insert(key, self.wire(&at, v)?);
            }
        }
        Ok(twin)
    }
}
