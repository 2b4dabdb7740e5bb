//! One annotated stretch of a capture (a telegram, a reply, skipped garbage,
//! an slcan line) and its text and JSON renderings, which carry the same
//! fields.

use serde::Serialize;

/// Who sent the bytes.
pub const HOST_TO_DRIVE: &str = "host -> drive";
/// Who sent the bytes.
pub const DRIVE_TO_HOST: &str = "drive -> host";

/// The BCC check of a telegram that has one.
#[derive(Debug, Clone, Serialize)]
pub struct Bcc {
    /// Whether it matches.
    pub ok: bool,
    /// The byte received.
    pub found: String,
    /// The byte computed over the telegram text.
    pub expected: String,
}

impl Bcc {
    /// A BCC that did not match: `found` received, `expected` computed.
    pub fn mismatch(found: u8, expected: u8) -> Bcc {
        Bcc {
            ok: false,
            found: format!("0x{found:02X}"),
            expected: format!("0x{expected:02X}"),
        }
    }

    /// The check of a telegram as received, its BCC the last byte
    /// (proto's [`driveset_proto::ascii::telegram_bcc`], LUSTBUS §2.2,
    /// LECOM §8.G); `None` for no bytes.
    pub fn of_telegram(bytes: &[u8]) -> Option<Bcc> {
        let c = driveset_proto::ascii::telegram_bcc(bytes)?;
        Some(Bcc {
            ok: c.ok(),
            found: format!("0x{:02X}", c.found),
            expected: format!("0x{:02X}", c.computed),
        })
    }
}

/// One event of the decoded stream.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Event {
    /// First byte (offset in the capture).
    pub start: u64,
    /// One past the last byte.
    pub end: u64,
    /// `host -> drive`, `drive -> host`, `host -> adapter`, ...; none for garbage.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub direction: Option<&'static str>,
    /// `ENQUIRY`, `SELECT`, `VALUE`, `ACK`, `NAK`, `EOT`, `GARBAGE`, `ERROR`, ...
    pub kind: &'static str,
    /// Device / controller address or CAN node.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub address: Option<String>,
    /// The code as on the wire (`00112`, `C0046`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub code: Option<String>,
    /// The code's name from the schema or the protocol.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// The value as on the wire.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub raw_value: Option<String>,
    /// The value in engineering units.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub value: Option<String>,
    /// BCC check.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bcc: Option<Bcc>,
    /// What it means (replies, special codes).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub meaning: Option<String>,
    /// Further lines (SIOF bits, C0068 fields, ...).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub details: Vec<String>,
    /// What is wrong with these bytes (makes the exit code 1).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// The bytes, hex (`<secret>` for a telegram carrying a secret).
    pub bytes: String,
    /// The telegram carries a secret's value (a password): its value, raw
    /// value, bytes and BCC bytes are never shown ([`Event::mask_secret`]).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub secret: bool,
}

/// The bytes `start..end` of `capture`, both clamped to the capture (an
/// end before the start is an empty stretch).
pub(super) fn slice(capture: &[u8], start: u64, end: u64) -> &[u8] {
    let s = usize::try_from(start)
        .unwrap_or(usize::MAX)
        .min(capture.len());
    let e = usize::try_from(end)
        .unwrap_or(usize::MAX)
        .min(capture.len())
        .max(s);
    &capture[s..e]
}

impl Event {
    /// An event over `start..end` of `capture`.
    pub fn new(capture: &[u8], start: u64, end: u64, kind: &'static str) -> Self {
        Event {
            start,
            end,
            kind,
            bytes: super::hex_spaced(slice(capture, start, end)),
            ..Event::default()
        }
    }

    /// An `ERROR` event over `start..end` of `capture`, sent in
    /// `direction` where known: what could not be decoded, and why.
    pub(super) fn error(
        capture: &[u8],
        start: u64,
        end: u64,
        direction: Option<&'static str>,
        why: String,
    ) -> Self {
        Event {
            direction,
            error: Some(why),
            ..Event::new(capture, start, end, "ERROR")
        }
    }

    /// Hide everything that could give a secret's value away: the value
    /// shows as `<secret>`, the raw value is dropped, the bytes are
    /// `<secret>`, the BCC says only whether it matched, and details about
    /// the value are dropped.
    pub fn mask_secret(&mut self) {
        let secret = driveset_schema::canonical::SECRET;
        self.secret = true;
        self.raw_value = None;
        self.value = Some(secret.to_string());
        self.bytes = secret.to_string();
        self.details.clear();
        if self.error.is_some() {
            self.error =
                Some("bad telegram (what is wrong is not shown: it carries a secret)".into());
        }
        if let Some(b) = &mut self.bcc {
            b.found = secret.to_string();
            b.expected = secret.to_string();
        }
    }

    /// The human line(s).
    pub fn render_text(&self) -> String {
        let mut parts: Vec<String> = Vec::new();
        if let Some(a) = &self.address {
            if a.starts_with("node ") {
                parts.push(a.clone());
            } else {
                parts.push(format!("address {a}"));
            }
        }
        if let Some(c) = &self.code {
            match &self.name {
                Some(n) => parts.push(format!("code {c} ({n})")),
                None => parts.push(format!("code {c}")),
            }
        }
        match (&self.raw_value, &self.value) {
            (Some(r), Some(v)) if v == r || v.starts_with(&format!("{r} ")) => {
                parts.push(format!("value {v}"));
            }
            (Some(r), Some(v)) => parts.push(format!("value {r} = {v}")),
            (Some(r), _) => parts.push(format!("value {r}")),
            (None, Some(v)) => parts.push(format!("value {v}")),
            (None, None) => {}
        }
        if let Some(b) = &self.bcc {
            if self.secret {
                parts.push(if b.ok { "BCC ok" } else { "BCC bad" }.to_string());
            } else if b.ok {
                parts.push(format!("BCC {} ok", b.found));
            } else {
                parts.push(format!(
                    "BCC bad: expected {}, found {}",
                    b.expected, b.found
                ));
            }
        }
        let mut rest = parts.join(", ");
        for extra in [&self.meaning, &self.error].into_iter().flatten() {
            if rest.is_empty() {
                rest.clone_from(extra);
            } else {
                rest = format!("{rest}: {extra}");
            }
        }
        // names and values come from the capture and the schema files:
        // no control character reaches the terminal raw
        let rest = driveset_schema::error::escape_controls(&rest);
        let range = format!("{}..{}", self.start, self.end);
        let mut line = format!(
            "{range:<11} {:<15} {:<9} {rest}",
            self.direction.unwrap_or("-"),
            self.kind
        );
        while line.ends_with(' ') {
            line.pop();
        }
        for d in &self.details {
            line.push_str("\n            ");
            line.push_str(&driveset_schema::error::escape_controls(d));
        }
        line
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_slice_is_clamped_to_the_capture() {
        let capture = [1u8, 2, 3, 4];
        assert_eq!(slice(&capture, 1, 3), [2, 3]);
        assert_eq!(slice(&capture, 2, 99), [3, 4]);
        assert_eq!(slice(&capture, 3, 1), [0u8; 0]);
        assert_eq!(slice(&capture, u64::MAX, u64::MAX), [0u8; 0]);
    }

    #[test]
    fn an_error_event_keeps_its_bytes_direction_and_why() {
        let e = Event::error(&[0x04, 0x30], 0, 2, Some(HOST_TO_DRIVE), "bad".into());
        let n = Event::new(&[0x04, 0x30], 0, 2, "ERROR");
        assert_eq!(e.kind, "ERROR");
        assert_eq!(e.bytes, n.bytes);
        assert_eq!((e.start, e.end), (0, 2));
        assert_eq!(e.direction, Some(HOST_TO_DRIVE));
        assert_eq!(e.error.as_deref(), Some("bad"));
    }
}
