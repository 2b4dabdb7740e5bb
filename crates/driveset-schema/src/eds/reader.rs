//! Owns reading CiA 306 electronic data sheets (EDS) and device
//! configuration files (DCF): the INI-style syntax (CiA 306 §4.1: sections,
//! `key=value` lines, `;` comment lines), the object sections (`[1000]`,
//! `[1018sub2]`, CiA 306 §4.6) with their keys (§4.6.3), and the value
//! syntax (§4.4: decimal, `0x` hex, `$NODEID` arithmetic, strings and
//! octet strings). Pure: bytes in, a model with line numbers and lints out.
//!
//! Tolerant of what vendor files carry (each case is a lint, never a
//! failure): keys and section names in any case, duplicate keys (the first
//! wins) and sections (merged), empty values, hex in any case (`0X1a`),
//! decimal with leading zeros (`001`, read as decimal; see [`parse_int`]),
//! `$NODEID+0x580` and `0x580+$NODEID`, Latin-1 bytes, a UTF-8 byte order
//! mark, UTF-16 with a byte order mark, CR LF and CR-only line ends, lines
//! without `=`, `#` comment lines, section names shaped like an object but
//! out of range (`[10000]`, `[1018sub100]`).
//!
//! Comments (CiA 306 §4.1: a line whose first character is `;`): a `;`
//! inside a value ends it only where python-canopen's reader
//! (`configparser` with `inline_comment_prefixes=(';',)`) ends it, after
//! whitespace (`Speed ; rpm` is `Speed`, with a lint); a `;` right after
//! text stays in the value (`C0016 Block detection; torque and time`).
//!
//! Refused (an [`EdsError`] with the line): a NUL byte (a binary file, or
//! UTF-16 without a byte order mark), UTF-16 that does not decode, a file
//! with no object section at all.

use std::collections::BTreeMap;

/// A lint or error location: 1-based line in the file.
pub type Line = usize;

/// One `key=value` line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Entry {
    /// The key as written (compare with [`eq_key`]).
    pub key: String,
    /// The value, trimmed, comment removed.
    pub value: String,
    /// Where.
    pub line: Line,
}

/// One `[section]` (duplicates merged into the first).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Section {
    /// The name as written.
    pub name: String,
    /// Line of the (first) header.
    pub line: Line,
    /// Entries in file order; a key given twice keeps its first entry.
    pub entries: Vec<Entry>,
}

impl Section {
    /// The entry of `key` (case-insensitive).
    pub fn get(&self, key: &str) -> Option<&Entry> {
        self.entries
            .iter()
            .find(|e| e.key.eq_ignore_ascii_case(key))
    }
}

/// A problem the reader worked around.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Lint {
    /// Where.
    pub line: Line,
    /// What and what was done.
    pub message: String,
}

/// Why a file cannot be read as an EDS / DCF.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EdsError {
    /// Where (0 when it concerns the whole file).
    pub line: Line,
    /// 1-based column (0 when it concerns the whole line or file).
    pub column: usize,
    /// What is wrong.
    pub message: String,
    /// What to do.
    pub help: String,
}

/// A section name parsed as an object dictionary address (CiA 306 §4.6:
/// `[IIII]` main index, `[IIIIsubS]` subindex, both hex without `0x`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum ObjectName {
    /// `[1018]`.
    Main(u16),
    /// `[1018sub2]`.
    Sub(u16, u8),
}

/// A parsed file: sections in file order, lints.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct EdsFile {
    /// Sections in file order (the first spelling of each name).
    pub sections: Vec<Section>,
    /// What the reader worked around.
    pub lints: Vec<Lint>,
}

impl EdsFile {
    /// A section by name (case-insensitive).
    pub fn section(&self, name: &str) -> Option<&Section> {
        self.sections
            .iter()
            .find(|s| s.name.eq_ignore_ascii_case(name))
    }

    /// The object sections by address, in address order.
    pub fn objects(&self) -> BTreeMap<ObjectName, &Section> {
        self.sections
            .iter()
            .filter_map(|s| object_name(&s.name).map(|n| (n, s)))
            .collect()
    }
}

/// Case-insensitive key comparison (CiA 306 §4.1: keys are not case sensitive).
pub fn eq_key(a: &str, b: &str) -> bool {
    a.eq_ignore_ascii_case(b)
}

/// `1018` -> Main(0x1018), `1018sub2` / `1018SUB02` -> Sub(0x1018, 2);
/// `None` for other sections and for a subindex above FF.
pub fn object_name(name: &str) -> Option<ObjectName> {
    let n = name.trim();
    let hex4 = |s: &str| -> Option<u16> {
        if s.len() == 4 && s.bytes().all(|b| b.is_ascii_hexdigit()) {
            u16::from_str_radix(s, 16).ok()
        } else {
            None
        }
    };
    if let Some(i) = hex4(n) {
        return Some(ObjectName::Main(i));
    }
    let (idx, rest) = (n.get(..4)?, n.get(4..)?);
    let index = hex4(idx)?;
    let sub = rest.get(..3)?;
    if !sub.eq_ignore_ascii_case("sub") {
        return None;
    }
    let digits = rest.get(3..)?;
    // leading zeros allowed (`sub01`, as python-canopen reads them)
    if digits.is_empty() || digits.len() > 8 || !digits.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    u32::from_str_radix(digits, 16)
        .ok()
        .and_then(|s| u8::try_from(s).ok())
        .map(|s| ObjectName::Sub(index, s))
}

/// Largest file read (CiA 306 files are tens to hundreds of kB).
pub const MAX_BYTES: usize = 16 * 1024 * 1024;

/// Read an EDS / DCF from its bytes.
pub fn parse(bytes: &[u8]) -> Result<EdsFile, EdsError> {
    if bytes.len() > MAX_BYTES {
        return Err(EdsError {
            line: 0,
            column: 0,
            message: format!(
                "{} bytes is more than an EDS / DCF holds (at most {MAX_BYTES})",
                bytes.len()
            ),
            help: "check that this is a CiA 306 data sheet".into(),
        });
    }
    let utf16 = decode_utf16(bytes)?;
    let body: &[u8] = match &utf16 {
        Some(text) => text.as_bytes(),
        None => bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes),
    };
    let mut file = EdsFile::default();
    let mut by_name: BTreeMap<String, usize> = BTreeMap::new();
    let mut current: Option<usize> = None;
    for (i, raw) in lines(body).enumerate() {
        let line = i + 1;
        if let Some(col) = raw.iter().position(|&b| b == 0) {
            return Err(nul_error(bytes, line, col));
        }
        let text = decode_line(raw);
        let t = text.trim();
        if t.is_empty() || t.starts_with(';') {
            continue;
        }
        if t.starts_with('#') {
            file.lints.push(Lint {
                line,
                message: "line starts with `#`: CiA 306 comments start with `;`; read as a comment, as python-canopen does".into(),
            });
            continue;
        }
        if let Some(rest) = t.strip_prefix('[') {
            let Some(end) = rest.find(']') else {
                file.lints.push(Lint {
                    line,
                    message: format!("section header `{t}` has no `]`; its entries are ignored"),
                });
                current = None;
                continue;
            };
            let name = rest[..end].trim().to_string();
            if let Some(why) = out_of_range_object(&name) {
                file.lints.push(Lint {
                    line,
                    message: format!(
                        "section [{name}] is shaped like an object but {why} (CiA 306 §4.6: [IIII] or [IIIIsubS], IIII 4 hex digits, S 0..FF); its entries are ignored"
                    ),
                });
            }
            let after = strip_comment(&rest[end + 1..]);
            if !after.trim().is_empty() {
                file.lints.push(Lint {
                    line,
                    message: format!("text after section header [{name}] ignored"),
                });
            }
            let key = name.to_ascii_lowercase();
            match by_name.get(&key) {
                Some(&at) => {
                    let first = file.sections.get(at).map_or(0, |s| s.line);
                    file.lints.push(Lint {
                        line,
                        message: format!(
                            "section [{name}] given again (first at line {first}); entries merged, the first value of a key wins"
                        ),
                    });
                    current = Some(at);
                }
                None => {
                    by_name.insert(key, file.sections.len());
                    current = Some(file.sections.len());
                    file.sections.push(Section {
                        name,
                        line,
                        entries: Vec::new(),
                    });
                }
            }
            continue;
        }
        let Some(eq) = t.find('=') else {
            file.lints.push(Lint {
                line,
                message: format!("`{}` is not `key=value`; ignored", shorten(t)),
            });
            continue;
        };
        let key = t[..eq].trim().to_string();
        let full = &t[eq + 1..];
        let kept = strip_comment(full);
        if kept.len() < full.len() {
            file.lints.push(Lint {
                line,
                message: format!(
                    "`{}` after whitespace read as a comment, as python-canopen reads it (CiA 306 comments are whole lines); {key} is `{}`",
                    shorten(full[kept.len()..].trim()),
                    shorten(kept.trim())
                ),
            });
        }
        let value = kept.trim().to_string();
        let Some(sec) = current.and_then(|c| file.sections.get_mut(c)) else {
            file.lints.push(Lint {
                line,
                message: format!("`{}` outside any [section]; ignored", shorten(&key)),
            });
            continue;
        };
        if key.is_empty() {
            file.lints.push(Lint {
                line,
                message: format!("empty key in [{}]; ignored", sec.name),
            });
            continue;
        }
        if let Some(first) = sec.get(&key) {
            let first_line = first.line;
            file.lints.push(Lint {
                line,
                message: format!(
                    "key {key} given twice in [{}] (first at line {first_line}); the first value is kept",
                    sec.name
                ),
            });
            continue;
        }
        sec.entries.push(Entry { key, value, line });
    }
    if !file.sections.iter().any(|s| object_name(&s.name).is_some()) {
        return Err(EdsError {
            line: 0,
            column: 0,
            message: "no object section ([1000], [5FF4], [1018sub1], ...): not a CiA 306 EDS / DCF"
                .into(),
            help: "give the .eds or .dcf file shipped with the device".into(),
        });
    }
    Ok(file)
}

/// UTF-8 where the line is UTF-8, else Latin-1 (vendor files often are).
fn decode_line(raw: &[u8]) -> String {
    match std::str::from_utf8(raw) {
        Ok(s) => s.to_string(),
        Err(_) => raw.iter().map(|&b| char::from(b)).collect(),
    }
}

/// The text after `=` (or `]`) before an inline `;` comment as
/// python-canopen reads one (`configparser`, `inline_comment_prefixes=(';',)`:
/// a `;` preceded by whitespace in the line); a `;` right after other text,
/// the `=` included (`DefaultValue=;x`), is part of the value.
fn strip_comment(s: &str) -> &str {
    let mut prev_space = false;
    for (i, c) in s.char_indices() {
        if c == ';' && prev_space {
            return &s[..i];
        }
        prev_space = c.is_whitespace();
    }
    s
}

/// Lines split at LF, CR LF or a lone CR (old Mac files), ends removed.
fn lines(body: &[u8]) -> impl Iterator<Item = &[u8]> {
    let mut rest = Some(body);
    std::iter::from_fn(move || {
        let r = rest?;
        match r.iter().position(|&b| b == b'\n' || b == b'\r') {
            None => {
                rest = None;
                Some(r)
            }
            Some(p) => {
                let skip = if r[p] == b'\r' && r.get(p + 1) == Some(&b'\n') {
                    2
                } else {
                    1
                };
                rest = Some(&r[p + skip..]);
                Some(&r[..p])
            }
        }
    })
}

/// A UTF-16 file (with its byte order mark) as text; `None` for other files.
fn decode_utf16(bytes: &[u8]) -> Result<Option<String>, EdsError> {
    let little = match bytes {
        [0xFF, 0xFE, ..] => true,
        [0xFE, 0xFF, ..] => false,
        _ => return Ok(None),
    };
    let body = &bytes[2..];
    let refuse = |line: usize, message: String| EdsError {
        line,
        column: 0,
        message,
        help: "save the data sheet as UTF-8 (or Latin-1) text and import that".into(),
    };
    if !body.len().is_multiple_of(2) {
        return Err(refuse(
            0,
            format!(
                "UTF-16 {} file (byte order mark) of an odd number of bytes ({}): cut short",
                if little { "LE" } else { "BE" },
                bytes.len()
            ),
        ));
    }
    let units = body.chunks_exact(2).map(|p| {
        if little {
            u16::from_le_bytes([p[0], p[1]])
        } else {
            u16::from_be_bytes([p[0], p[1]])
        }
    });
    let mut text = String::with_capacity(body.len() / 2);
    let mut line = 1;
    for c in char::decode_utf16(units) {
        match c {
            Ok(c) => {
                if c == '\n' {
                    line += 1;
                }
                text.push(c);
            }
            Err(e) => {
                return Err(refuse(
                    line,
                    format!(
                        "UTF-16 {} file: unpaired surrogate 0x{:04X}: not UTF-16 text",
                        if little { "LE" } else { "BE" },
                        e.unpaired_surrogate()
                    ),
                ));
            }
        }
    }
    Ok(Some(text))
}

/// The refusal of a NUL byte at `line` / `col` (0-based): UTF-16 without a
/// byte order mark when every other byte of the start is NUL.
fn nul_error(bytes: &[u8], line: usize, col: usize) -> EdsError {
    let head = &bytes[..bytes.len().min(64)];
    let nul_at = |odd: bool| {
        head.len() >= 4
            && head
                .iter()
                .enumerate()
                .all(|(i, &b)| (i % 2 == 1) == odd || b != 0)
            && head
                .iter()
                .enumerate()
                .filter(|(i, _)| (i % 2 == 1) == odd)
                .all(|(_, &b)| b == 0)
    };
    if nul_at(true) || nul_at(false) {
        return EdsError {
            line,
            column: col + 1,
            message: format!(
                "UTF-16 {} text without a byte order mark",
                if nul_at(true) { "LE" } else { "BE" }
            ),
            help: "save the data sheet as UTF-8, or as UTF-16 with a byte order mark".into(),
        };
    }
    EdsError {
        line,
        column: col + 1,
        message: "NUL byte: this is a binary file, not a CiA 306 EDS / DCF".into(),
        help: "give the .eds or .dcf text file shipped with the device".into(),
    }
}

/// Why a section name shaped like an object address (hex digits, or hex
/// digits + `sub` + hex digits) is none; `None` for object names and for
/// other sections (`[FileInfo]`, `[1003Name]`, `[1F50Value]`).
fn out_of_range_object(name: &str) -> Option<&'static str> {
    if object_name(name).is_some() {
        return None;
    }
    let hex = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_hexdigit());
    let n = name.trim();
    if hex(n) && n.len() <= 8 && n.bytes().any(|b| b.is_ascii_digit()) {
        return Some(if n.len() > 4 {
            "its index has more than 4 hex digits"
        } else {
            "its index has fewer than 4 hex digits"
        });
    }
    let lower = n.to_ascii_lowercase();
    let (idx, sub) = lower.split_once("sub")?;
    if !hex(idx) || !hex(sub) {
        return None;
    }
    Some(if idx.len() != 4 {
        "its index is not 4 hex digits"
    } else {
        "its subindex is above FF"
    })
}

fn shorten(s: &str) -> String {
    if s.chars().count() <= 40 {
        s.to_string()
    } else {
        let mut t: String = s.chars().take(40).collect();
        t.push_str("...");
        t
    }
}

/// An integer value: a constant, or a constant plus the node id
/// (`$NODEID+0x580`, CiA 306 §4.6.3 "DefaultValue").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IntValue {
    /// The constant part.
    pub value: i128,
    /// `$NODEID` is added.
    pub plus_node_id: bool,
    /// Written in hex (`0x..`): for signed types a two's complement pattern.
    pub hex: bool,
    /// Written with leading zeros whose octal reading differs (`010`).
    pub octal_differs: Option<i128>,
}

impl IntValue {
    /// The value for a node id.
    pub fn at_node(&self, node: u8) -> i128 {
        self.value
            + if self.plus_node_id {
                i128::from(node)
            } else {
                0
            }
    }
}

/// Parse an integer value (CiA 306 §4.4): optional sign, decimal or `0x`
/// hex in any case, optionally `$NODEID +` before or `+ $NODEID` after
/// (spaces allowed, `$NODEID` in any case).
///
/// Leading zeros (`001`): CiA 306 follows C's `strtoul(s, 0)`, where a
/// leading 0 means octal, but the vendor files python-canopen's users
/// report (issue #313, `VendorNumber=001`) mean decimal. driveset reads
/// decimal and records in [`IntValue::octal_differs`] the octal reading
/// when it differs (`010` = 10, octal 8), so the importer can say so;
/// `08` / `09` are decimal either way.
pub fn parse_int(text: &str) -> Option<IntValue> {
    let t: String = text.chars().filter(|c| !c.is_whitespace()).collect();
    let upper = t.to_ascii_uppercase();
    let (num, plus) = if let Some(r) = upper.strip_prefix("$NODEID+") {
        (r.to_string(), true)
    } else if let Some(r) = upper.strip_suffix("+$NODEID") {
        (r.to_string(), true)
    } else if upper == "$NODEID" {
        ("0".to_string(), true)
    } else {
        (upper, false)
    };
    let (neg, body) = match num.strip_prefix('-') {
        Some(r) => (true, r),
        None => (false, num.strip_prefix('+').unwrap_or(&num)),
    };
    if body.is_empty() || body.len() > 34 {
        return None;
    }
    let (v, hex, octal_differs) = if let Some(h) = body.strip_prefix("0X") {
        if h.is_empty() || !h.bytes().all(|b| b.is_ascii_hexdigit()) {
            return None;
        }
        (i128::from_str_radix(h, 16).ok()?, true, None)
    } else {
        if !body.bytes().all(|b| b.is_ascii_digit()) {
            return None;
        }
        let d: i128 = body.parse().ok()?;
        let oct = if body.len() > 1 && body.starts_with('0') {
            i128::from_str_radix(body, 8).ok().filter(|o| *o != d)
        } else {
            None
        };
        (d, false, oct)
    };
    let sign = |x: i128| if neg { -x } else { x };
    Some(IntValue {
        value: sign(v),
        plus_node_id: plus,
        hex,
        octal_differs: octal_differs.map(sign),
    })
}

/// Octets of an OCTET_STRING / DOMAIN value: hex digit pairs without `0x`
/// (CiA 306 §4.4). `None` when the text is not that.
pub fn parse_octets(text: &str) -> Option<Vec<u8>> {
    let t = text.trim();
    if !t.len().is_multiple_of(2) || !t.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    (0..t.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(t.get(i..i + 2)?, 16).ok())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sections_keys_comments_and_case() {
        let text = b"; header comment\r\n[FileInfo]\r\nFileName=x.eds ; trailing\r\n\r\n[1000]\r\nparametername=Device type\r\nDATATYPE=0x0007\r\n[1018SUB2]\nParameterName = Product code \n";
        let f = parse(text).unwrap();
        assert_eq!(
            f.lints,
            vec![Lint {
                line: 3,
                message: "`; trailing` after whitespace read as a comment, as python-canopen reads it (CiA 306 comments are whole lines); FileName is `x.eds`".into()
            }]
        );
        assert_eq!(f.sections.len(), 3);
        let fi = f.section("fileinfo").unwrap();
        assert_eq!(fi.get("FILENAME").unwrap().value, "x.eds");
        assert_eq!(fi.line, 2);
        let obj = f.objects();
        let keys: Vec<ObjectName> = obj.keys().copied().collect();
        assert_eq!(
            keys,
            vec![ObjectName::Main(0x1000), ObjectName::Sub(0x1018, 2)]
        );
        let s = obj[&ObjectName::Main(0x1000)];
        assert_eq!(s.get("ParameterName").unwrap().value, "Device type");
        assert_eq!(s.get("DataType").unwrap().line, 7);
        assert_eq!(
            obj[&ObjectName::Sub(0x1018, 2)]
                .get("parameterName")
                .unwrap()
                .value,
            "Product code"
        );
    }

    #[test]
    fn duplicate_keys_and_sections_are_lints_first_wins() {
        let text = b"[2000]\nDefaultValue=1\nDefaultValue=2\n[2000]\nDefaultValue=3\nHighLimit=9\n";
        let f = parse(text).unwrap();
        assert_eq!(
            f.lints,
            vec![
                Lint {
                    line: 3,
                    message: "key DefaultValue given twice in [2000] (first at line 2); the first value is kept".into()
                },
                Lint {
                    line: 4,
                    message: "section [2000] given again (first at line 1); entries merged, the first value of a key wins".into()
                },
                Lint {
                    line: 5,
                    message: "key DefaultValue given twice in [2000] (first at line 2); the first value is kept".into()
                },
            ]
        );
        let s = f.section("2000").unwrap();
        assert_eq!(s.get("defaultvalue").unwrap().value, "1");
        assert_eq!(s.get("HighLimit").unwrap().value, "9");
        assert_eq!(s.get("HighLimit").unwrap().line, 6);
    }

    #[test]
    fn stray_lines_and_bad_headers_are_lints() {
        let text = b"stray=1\n[1000\nx=1\n[1001] junk\njust text\n=5\n";
        let f = parse(text).unwrap();
        let got: Vec<(usize, &str)> = f
            .lints
            .iter()
            .map(|l| (l.line, l.message.as_str()))
            .collect();
        assert_eq!(
            got,
            vec![
                (1, "`stray` outside any [section]; ignored"),
                (
                    2,
                    "section header `[1000` has no `]`; its entries are ignored"
                ),
                (3, "`x` outside any [section]; ignored"),
                (4, "text after section header [1001] ignored"),
                (5, "`just text` is not `key=value`; ignored"),
                (6, "empty key in [1001]; ignored"),
            ]
        );
    }

    #[test]
    fn refusals_carry_the_location() {
        let e = parse(b"[1000]\nDataType=0x0007\nab\0cd\n").unwrap_err();
        assert_eq!((e.line, e.column), (3, 3));
        assert_eq!(
            e.message,
            "NUL byte: this is a binary file, not a CiA 306 EDS / DCF"
        );
        let e = parse(b"[FileInfo]\nFileName=a.eds\n").unwrap_err();
        assert_eq!(e.line, 0);
        assert_eq!(
            e.message,
            "no object section ([1000], [5FF4], [1018sub1], ...): not a CiA 306 EDS / DCF"
        );
        assert!(parse(b"").is_err());
    }

    #[test]
    fn a_semicolon_after_text_stays_in_the_value() {
        let f = parse(b"[5FE7]\nParameterName=C0016 Block detection; torque and time\nDefaultValue=5\t; five\n").unwrap();
        let s = f.section("5FE7").unwrap();
        assert_eq!(
            s.get("ParameterName").unwrap().value,
            "C0016 Block detection; torque and time"
        );
        assert_eq!(s.get("DefaultValue").unwrap().value, "5");
        assert_eq!(
            f.lints,
            vec![Lint {
                line: 3,
                message: "`; five` after whitespace read as a comment, as python-canopen reads it (CiA 306 comments are whole lines); DefaultValue is `5`".into()
            }]
        );
        assert_eq!(strip_comment(";x"), ";x");
        assert_eq!(strip_comment(" ;x"), " ");
        assert_eq!(strip_comment("a;b ;c"), "a;b ");
    }

    #[test]
    fn cr_only_lf_and_crlf_line_ends() {
        for text in [
            &b"[1000]\rParameterName=Device type\rDataType=0x0007\r"[..],
            b"[1000]\r\nParameterName=Device type\r\nDataType=0x0007",
            b"[1000]\nParameterName=Device type\nDataType=0x0007\n",
        ] {
            let f = parse(text).unwrap();
            let s = f.section("1000").unwrap();
            assert_eq!(s.get("ParameterName").unwrap().value, "Device type");
            assert_eq!(s.get("DataType").unwrap().line, 3);
        }
    }

    #[test]
    fn utf16_with_bom_is_read_without_is_refused() {
        let text = "[5FF4]\r\nParameterName=Drehzahl \u{fc}ber\r\n";
        let le: Vec<u8> = [0xFF, 0xFE]
            .into_iter()
            .chain(text.encode_utf16().flat_map(u16::to_le_bytes))
            .collect();
        let be: Vec<u8> = [0xFE, 0xFF]
            .into_iter()
            .chain(text.encode_utf16().flat_map(u16::to_be_bytes))
            .collect();
        for bytes in [&le, &be] {
            let f = parse(bytes).unwrap();
            assert_eq!(
                f.section("5FF4")
                    .unwrap()
                    .get("ParameterName")
                    .unwrap()
                    .value,
                "Drehzahl \u{fc}ber"
            );
        }
        let e = parse(&le[2..]).unwrap_err();
        assert_eq!((e.line, e.column), (1, 2));
        assert_eq!(e.message, "UTF-16 LE text without a byte order mark");
        let e = parse(&be[..be.len() - 1]).unwrap_err();
        assert_eq!(
            e.message,
            "UTF-16 BE file (byte order mark) of an odd number of bytes (75): cut short"
        );
        let mut bad = le.clone();
        bad.extend([0x00, 0xD8, b'x', 0]);
        let e = parse(&bad).unwrap_err();
        assert_eq!(e.line, 3);
        assert_eq!(
            e.message,
            "UTF-16 LE file: unpaired surrogate 0xD800: not UTF-16 text"
        );
    }

    #[test]
    fn object_shaped_names_out_of_range_and_hash_comments_are_lints() {
        let f = parse(b"[10000]\nx=1\n[1018sub100]\nx=1\n[101sub1]\n# note\n[1003Name]\n[1000]\n")
            .unwrap();
        let got: Vec<(usize, &str)> = f
            .lints
            .iter()
            .map(|l| (l.line, l.message.as_str()))
            .collect();
        assert_eq!(
            got,
            vec![
                (
                    1,
                    "section [10000] is shaped like an object but its index has more than 4 hex digits (CiA 306 §4.6: [IIII] or [IIIIsubS], IIII 4 hex digits, S 0..FF); its entries are ignored"
                ),
                (
                    3,
                    "section [1018sub100] is shaped like an object but its subindex is above FF (CiA 306 §4.6: [IIII] or [IIIIsubS], IIII 4 hex digits, S 0..FF); its entries are ignored"
                ),
                (
                    5,
                    "section [101sub1] is shaped like an object but its index is not 4 hex digits (CiA 306 §4.6: [IIII] or [IIIIsubS], IIII 4 hex digits, S 0..FF); its entries are ignored"
                ),
                (
                    6,
                    "line starts with `#`: CiA 306 comments start with `;`; read as a comment, as python-canopen does"
                ),
            ]
        );
        assert_eq!(f.objects().len(), 1);
    }

    #[test]
    fn latin1_and_bom() {
        let f = parse(b"\xEF\xBB\xBF[5FF4]\nParameterName=Drehzahl \xFCber\n").unwrap();
        assert_eq!(
            f.section("5ff4")
                .unwrap()
                .get("ParameterName")
                .unwrap()
                .value,
            "Drehzahl \u{fc}ber"
        );
    }

    #[test]
    fn object_names() {
        assert_eq!(object_name("5FF4"), Some(ObjectName::Main(0x5FF4)));
        assert_eq!(object_name("5ff4"), Some(ObjectName::Main(0x5FF4)));
        assert_eq!(object_name("1018sub0"), Some(ObjectName::Sub(0x1018, 0)));
        assert_eq!(object_name("1018SubA"), Some(ObjectName::Sub(0x1018, 10)));
        assert_eq!(object_name("1018sub10"), Some(ObjectName::Sub(0x1018, 16)));
        assert_eq!(object_name("1018sub"), None);
        assert_eq!(object_name("1018sub100"), None);
        assert_eq!(object_name("1018sub001"), Some(ObjectName::Sub(0x1018, 1)));
        assert_eq!(object_name("1003Name"), None);
        assert_eq!(object_name("FileInfo"), None);
        assert_eq!(object_name("10180"), None);
    }

    fn iv(value: i128, plus_node_id: bool, hex: bool, oct: Option<i128>) -> Option<IntValue> {
        Some(IntValue {
            value,
            plus_node_id,
            hex,
            octal_differs: oct,
        })
    }

    #[test]
    fn integers() {
        assert_eq!(parse_int("0x1A"), iv(26, false, true, None));
        assert_eq!(parse_int("0X1a"), iv(26, false, true, None));
        assert_eq!(parse_int("001"), iv(1, false, false, None));
        assert_eq!(parse_int("010"), iv(10, false, false, Some(8)));
        assert_eq!(parse_int("09"), iv(9, false, false, None));
        assert_eq!(parse_int("-25"), iv(-25, false, false, None));
        assert_eq!(parse_int("$NODEID+0x580"), iv(0x580, true, true, None));
        assert_eq!(parse_int("0x580+$NODEID"), iv(0x580, true, true, None));
        assert_eq!(parse_int("$nodeid + 0x180"), iv(0x180, true, true, None));
        assert_eq!(parse_int("$NODEID"), iv(0, true, false, None));
        assert_eq!(parse_int("$NODEID+0x580").unwrap().at_node(5), 0x585);
        for bad in [
            "",
            "0x",
            "0.0",
            "1e3",
            "abc",
            "$NODEID-1",
            "0x1G",
            "--1",
            "+",
        ] {
            assert_eq!(parse_int(bad), None, "{bad}");
        }
    }

    #[test]
    fn octets() {
        assert_eq!(parse_octets("01a1FF"), Some(vec![1, 0xA1, 0xFF]));
        assert_eq!(parse_octets(""), Some(vec![]));
        assert_eq!(parse_octets("0"), None);
        assert_eq!(parse_octets("0x01"), None);
    }
}
