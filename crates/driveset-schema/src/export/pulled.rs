//! The set file `driveset pull` writes (docs/file-formats.md): the read-only
//! values taken out of the set into the header ([`take_actual_values`]: a
//! set cannot hold them, `validate` refuses them), and the file's text
//! ([`pulled_file`]): comments naming the port, the address, what the
//! drive said it is, the fingerprint and the codes not read; the schema
//! reference in place of [`export`]'s schema line; the `[drive]` table
//! (informational, ignored by the loader) spliced in before the values, so
//! `driveset validate` / `driveset fingerprint` read it back to the same
//! fingerprint. Pure: the set and what the pull found in, text out; but
//! [`schema_ref`], which names a schema file relative to the set's
//! directory (both made absolute and canonical to compare them).

use std::fmt::Write as _;
use std::path::{Component, Path, PathBuf};

use super::{Format, export};
use crate::canonical::ResolvedSet;
use crate::schema::{Access, Schema, StorageKind};
use crate::validate::display_value;

/// The drive a set was pulled from, as the file's header and `[drive]`
/// table name it.
#[derive(Debug, Clone, Copy)]
pub struct PulledFrom<'a> {
    /// The port, as the pull opened it.
    pub port: &'a str,
    /// The drive's address.
    pub address: u8,
    /// What it said it is: its protocol name (`lustbus-mc`, `lecom`, ...).
    pub protocol: &'a str,
    /// The identify codes and their values as text, in the order read.
    pub identity: &'a [(String, String)],
    /// Its software version, where the family has one.
    pub software: Option<&'a str>,
}

/// What the file says of a pull beyond its values.
#[derive(Debug, Clone, Copy)]
pub struct Pulled<'a> {
    /// The drive.
    pub from: PulledFrom<'a>,
    /// The schema reference: a file named by path (relative to the set
    /// file), or the schema's id.
    pub schema_ref: &'a str,
    /// The set's fingerprint.
    pub fingerprint: &'a str,
    /// `--changed-only`: how many values equal to the factory default were
    /// left out, and the fingerprint of every value read.
    pub changed_only: Option<(usize, &'a str)>,
    /// The read-only actual values, `CODE = value` ([`take_actual_values`]).
    pub actual: &'a [String],
    /// The codes not read and why (`code`, `reason`).
    pub not_read: &'a [(&'a str, &'a str)],
}

/// Take the read-only codes (access `ro`, kind `ram-actual`: actual
/// values) out of `set`; they are read but cannot be part of a set. Gives
/// them as `CODE = value` lines for the file's header.
pub fn take_actual_values(set: &mut ResolvedSet, schema: &Schema) -> Vec<String> {
    let mut actual = Vec::new();
    set.values.retain(|k, v| {
        let ro = schema
            .code(k.number)
            .filter(|c| c.access == Some(Access::Ro) || c.kind == Some(StorageKind::RamActual));
        if let Some(c) = ro {
            actual.push(format!(
                "{} = {}",
                schema.display_code(k.number, k.subcode),
                display_value(schema, c, v)
            ));
        }
        ro.is_none()
    });
    actual
}

/// The directory of the set file `output` (`.` for a bare file name):
/// where its schema reference is relative to ([`schema_ref`]) and where
/// `driveset pull` writes a learned schema unless `--schema-dir` says.
pub fn set_dir(output: &Path) -> PathBuf {
    output
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
        .to_path_buf()
}

/// The set file's schema reference ([`Pulled::schema_ref`]): a schema
/// file named by path stays a path, relative to the set's directory
/// `set_dir` ([`relative_path`]); a schema named by id stays its `id`.
pub fn schema_ref(path: Option<&Path>, id: &str, set_dir: &Path) -> String {
    match path {
        Some(p) => relative_path(p, set_dir).display().to_string(),
        None => id.to_string(),
    }
}

/// `to` relative to the directory `from_dir` (both made absolute against
/// the current directory, and canonical where they exist); `to` absolute
/// when they share nothing but the root.
pub fn relative_path(to: &Path, from_dir: &Path) -> PathBuf {
    let abs = |p: &Path| {
        let p = if p.is_absolute() {
            p.to_path_buf()
        } else {
            std::env::current_dir().unwrap_or_default().join(p)
        };
        p.canonicalize().unwrap_or(p)
    };
    let to = abs(to);
    let from = abs(from_dir);
    let t: Vec<Component> = to.components().collect();
    let f: Vec<Component> = from.components().collect();
    let common = t.iter().zip(&f).take_while(|(a, b)| a == b).count();
    if common <= 1 {
        // nothing shared but the root: an absolute path reads better
        return to;
    }
    let mut out = PathBuf::new();
    for _ in common..f.len() {
        out.push("..");
    }
    for c in &t[common..] {
        out.push(c);
    }
    out
}

fn quoted(s: &str) -> String {
    serde_json::to_string(s).unwrap_or_else(|_| "\"\"".into())
}

/// The text of the set file of `set` (of `schema`) pulled as `p` says, in
/// `format` (module docs).
pub fn pulled_file(set: &ResolvedSet, schema: &Schema, p: &Pulled<'_>, format: Format) -> String {
    let from = &p.from;
    let (port, address) = (from.port, from.address);
    let title = format!("pulled from {port} address {address}");
    let body = export(set, schema, Some(&title), format);
    // export starts with the schema line; replace it by the reference.
    let body = body.split_once('\n').map_or("", |(_, rest)| rest);
    let ident: Vec<String> = from
        .identity
        .iter()
        .map(|(c, v)| format!("{c} = {v}"))
        .collect();
    let mut text = String::new();
    let _ = writeln!(text, "# Pulled by driveset from {port} address {address}.");
    let _ = writeln!(
        text,
        "# Drive: {}{}{}",
        from.protocol,
        if ident.is_empty() { "" } else { ", " },
        ident.join(", ")
    );
    if let Some(sw) = from.software {
        let _ = writeln!(text, "# Software: {sw}");
    }
    let _ = writeln!(
        text,
        "# Fingerprint: {} ({} values{})",
        p.fingerprint,
        set.values.len(),
        match p.changed_only {
            Some((dropped, full)) => format!(
                "; {dropped} equal to the factory default left out, all values read: {full}"
            ),
            None => String::new(),
        }
    );
    if !p.actual.is_empty() {
        let _ = writeln!(
            text,
            "# Read-only actual values (not part of the set): {}",
            p.actual.join(", ")
        );
    }
    if !p.not_read.is_empty() {
        let _ = writeln!(text, "# Not read: {} codes", p.not_read.len());
        for (code, reason) in p.not_read {
            let _ = writeln!(text, "#   {code}: {reason}");
        }
    }
    match format {
        Format::Yaml | Format::Json => {
            let _ = writeln!(text, "schema: {}", quoted(p.schema_ref));
            let (head, values) = body.split_once("values:").unwrap_or((body, " {}\n"));
            text.push_str(head);
            let _ = writeln!(text, "drive:");
            let _ = writeln!(text, "  port: {}", quoted(port));
            let _ = writeln!(text, "  address: {address}");
            let _ = writeln!(text, "  protocol: {}", quoted(from.protocol));
            for (c, v) in from.identity {
                let _ = writeln!(text, "  {}: {}", quoted(c), quoted(v));
            }
            let _ = writeln!(text, "  fingerprint: {}", quoted(p.fingerprint));
            text.push_str("values:");
            text.push_str(values);
        }
        Format::Toml => {
            let _ = writeln!(text, "schema = {}", quoted(p.schema_ref));
            let (head, values) = body.split_once("[values]\n").unwrap_or((body, ""));
            text.push_str(head);
            let _ = writeln!(text, "[drive]");
            let _ = writeln!(text, "port = {}", quoted(port));
            let _ = writeln!(text, "address = {address}");
            let _ = writeln!(text, "protocol = {}", quoted(from.protocol));
            for (c, v) in from.identity {
                let _ = writeln!(text, "{} = {}", quoted(c), quoted(v));
            }
            let _ = writeln!(text, "fingerprint = {}", quoted(p.fingerprint));
            text.push_str("\n[values]\n");
            text.push_str(values);
        }
    }
    text
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;

    #[test]
    fn a_set_files_directory_is_its_parent_or_here() {
        assert_eq!(set_dir(Path::new("axis-1.toml")), Path::new("."));
        assert_eq!(set_dir(Path::new("line/axis-1.toml")), Path::new("line"));
        assert_eq!(set_dir(Path::new("/abs/a.yaml")), Path::new("/abs"));
    }
    use crate::canonical::{CodeKey, RawValue};
    use crate::{Registry, load_set_str};

    #[test]
    fn a_schema_file_is_named_relative_to_the_set_and_an_id_as_it_is() {
        // paths that do not exist stay as given (nothing to canonicalize)
        let dir = Path::new("/nonexistent-driveset/plant/sets");
        assert_eq!(
            schema_ref(
                Some(Path::new("/nonexistent-driveset/plant/schemas/x.toml")),
                "x",
                dir
            ),
            "../schemas/x.toml"
        );
        assert_eq!(
            schema_ref(
                Some(Path::new("/nonexistent-driveset/plant/sets/x.toml")),
                "x",
                dir
            ),
            "x.toml"
        );
        // nothing shared but the root: absolute
        assert_eq!(
            relative_path(Path::new("/other-driveset/x.toml"), dir),
            Path::new("/other-driveset/x.toml")
        );
        assert_eq!(schema_ref(None, "lenze-tmd", dir), "lenze-tmd");
    }

    const SET: &str = "schema = \"lenze-tmd\"\n[values]\nC0011 = \"60 Hz\"\nC0010 = 5\n";

    fn tmd_set() -> (ResolvedSet, std::sync::Arc<Schema>) {
        let mut reg = Registry::builtin().unwrap();
        let l = load_set_str(Path::new("s.toml"), SET, &mut reg).unwrap();
        assert!(l.findings.is_empty(), "{:?}", l.findings);
        (l.resolved.unwrap(), l.schema.unwrap())
    }

    fn identity() -> Vec<(String, String)> {
        vec![
            ("C0093".to_string(), "8201".to_string()),
            ("C0099".to_string(), "1.20".to_string()),
        ]
    }

    fn pulled<'a>(
        identity: &'a [(String, String)],
        fingerprint: &'a str,
        actual: &'a [String],
        not_read: &'a [(&'a str, &'a str)],
    ) -> Pulled<'a> {
        Pulled {
            from: PulledFrom {
                port: "/dev/ttyUSB0",
                address: 3,
                protocol: "lecom",
                identity,
                software: Some("1.20"),
            },
            schema_ref: "lenze-tmd",
            fingerprint,
            changed_only: None,
            actual,
            not_read,
        }
    }

    /// The read-only codes leave the set for the header, as `CODE = value`;
    /// the others stay.
    #[test]
    fn actual_values_leave_the_set() {
        let (mut set, schema) = tmd_set();
        set.values
            .insert(CodeKey::new(99), RawValue::Text("1.20".into()));
        let n = set.values.len();
        let actual = take_actual_values(&mut set, &schema);
        assert_eq!(actual.len(), 1, "{actual:?}");
        assert!(actual[0].starts_with("C0099 = "), "{actual:?}");
        assert!(actual[0].contains("1.20"), "{actual:?}");
        assert_eq!(set.values.len(), n - 1);
        assert!(!set.values.contains_key(&CodeKey::new(99)));
    }

    /// The TOML file: the header comments, the schema reference, the
    /// `[drive]` table before `[values]`; it reads back to the set's
    /// fingerprint.
    #[test]
    fn the_toml_file_reads_back_to_the_fingerprint() {
        let (set, schema) = tmd_set();
        let fp = set.fingerprint();
        let id = identity();
        let actual = vec!["C0099 = 1.20".to_string()];
        let not_read = [("C0094", "password: not read")];
        let text = pulled_file(
            &set,
            &schema,
            &pulled(&id, &fp, &actual, &not_read),
            Format::Toml,
        );
        assert!(
            text.starts_with(
                "# Pulled by driveset from /dev/ttyUSB0 address 3.\n# Drive: lecom, C0093 = 8201, C0099 = 1.20\n# Software: 1.20\n"
            ),
            "{text}"
        );
        assert!(
            text.contains(&format!("# Fingerprint: {fp} (2 values)\n")),
            "{text}"
        );
        assert!(
            text.contains("# Read-only actual values (not part of the set): C0099 = 1.20\n"),
            "{text}"
        );
        assert!(
            text.contains("# Not read: 1 codes\n#   C0094: password: not read\n"),
            "{text}"
        );
        assert!(text.contains("\nschema = \"lenze-tmd\"\n"), "{text}");
        assert_eq!(text.matches("schema = ").count(), 1, "{text}");
        let drive = text.find("[drive]\nport = \"/dev/ttyUSB0\"\naddress = 3\nprotocol = \"lecom\"\n\"C0093\" = \"8201\"\n").expect("[drive]");
        let values = text.find("\n[values]\n").expect("[values]");
        assert!(drive < values, "{text}");
        assert!(
            text.contains(&format!("fingerprint = \"{fp}\"\n\n[values]\n")),
            "{text}"
        );
        let mut reg = Registry::builtin().unwrap();
        let l = load_set_str(Path::new("p.toml"), &text, &mut reg).unwrap();
        assert!(l.findings.is_empty(), "{:?}\n{text}", l.findings);
        assert_eq!(l.resolved.unwrap().fingerprint(), fp);
    }

    /// The YAML file: the `drive:` mapping before `values:`; it reads back
    /// to the set's fingerprint. `--changed-only` names what it left out.
    #[test]
    fn the_yaml_file_reads_back_to_the_fingerprint() {
        let (set, schema) = tmd_set();
        let fp = set.fingerprint();
        let id = identity();
        let mut p = pulled(&id, &fp, &[], &[]);
        p.changed_only = Some((7, "sha256:full"));
        let text = pulled_file(&set, &schema, &p, Format::Yaml);
        assert!(
            text.contains(&format!(
                "# Fingerprint: {fp} (2 values; 7 equal to the factory default left out, all values read: sha256:full)\n"
            )),
            "{text}"
        );
        assert!(!text.contains("# Not read"), "{text}");
        assert!(!text.contains("# Read-only"), "{text}");
        assert!(text.contains("\nschema: \"lenze-tmd\"\n"), "{text}");
        let drive = text
            .find("drive:\n  port: \"/dev/ttyUSB0\"\n  address: 3\n  protocol: \"lecom\"\n  \"C0093\": \"8201\"\n")
            .expect("drive:");
        let values = text.find("\nvalues:").expect("values:");
        assert!(drive < values, "{text}");
        let mut reg = Registry::builtin().unwrap();
        let l = load_set_str(Path::new("p.yaml"), &text, &mut reg).unwrap();
        assert!(l.findings.is_empty(), "{:?}\n{text}", l.findings);
        assert_eq!(l.resolved.unwrap().fingerprint(), fp);
    }
}
