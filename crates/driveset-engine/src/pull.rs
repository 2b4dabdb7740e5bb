//! `driveset pull`: read a drive's parameters into a [`ResolvedSet`].
//!
//! Every code of the schema is read (each subcode of codes that have
//! subcodes), except:
//! - codes whose reading clears them (85-SIOF/SERR): reading would unlatch
//!   the drive's error state;
//! - password codes, unless [`PullOptions::include_passwords`];
//! - codes of role `command` or `control-word` (`driveset_schema::role`):
//!   a set cannot hold them (it would run a command or could start a motor
//!   when uploaded back), so a pulled set leaves them out;
//! - codes of role `bus-address` or `baud-rate` (LUSTBUS 82-SIOA/SADDR and
//!   81-SIOC/SBAUD, Tmd C0009 and C0125), unless
//!   [`PullOptions::keep_bus_codes`]: the line manifest owns the drive's
//!   address and the bus's rate, and a set copied for another drive must not
//!   carry this drive's (docs/file-formats.md, "The manifest's address is
//!   the truth");
//! - codes whose type the schema does not know (the value could not be
//!   converted or written back);
//! - codes the drive refuses to read (says they do not exist, or read
//!   protected), does not answer for, or answers with a VALUE the schema's
//!   type cannot hold: skipped, reported with the cause and marked
//!   [`Skipped::failed`]; the pull carries on with the next code.
//!
//! Only a failure of the transport itself (the port is gone) or a drive
//! restart ends the pull with the error.
//!
//! A pull for a set file ([`Pulled::for_file`], [`ForFile`]): the
//! read-only actual values taken out of the set for the header, the bus
//! codes left out and the codes that failed named, the file's text
//! assembled by the schema crate's `export::pulled` (docs/file-formats.md).

use std::time::Duration;

use driveset_schema::export::pulled as pulled_file;
use driveset_schema::{Code, CodeKey, Format, ResolvedSet, Role, Schema};

use crate::client::{DriveClient, Identity};
use crate::error::{DeviceFailure, EngineError, ErrorKind, LinkFailure};
use crate::observe::{Hook, Phase};
use crate::plan::code_label;

/// Options of [`pull`].
#[derive(Debug, Clone, Copy, Default)]
pub struct PullOptions {
    /// Drop values equal to the schema's factory default.
    pub changed_only: bool,
    /// Read password codes too (the file will hold them).
    pub include_passwords: bool,
    /// Read the bus address and line rate codes too (roles `bus-address`,
    /// `baud-rate`); left out by default.
    pub keep_bus_codes: bool,
}

/// Why `pull` leaves `code` out on purpose, if it does (the module docs'
/// list, but for codes the drive refuses): the one rule [`pull`] and
/// [`crate::transfer::pull_exchanges`] share.
pub fn left_out_reason(schema: &Schema, code: &Code, opts: &PullOptions) -> Option<String> {
    if code.read_clears == Some(true) {
        return Some("reading clears it (status code)".into());
    }
    if schema.is_password(code) && !opts.include_passwords {
        return Some("password (never read: its value stays on the drive)".into());
    }
    if let Some(role) = code.role() {
        if role != Role::Password && role.left_out_of_pulled_sets() {
            return Some(format!("role `{role}`: left out, a set cannot hold it"));
        }
        if role.is_bus_link() && !opts.keep_bus_codes {
            return Some(format!(
                "role `{role}`: left out, the line manifest gives the drive's address and the bus's rate"
            ));
        }
    }
    if schema.type_of(code).is_none() {
        return Some("the schema gives no type for it".into());
    }
    if driveset_schema::schema::ram_note(schema, code, driveset_schema::CodeKey::new(code.number))
        .is_some()
    {
        return Some("RAM control value: lost at power off, a set cannot hold it".into());
    }
    None
}

/// A code that was not read, and why.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct Skipped {
    /// Code number.
    pub number: u32,
    /// Subcode.
    pub subcode: Option<u32>,
    /// Code as humans spell it.
    pub code: String,
    /// Why.
    pub reason: String,
    /// The code could not be read (refused, no answer, a VALUE that does
    /// not decode), as opposed to left out on purpose.
    pub failed: bool,
}

/// A pulled set.
#[derive(Debug, Clone)]
pub struct Pulled {
    /// The values (without the defaults when `changed_only`).
    pub set: ResolvedSet,
    /// What the drive said it is (for the file header).
    pub identity: Identity,
    /// Fingerprint of [`Pulled::set`].
    pub fingerprint: String,
    /// Fingerprint of every value read (before `changed_only`).
    pub full_fingerprint: String,
    /// Codes read.
    pub read: usize,
    /// Values dropped as equal to the factory default.
    pub dropped_defaults: usize,
    /// Codes not read.
    pub skipped: Vec<Skipped>,
    /// Time taken on the client's clock.
    pub elapsed: Duration,
}

impl Pulled {
    /// The bus address / line rate codes left out (role `bus-address` /
    /// `baud-rate`: the line manifest owns them), as humans spell them.
    pub fn left_out_bus_codes(&self, schema: &Schema) -> Vec<String> {
        self.skipped
            .iter()
            .filter(|s| !s.failed && schema.role_of(s.number).is_some_and(Role::is_bus_link))
            .map(|s| s.code.clone())
            .collect()
    }

    /// Made ready for a set file: the read-only codes (actual values) are
    /// read but cannot be part of a set (`validate` refuses them), so they
    /// leave it for the header and the fingerprint is the rest's; the bus
    /// codes left out and the codes that could not be read named.
    pub fn for_file(mut self, schema: &Schema) -> ForFile {
        let read = crate::history::values_read(schema, &self.set);
        let actual = pulled_file::take_actual_values(&mut self.set, schema);
        self.fingerprint = self.set.fingerprint();
        let bus_codes = self.left_out_bus_codes(schema);
        let failed = self.skipped.iter().filter(|s| s.failed).cloned().collect();
        ForFile {
            pulled: self,
            actual,
            bus_codes,
            failed,
            read,
        }
    }
}

/// A pull made ready for its set file ([`Pulled::for_file`]).
#[derive(Debug, Clone)]
pub struct ForFile {
    /// The pull, the actual values out of its set.
    pub pulled: Pulled,
    /// The read-only actual values taken out, `CODE = value`.
    pub actual: Vec<String>,
    /// The bus address / line rate codes left out.
    pub bus_codes: Vec<String>,
    /// The codes that could not be read.
    pub failed: Vec<Skipped>,
    /// Every value read, actual values included, as the plant history
    /// records them ([`crate::history::values_read`];
    /// [`crate::history::DriveRecord::of_pull`]).
    pub read: Vec<crate::history::CodeRecord>,
}

/// Where a set file says it was pulled from and what it refers to.
#[derive(Debug, Clone, Copy)]
pub struct SetFileFrom<'a> {
    /// The port, as the pull opened it.
    pub port: &'a str,
    /// The drive's address.
    pub address: u8,
    /// The schema reference: a file named by path (relative to the set
    /// file), or the schema's id.
    pub schema_ref: &'a str,
    /// Whether the values equal to the factory default were left out.
    pub changed_only: bool,
}

impl ForFile {
    /// The codes not read, but for the bus codes left out on purpose
    /// ([`ForFile::bus_codes`]), as the report names them.
    pub fn not_read(&self) -> Vec<&str> {
        self.pulled
            .skipped
            .iter()
            .map(|s| s.code.as_str())
            .filter(|c| !self.bus_codes.iter().any(|b| b == c))
            .collect()
    }

    /// The set file's text in `format` (driveset-schema's
    /// [`pulled_file::pulled_file`]).
    pub fn text(&self, schema: &Schema, from: &SetFileFrom<'_>, format: Format) -> String {
        let pulled = &self.pulled;
        let identity = pulled.identity.pairs();
        let not_read: Vec<(&str, &str)> = pulled
            .skipped
            .iter()
            .map(|s| (s.code.as_str(), s.reason.as_str()))
            .collect();
        let file = pulled_file::Pulled {
            from: pulled_file::PulledFrom {
                port: from.port,
                address: from.address,
                protocol: pulled.identity.protocol.name(),
                identity: &identity,
                software: pulled.identity.software.as_deref(),
            },
            schema_ref: from.schema_ref,
            fingerprint: &pulled.fingerprint,
            changed_only: from
                .changed_only
                .then_some((pulled.dropped_defaults, pulled.full_fingerprint.as_str())),
            actual: &self.actual,
            not_read: &not_read,
        };
        pulled_file::pulled_file(&pulled.set, schema, &file, format)
    }
}

/// Read every readable code of the client's schema.
pub fn pull(client: &mut dyn DriveClient, opts: &PullOptions) -> Result<Pulled, EngineError> {
    pull_observed(client, opts, &Hook::none())
}

/// [`pull`], telling `hook` its phases (identify, read) and each code read
/// or passed over, of every code and subcode of the schema
/// ([`crate::observe`]).
pub fn pull_observed(
    client: &mut dyn DriveClient,
    opts: &PullOptions,
    hook: &Hook,
) -> Result<Pulled, EngineError> {
    let start = client.clock().now();
    let schema = client.schema().clone();
    hook.enter(client.clock(), Phase::Identify, None);
    let identity = client.identify()?;
    let total: usize = schema
        .codes
        .iter()
        .map(|c| c.subcodes.filter(|n| *n > 0).unwrap_or(1) as usize)
        .sum();
    hook.enter(client.clock(), Phase::Read, Some(total));
    let mut done = 0;
    let mut all = ResolvedSet::new(&schema);
    let mut skipped = Vec::new();
    for code in &schema.codes {
        let keys: Vec<CodeKey> = match code.subcodes {
            Some(n) if n > 0 => (1..=n).map(|s| CodeKey::sub(code.number, s)).collect(),
            _ => vec![CodeKey::new(code.number)],
        };
        for key in keys {
            done += 1;
            hook.step(client.clock(), Phase::Read, done, total);
            let skip = |reason: &str| Skipped {
                number: key.number,
                subcode: key.subcode,
                code: code_label(&schema, key),
                reason: reason.into(),
                failed: false,
            };
            let fail = |reason: String| Skipped {
                failed: true,
                ..skip(&reason)
            };
            if let Some(reason) = left_out_reason(&schema, code, opts) {
                skipped.push(skip(&reason));
                continue;
            }
            match client.read(key) {
                Ok(v) => all.insert(key, v),
                Err(e) => match &*e.kind {
                    ErrorKind::Device(DeviceFailure::Refused { cause, .. }) => {
                        skipped.push(fail(format!(
                            "the drive refused to read it: {} ({})",
                            cause.cause(),
                            cause.raw()
                        )))
                    }
                    ErrorKind::Link(LinkFailure::Protocol { detail, .. }) => {
                        skipped.push(fail(format!(
                            "its VALUE does not fit the schema's type {}: {detail}",
                            schema.type_of(code).map_or("(none)", |t| t.name())
                        )))
                    }
                    ErrorKind::Link(LinkFailure::NoAnswer { tries, .. }) => {
                        skipped.push(fail(format!("the drive did not answer ({tries} tries)")))
                    }
                    _ => return Err(e),
                },
            }
        }
    }
    let full_fingerprint = all.fingerprint();
    let read = all.values.len();
    let mut set = all;
    let mut dropped_defaults = 0;
    if opts.changed_only {
        let before = set.values.len();
        set.values.retain(|k, v| {
            let default = schema
                .code(k.number)
                .and_then(|c| c.default.as_ref().map(|d| schema.fact_raw(c, d)));
            !matches!(default, Some(Ok(d)) if &d == v)
        });
        dropped_defaults = before - set.values.len();
    }
    hook.end(client.clock());
    Ok(Pulled {
        fingerprint: set.fingerprint(),
        set,
        identity,
        full_fingerprint,
        read,
        dropped_defaults,
        skipped,
        elapsed: client.clock().now() - start,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pull made ready for its file: the read-only C0099 leaves the set
    /// for the header and the fingerprint is the rest's; the bus codes left
    /// out on purpose and the codes that failed are told apart; the text
    /// names the drive, the schema reference and the codes not read.
    #[test]
    fn a_pull_for_its_file_takes_the_actual_values_out_and_names_what_was_not_read() {
        let registry = driveset_schema::Registry::builtin().expect("built-in schemas");
        let schema = registry.get("lenze-tmd").expect("lenze-tmd");
        let code = schema.code(11).expect("C0011");
        let c0011 = schema
            .fact_raw(code, code.default.as_ref().expect("a default"))
            .expect("C0011 holds its default");
        let mut set = ResolvedSet::new(&schema);
        set.insert(CodeKey::new(11), c0011);
        set.insert(
            CodeKey::new(99),
            driveset_schema::RawValue::Text("1.20".into()),
        );
        let skipped = |number: u32, failed: bool| Skipped {
            number,
            subcode: None,
            code: format!("C{number:04}"),
            reason: if failed { "no answer" } else { "left out" }.into(),
            failed,
        };
        let pulled = Pulled {
            fingerprint: set.fingerprint(),
            full_fingerprint: set.fingerprint(),
            set,
            identity: Identity::of(crate::client::IdentProtocol::Family(schema.family)),
            read: 2,
            dropped_defaults: 0,
            skipped: vec![skipped(9, false), skipped(17, true)],
            elapsed: Duration::ZERO,
        };
        let file = pulled.for_file(&schema);
        assert_eq!(file.actual.len(), 1, "{:?}", file.actual);
        assert!(file.actual[0].starts_with("C0099 = "), "{:?}", file.actual);
        assert_eq!(file.pulled.set.values.len(), 1);
        assert_eq!(file.pulled.fingerprint, file.pulled.set.fingerprint());
        assert_eq!(file.bus_codes, ["C0009"]);
        assert_eq!(file.failed, [skipped(17, true)]);
        let from = SetFileFrom {
            port: "/dev/ttyUSB0",
            address: 3,
            schema_ref: "../schemas/tmd.toml",
            changed_only: false,
        };
        let text = file.text(&schema, &from, Format::Toml);
        assert!(
            text.starts_with("# Pulled by driveset from /dev/ttyUSB0 address 3.\n"),
            "{text}"
        );
        assert!(text.contains("../schemas/tmd.toml"), "{text}");
        assert!(text.contains("C0017"), "{text}");
        assert!(text.contains("C0099 = "), "{text}");
    }

    /// The Tmd's C0009 / C0125 (floor roles bus-address / baud-rate) are
    /// left out unless kept; C0011 (an ordinary setting) never is.
    #[test]
    fn bus_codes_are_left_out_unless_kept() {
        let registry = driveset_schema::Registry::builtin().expect("built-in schemas");
        let schema = registry.get("lenze-tmd").expect("lenze-tmd");
        let code = |n| schema.code(n).expect("code in lenze-tmd");
        let plain = PullOptions::default();
        assert_eq!(
            left_out_reason(&schema, code(9), &plain).as_deref(),
            Some(
                "role `bus-address`: left out, the line manifest gives the drive's address and the bus's rate"
            )
        );
        assert_eq!(
            left_out_reason(&schema, code(125), &plain).as_deref(),
            Some(
                "role `baud-rate`: left out, the line manifest gives the drive's address and the bus's rate"
            )
        );
        assert_eq!(left_out_reason(&schema, code(11), &plain), None);
        let kept = PullOptions {
            keep_bus_codes: true,
            ..plain
        };
        assert_eq!(left_out_reason(&schema, code(9), &kept), None);
        assert_eq!(left_out_reason(&schema, code(125), &kept), None);
    }
}
