//! Owns what a capture is decoded from and in: the capture's bytes as
//! `driveset decode` is given them ([`CaptureGiven::read`]: hex text,
//! escaped ASCII, a file or stdin, as bytes or as hex text; proto's `text`
//! parsers, the schema crate's one reader with the capture's size cap) and
//! the [`Context`] it is decoded in ([`Context::fitted`]: the schema
//! checked against the capture's protocol and LUSTBUS family, else the
//! built-in schema of the one family a LECOM or slcan capture carries).
//! docs/architecture.md (`decode/`); the input forms in `driveset decode
//! --help`.

use std::io::Read;
use std::path::Path;
use std::sync::Arc;

use driveset_proto::lustbus::Dialect;
use driveset_proto::text;
use driveset_schema::input::{InputKind, read_input};
use driveset_schema::{InputErrorKind, Registry, Schema};

use super::{Capture, Context};

/// The most bytes a capture is read with from a file or stdin (16 MiB: at
/// 57600 baud that is 48 minutes of traffic), so `--raw -` fed from an
/// endless stream ends with an error instead of filling memory.
pub const MAX_CAPTURE_BYTES: u64 = InputKind::CAPTURE.cap;

/// The capture as given: exactly one of `hex`, `ascii` and `file` is
/// expected (`-` for stdin); `raw` says the file holds the bytes
/// themselves rather than hex text.
#[derive(Debug, Clone, Copy, Default)]
pub struct CaptureGiven<'a> {
    /// `--hex`: hex text.
    pub hex: Option<&'a str>,
    /// `--ascii`: the escaped form `driveset encode` prints.
    pub ascii: Option<&'a str>,
    /// FILE, `-` for stdin.
    pub file: Option<&'a Path>,
    /// `--raw`: FILE holds the bytes.
    pub raw: bool,
}

/// Why the capture could not be read; each says what to give instead.
#[derive(Debug, thiserror::Error)]
pub enum CaptureInputError {
    /// `--raw` given with `--hex` or `--ascii` (the flag named).
    #[error("--raw applies to FILE, not to {0}")]
    RawNotFile(&'static str),
    /// Nothing given.
    #[error(
        "no capture given: pass --hex \"04 40 ...\", --ascii \"<EOT>...\", a FILE, or - for stdin"
    )]
    Nothing,
    /// Hex or escaped ASCII that does not parse (proto's message, with
    /// line and column).
    #[error("{0}")]
    Parse(String),
    /// Stdin could not be read.
    #[error("cannot read stdin: {0}")]
    Stdin(std::io::Error),
    /// More than [`MAX_CAPTURE_BYTES`] in `name` (a file, or `<stdin>`).
    #[error(
        "{name}: the capture is larger than {MAX_CAPTURE_BYTES} bytes, the most `driveset decode` reads; split it (e.g. with `split -b`) and decode the parts"
    )]
    TooLarge {
        /// The file, or `<stdin>`.
        name: String,
    },
    /// The file could not be read (the one reader's message and help).
    #[error("{message}; {help}")]
    File {
        /// What went wrong.
        message: String,
        /// What to do.
        help: String,
    },
    /// Hex text expected, but byte `at` of `name` is not text.
    #[error("{name}: byte {at} is not text; is this a binary capture? pass --raw")]
    NotText {
        /// The file, or `<stdin>`.
        name: String,
        /// The first byte that is not UTF-8.
        at: usize,
    },
}

impl CaptureGiven<'_> {
    /// The capture's bytes; stdin (`stdin`) is read only for FILE `-`.
    ///
    /// # Errors
    /// [`CaptureInputError`]: nothing or too much given, unreadable,
    /// larger than [`MAX_CAPTURE_BYTES`], not hex text.
    pub fn read(&self, stdin: &mut dyn Read) -> Result<Vec<u8>, CaptureInputError> {
        for (given, flag, parse) in [
            (
                self.hex,
                "--hex",
                text::parse_hex as fn(&str, &str) -> Result<Vec<u8>, String>,
            ),
            (self.ascii, "--ascii", text::parse_ascii),
        ] {
            if let Some(t) = given {
                if self.raw {
                    return Err(CaptureInputError::RawNotFile(flag));
                }
                return parse(t, flag).map_err(CaptureInputError::Parse);
            }
        }
        let Some(file) = self.file else {
            return Err(CaptureInputError::Nothing);
        };
        let (bytes, name) = if file.as_os_str() == "-" {
            let name = "<stdin>".to_string();
            let mut b = Vec::new();
            stdin
                .take(MAX_CAPTURE_BYTES + 1)
                .read_to_end(&mut b)
                .map_err(CaptureInputError::Stdin)?;
            if b.len() as u64 > MAX_CAPTURE_BYTES {
                return Err(CaptureInputError::TooLarge { name });
            }
            (b, name)
        } else {
            let name = file.display().to_string();
            let b = read_input(file, InputKind::CAPTURE).map_err(|e| match e.kind {
                InputErrorKind::TooLarge => CaptureInputError::TooLarge { name: name.clone() },
                _ => CaptureInputError::File {
                    message: e.message,
                    help: e.help,
                },
            })?;
            (b, name)
        };
        if self.raw {
            return Ok(bytes);
        }
        let text = String::from_utf8(bytes).map_err(|e| CaptureInputError::NotText {
            name: name.clone(),
            at: e.utf8_error().valid_up_to(),
        })?;
        text::parse_hex(&text, &name).map_err(CaptureInputError::Parse)
    }
}

/// A schema given for a capture of another protocol or LUSTBUS family.
#[derive(Debug, thiserror::Error)]
#[error("schema {schema} is for another protocol or family than the capture")]
pub struct SchemaMisfit {
    /// The schema's id.
    pub schema: String,
}

impl Context {
    /// The context a capture of `format` is decoded in: `schema` if given
    /// and it fits (LECOM and slcan carry one family each; a LUSTBUS
    /// schema's dialect must be `family` when that is given, and becomes
    /// the family), else for LECOM and slcan the built-in schema of their
    /// one family from `registry` (LUSTBUS picks per telegram, from the
    /// CODE's dialect).
    ///
    /// # Errors
    /// [`SchemaMisfit`]: `schema` is of another protocol or family.
    pub fn fitted(
        format: Capture,
        family: Option<Dialect>,
        schema: Option<Arc<Schema>>,
        registry: Registry,
    ) -> Result<Context, SchemaMisfit> {
        let only = format.bus().only_family();
        let (schema, family) = match schema {
            Some(s) => {
                // the schema's LUSTBUS dialect, where it has one (its descriptor's)
                let dialect = s.family.descriptor().dialect;
                match format {
                    Capture::Lecom | Capture::Slcan if only == Some(s.family) => (Some(s), family),
                    Capture::Lustbus
                        if dialect.is_some() && (family.is_none() || family == dialect) =>
                    {
                        (Some(s), dialect)
                    }
                    _ => {
                        return Err(SchemaMisfit {
                            schema: s.id.clone(),
                        });
                    }
                }
            }
            None => match format {
                Capture::Lecom | Capture::Slcan => (
                    only.and_then(|f| registry.get(f.descriptor().schema_id)),
                    family,
                ),
                Capture::Lustbus => (None, family),
            },
        };
        Ok(Context {
            registry,
            schema,
            family,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn given(hex: Option<&str>, ascii: Option<&str>, file: Option<&str>, raw: bool) -> Vec<u8> {
        CaptureGiven {
            hex,
            ascii,
            file: file.map(Path::new),
            raw,
        }
        .read(&mut std::io::empty())
        .expect("reads")
    }

    fn refused(g: CaptureGiven<'_>, stdin: &mut dyn Read) -> String {
        g.read(stdin).expect_err("refused").to_string()
    }

    #[test]
    fn hex_ascii_and_stdin_read_as_given() {
        assert_eq!(
            given(Some("04 40 0x30"), None, None, false),
            [4, 0x40, 0x30]
        );
        assert_eq!(given(None, Some("<EOT>@0"), None, false), [4, b'@', b'0']);
        let mut stdin: &[u8] = b"04 05 # comment\n";
        let g = CaptureGiven {
            file: Some(Path::new("-")),
            ..CaptureGiven::default()
        };
        assert_eq!(g.read(&mut stdin).expect("hex text"), [4, 5]);
        let mut stdin: &[u8] = &[0xff, 0x04];
        let raw = CaptureGiven { raw: true, ..g };
        assert_eq!(raw.read(&mut stdin).expect("raw"), [0xff, 0x04]);
    }

    #[test]
    fn every_refusal_says_what_to_give() {
        let none = &mut std::io::empty();
        let hex = CaptureGiven {
            hex: Some("04"),
            raw: true,
            ..CaptureGiven::default()
        };
        assert_eq!(refused(hex, none), "--raw applies to FILE, not to --hex");
        let ascii = CaptureGiven {
            ascii: Some("x"),
            raw: true,
            ..CaptureGiven::default()
        };
        assert_eq!(
            refused(ascii, none),
            "--raw applies to FILE, not to --ascii"
        );
        assert!(refused(CaptureGiven::default(), none).starts_with("no capture given: pass --hex"));
        let bad = CaptureGiven {
            hex: Some("zz"),
            ..CaptureGiven::default()
        };
        assert!(refused(bad, none).starts_with("--hex"));
        let stdin = CaptureGiven {
            file: Some(Path::new("-")),
            ..CaptureGiven::default()
        };
        let mut binary: &[u8] = &[b'0', b'4', 0xff];
        assert_eq!(
            refused(stdin, &mut binary),
            "<stdin>: byte 2 is not text; is this a binary capture? pass --raw"
        );
        let mut endless = std::io::repeat(b'0');
        assert!(refused(stdin, &mut endless).starts_with(&format!(
            "<stdin>: the capture is larger than {MAX_CAPTURE_BYTES} bytes"
        )));
    }

    #[test]
    fn a_schema_fits_its_protocol_and_family_or_is_refused() {
        let registry = Registry::builtin().expect("built-in schemas");
        let get = |id: &str| registry.get(id).expect("built in");
        // LECOM and slcan: their one family's built-in schema by default
        let c = Context::fitted(Capture::Lecom, None, None, registry.clone()).expect("fits");
        assert_eq!(c.schema.map(|s| s.id.clone()).as_deref(), Some("lenze-tmd"));
        let c = Context::fitted(Capture::Slcan, None, None, registry.clone()).expect("fits");
        assert_eq!(c.schema.map(|s| s.id.clone()).as_deref(), Some("lenze-ecs"));
        // LUSTBUS: the schema's dialect becomes the family
        let c = Context::fitted(
            Capture::Lustbus,
            None,
            Some(get("lust-vf1000")),
            registry.clone(),
        )
        .expect("fits");
        assert_eq!(c.family, Some(Dialect::Vf1000));
        let c = Context::fitted(Capture::Lustbus, Some(Dialect::Mc), None, registry.clone())
            .expect("fits");
        assert!(c.schema.is_none() && c.family == Some(Dialect::Mc));
        // another family or protocol
        for (format, family, id) in [
            (Capture::Lustbus, Some(Dialect::Mc), "lust-vf1000"),
            (Capture::Lustbus, None, "lenze-tmd"),
            (Capture::Lecom, None, "lust-mc6000"),
            (Capture::Slcan, None, "lenze-tmd"),
        ] {
            let e = Context::fitted(format, family, Some(get(id)), registry.clone())
                .expect_err("misfit");
            assert_eq!(e.schema, id);
        }
    }
}
