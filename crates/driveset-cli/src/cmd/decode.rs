//! `driveset decode`: annotate a captured bus byte stream telegram by
//! telegram.
//!
//! ```text
//! driveset decode --protocol lustbus|lecom|slcan [--family vf1000|mc6000]
//!                 [--schema ID_OR_PATH] [--format text|json]
//!                 (--hex "04 40 30 ..." | --ascii "<EOT>@00112<ENQ>" | FILE [--raw])
//! ```
//!
//! Input: `--hex` bytes on the command line; `--ascii` the escaped form
//! `driveset encode` prints; or FILE (`-` = stdin) holding hex text
//! (whitespace, `,`, `0x` prefixes and `#` comments allowed) or, with
//! `--raw`, the bytes themselves. Bad input names line:column and exits 2.
//! FILE must be a regular file (a FIFO or device is refused, never opened)
//! and, like stdin, at most [`MAX_CAPTURE_BYTES`] (16 MiB); hex text is
//! parsed in one linear pass.
//!
//! Output: one line per event (telegram, reply, skipped garbage, slcan line):
//! byte range `start..end` (end exclusive), direction, kind, then address,
//! code (with its schema name), value as sent `=` value in engineering units,
//! BCC, and what it means; detail lines (SIOF bits, C0068 fields) follow
//! indented. `--format json` prints one JSON object per line with the same
//! fields plus the bytes.
//!
//! Schemas: `--schema` (a built-in id or a file); else LECOM uses
//! `lenze-tmd`, slcan `lenze-ecs`, LUSTBUS the schema of `--family`, or the
//! family the CODE layout shows (`20ppp` MC6000/7000, `00dpp` VF1000; the
//! shared codes 81..85, 91 keep the family seen last).
//!
//! LECOM: the decoder follows each controller's C0249 code bank and C0248
//! input selection as the capture writes them (8.B, 8.C). Replies the specs
//! rule out are bad telegrams: an answer to LUSTBUS address 31 (§4.2, §9.1),
//! a reply from another LUSTBUS address than the one asked (§3), any reply
//! to a LECOM broadcast or group address (8.J).
//!
//! Exit codes: 0 every byte decoded; 1 the capture holds bad telegrams
//! (garbage, BCC mismatch, malformed or cut-off frames, replies that cannot
//! occur); 2 usage or input error.

use std::io::Read as _;
use std::path::PathBuf;

use anyhow::{Context as _, bail};
use driveset_engine::decode::Context;
use driveset_proto::text;

use crate::args::LustFamilyArg as FamilyArg;
use crate::offline::{DecodeProtocol, builtin_registry, load_schema};
use crate::output::OutputFormat;
use crate::{EXIT_FINDINGS, EXIT_OK};

#[derive(clap::Args)]
#[command(after_help = "\
Examples:
  driveset decode --protocol lustbus --hex \"04 40 30 30 31 31 32 05\"
  driveset decode --protocol lecom --ascii \"<EOT>34<STX>1195.2<ETX><13>\"
  driveset decode --protocol slcan --ascii \"t601823F45F0020A10700<CR>\"
  driveset decode --protocol lustbus --family mc6000 capture.hex
  driveset decode --protocol lustbus --raw --format json capture.bin

Each line: byte range (end exclusive), direction, kind, address, code (schema name),
value as sent = engineering value, BCC, meaning; details indented below.

LECOM: C0249 (code bank) and C0248 (input selection) writes in the capture are
followed, so a standard-addressed code names what the drive reads (8.B, 8.C).
Replies that cannot occur are bad telegrams: an answer to LUSTBUS address 31, a
reply from another address than the one asked, a reply to a LECOM broadcast or
group address.

FILE must be a regular file; FILE and stdin are read up to 16 MiB.

Exit codes: 0 every byte decoded, 1 the capture holds bad telegrams (garbage, BCC
mismatch, malformed or cut-off frames, replies that cannot occur), 2 usage or
input error.")]
pub struct Args {
    /// Bus protocol of the capture.
    #[arg(long, value_enum)]
    pub protocol: DecodeProtocol,
    /// LUSTBUS device family (value syntax and schema); guessed from the CODEs if not given.
    #[arg(long, value_enum)]
    pub family: Option<FamilyArg>,
    /// Schema for names, types and units: a built-in id (lust-vf1000, lust-mc6000,
    /// lenze-tmd, lenze-ecs) or a schema file.
    #[arg(long, value_name = "ID_OR_PATH")]
    pub schema: Option<String>,
    /// The capture as hex bytes, e.g. "04 40 30 30 31 31 32 05".
    #[arg(long, conflicts_with_all = ["ascii", "file"])]
    pub hex: Option<String>,
    /// The capture in escaped ASCII, e.g. "<EOT>@00112<ENQ>" (<xx> = any byte in hex).
    #[allow(rustdoc::invalid_html_tags)] // clap's help text, printed as written
    #[arg(long, conflicts_with_all = ["hex", "file"])]
    pub ascii: Option<String>,
    /// FILE holds the raw bytes (default: hex text).
    #[arg(long)]
    pub raw: bool,
    /// Output format.
    #[arg(long, value_parser = crate::output::formats(crate::output::DECODE_FORMATS), default_value = "text")]
    pub format: OutputFormat,
    /// Capture file (hex text, or bytes with --raw); `-` reads stdin.
    #[arg(value_name = "FILE")]
    pub file: Option<PathBuf>,
}

/// The most bytes `decode` reads from a file or stdin (16 MiB: at 57600
/// baud that is 48 minutes of traffic), so `--raw -` fed from an endless
/// stream ends with an error instead of filling memory.
pub const MAX_CAPTURE_BYTES: u64 = driveset_schema::input::InputKind::CAPTURE.cap;

fn read_input(args: &Args) -> anyhow::Result<Vec<u8>> {
    if let Some(h) = &args.hex {
        if args.raw {
            bail!("--raw applies to FILE, not to --hex");
        }
        return text::parse_hex(h, "--hex").map_err(anyhow::Error::msg);
    }
    if let Some(a) = &args.ascii {
        if args.raw {
            bail!("--raw applies to FILE, not to --ascii");
        }
        return text::parse_ascii(a, "--ascii").map_err(anyhow::Error::msg);
    }
    let Some(file) = &args.file else {
        bail!(
            "no capture given: pass --hex \"04 40 ...\", --ascii \"<EOT>...\", a FILE, or - for stdin"
        );
    };
    let (bytes, name) = if file.as_os_str() == "-" {
        let mut b = Vec::new();
        std::io::stdin()
            .lock()
            .take(MAX_CAPTURE_BYTES + 1)
            .read_to_end(&mut b)
            .context("cannot read stdin")?;
        if b.len() as u64 > MAX_CAPTURE_BYTES {
            bail!(
                "<stdin>: the capture is larger than {MAX_CAPTURE_BYTES} bytes, the most `driveset decode` reads; split it (e.g. with `split -b`) and decode the parts"
            );
        }
        (b, "<stdin>".to_string())
    } else {
        let b = driveset_schema::input::read_input(file, driveset_schema::input::InputKind::CAPTURE)
        .map_err(|e| match e.kind {
            driveset_schema::InputErrorKind::TooLarge => anyhow::anyhow!(
                "{}: the capture is larger than {MAX_CAPTURE_BYTES} bytes, the most `driveset decode` reads; split it (e.g. with `split -b`) and decode the parts",
                file.display()
            ),
            _ => anyhow::anyhow!("{}; {}", e.message, e.help),
        })?;
        (b, file.display().to_string())
    };
    if args.raw {
        return Ok(bytes);
    }
    let text = String::from_utf8(bytes).map_err(|e| {
        anyhow::anyhow!(
            "{name}: byte {} is not text; is this a binary capture? pass --raw",
            e.utf8_error().valid_up_to()
        )
    })?;
    text::parse_hex(&text, &name).map_err(anyhow::Error::msg)
}

/// Runs `driveset decode`.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    let capture = match read_input(&args) {
        Ok(c) => c,
        Err(e) => {
            return Err(crate::fail::Fail::input(format!("{e:#}")));
        }
    };
    let mut registry = builtin_registry()?;
    let family = args.family.map(FamilyArg::dialect);
    if args.family.is_some() && args.protocol != DecodeProtocol::Lustbus {
        return Err(crate::fail::Fail::input(
            "--family applies to --protocol lustbus only",
        ));
    }
    let mut schema = match &args.schema {
        Some(s) => match load_schema(&mut registry, s) {
            Ok(s) => Some(s),
            Err(e) => {
                return Err(crate::fail::Fail::input(format!("{e:#}")));
            }
        },
        None => None,
    };
    let mut family = family;
    if let Some(s) = &schema {
        // the schema's LUSTBUS dialect, where it has one (its descriptor's)
        let schema_family = s.family.descriptor().dialect;
        let fits = match args.protocol {
            // LECOM and slcan carry one family each (Tmd, ECS)
            DecodeProtocol::Lecom | DecodeProtocol::Slcan => {
                args.protocol.capture().bus().only_family() == Some(s.family)
            }
            DecodeProtocol::Lustbus => {
                schema_family.is_some() && (family.is_none() || family == schema_family)
            }
        };
        if fits && args.protocol == DecodeProtocol::Lustbus {
            family = schema_family;
        }
        if !fits {
            return Err(crate::fail::Fail::input(format!(
                "--schema {}: schema {} is for another protocol or family than --protocol {}{}",
                args.schema.as_deref().unwrap_or(""),
                s.id,
                match args.protocol {
                    DecodeProtocol::Lustbus => "lustbus",
                    DecodeProtocol::Lecom => "lecom",
                    DecodeProtocol::Slcan => "slcan",
                },
                args.family
                    .map(|f| format!(" --family {}", f.0.name()))
                    .unwrap_or_default()
            )));
        }
    } else {
        // LECOM and slcan carry one family each: its built-in schema (LUSTBUS
        // picks per telegram, from the CODE's dialect)
        schema = match args.protocol {
            DecodeProtocol::Lecom | DecodeProtocol::Slcan => args
                .protocol
                .capture()
                .bus()
                .only_family()
                .and_then(|f| registry.get(f.descriptor().schema_id)),
            DecodeProtocol::Lustbus => None,
        };
    }
    let ctx = Context {
        registry,
        schema,
        family,
    };
    // each event is written out as it is decoded, in chunks of
    // OUT_CHUNK: memory grows with one event, not with the capture
    const OUT_CHUNK: usize = 64 * 1024;
    let (mut out, mut any, mut bad) = (String::new(), false, false);
    driveset_engine::decode::decode_each(args.protocol.capture(), &capture, &ctx, &mut |e| {
        any = true;
        bad |= e.error.is_some();
        match args.format {
            // serializing strings and integers cannot fail
            OutputFormat::Json => out.push_str(&serde_json::to_string(&e).unwrap_or_default()),
            _ => out.push_str(&e.render_text()),
        }
        out.push('\n');
        if out.len() >= OUT_CHUNK {
            crate::output::emit(&out);
            out.clear();
        }
    });
    drop(capture);
    if !any && args.format == OutputFormat::Text {
        out.push_str("(no bytes)\n");
    }
    crate::output::emit(&out);
    Ok(if bad { EXIT_FINDINGS } else { EXIT_OK })
}
