//! A manifest's findings: [`ManifestFinding`], its rendering and its
//! mapping onto the schema crate's closed set of finding kinds.

use std::fmt;

use driveset_schema::{Finding, FindingKind, Location};

/// One finding in a manifest (or in a set it names).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ManifestFinding {
    /// Kebab-case kind (`duplicate-address`, ...; a set's findings keep their kind).
    pub kind: String,
    /// What is wrong.
    pub message: String,
    /// What to do.
    pub help: String,
    /// Where.
    pub location: Location,
    /// Other places involved (the first use of a duplicate address, ...).
    pub related: Vec<(String, Location)>,
}

impl ManifestFinding {
    pub(super) fn new(
        kind: &str,
        location: Location,
        message: impl Into<String>,
        help: impl Into<String>,
    ) -> Self {
        ManifestFinding {
            kind: kind.to_string(),
            message: message.into(),
            help: help.into(),
            location,
            related: Vec::new(),
        }
    }

    pub(super) fn related(mut self, label: &str, loc: Location) -> Self {
        self.related.push((label.to_string(), loc));
        self
    }

    /// A finding about one drive's set that a line run turns into a refusal
    /// of that drive, not of the line: `set-address` / `set-rate` (the
    /// manifest's address is the truth, `crate::line::address_truth`).
    pub fn is_per_drive(&self) -> bool {
        matches!(self.kind.as_str(), "set-address" | "set-rate")
    }

    /// rustc-style text, like the schema crate's findings.
    pub fn render_human(&self) -> String {
        let mut f = self.to_finding();
        f.message = self.message.clone();
        let mut out = f.render_human();
        // the schema crate's renderer names its own kind; put ours back
        if let Some(rest) = out.split_once("]: ").map(|x| x.1.to_string()) {
            out = format!("error[{}]: {rest}", self.kind);
        }
        out
    }

    /// The nearest schema-crate [`Finding`] (for `driveset validate`, whose
    /// output model has a closed set of kinds): the kind maps to the
    /// closest one; the message is kept word for word.
    pub fn to_finding(&self) -> Finding {
        let kind = match self.kind.as_str() {
            "duplicate-address" | "duplicate-name" | "duplicate-bus" => FindingKind::DuplicateCode,
            "group-address" | "address-out-of-range" => FindingKind::OutOfRange,
            "unknown-key" | "unknown-bus" => FindingKind::UnknownCode,
            "missing-set" => FindingKind::BadExtends,
            "set-family" => FindingKind::UnknownSchema,
            "rate-mismatch" | "no-drives" => FindingKind::RuleViolation,
            "missing-key" | "wrong-type" | "bad-port" | "bad-protocol" => FindingKind::WrongType,
            other => set_kind(other).unwrap_or(FindingKind::RuleViolation),
        };
        Finding {
            kind,
            message: self.message.clone(),
            help: self.help.clone(),
            location: self.location.clone(),
            related: self.related.clone(),
        }
    }

    pub(super) fn from_set(f: &Finding) -> Self {
        ManifestFinding {
            kind: f.kind.as_str().to_string(),
            message: f.message.clone(),
            help: f.help.clone(),
            location: f.location.clone(),
            related: f.related.clone(),
        }
    }
}

fn set_kind(s: &str) -> Option<FindingKind> {
    use FindingKind as K;
    [
        K::UnknownCode,
        K::DuplicateCode,
        K::WrongType,
        K::OutOfRange,
        K::Unrepresentable,
        K::UnknownEnumLabel,
        K::UnknownBitField,
        K::ReadOnly,
        K::RuleViolation,
        K::UnknownSchema,
        K::BadExtends,
        K::UnknownType,
        K::UnitMismatch,
        K::SchemaError,
    ]
    .into_iter()
    .find(|k| k.as_str() == s)
}

impl fmt::Display for ManifestFinding {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        driveset_schema::error::write_finding_line(
            f,
            &self.location,
            &self.kind,
            &self.message,
            &self.help,
        )
    }
}
