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
//! and, like stdin, at most `driveset_engine::decode::MAX_CAPTURE_BYTES` (16 MiB); hex text is
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

use std::path::PathBuf;

use clap::ValueEnum as _;
use driveset_engine::decode::{CaptureGiven, Context};

use crate::args::LustFamilyArg as FamilyArg;
use crate::fail::Fail;
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

/// Runs `driveset decode`.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    let given = CaptureGiven {
        hex: args.hex.as_deref(),
        ascii: args.ascii.as_deref(),
        file: args.file.as_deref(),
        raw: args.raw,
    };
    let capture = given
        .read(&mut std::io::stdin().lock())
        .map_err(|e| Fail::input(e.to_string()))?;
    let mut registry = builtin_registry()?;
    if args.family.is_some() && args.protocol != DecodeProtocol::Lustbus {
        return Err(Fail::input("--family applies to --protocol lustbus only"));
    }
    let schema = match &args.schema {
        Some(s) => Some(load_schema(&mut registry, s).map_err(|e| Fail::input(format!("{e:#}")))?),
        None => None,
    };
    let family = args.family.map(FamilyArg::dialect);
    let ctx = Context::fitted(args.protocol.capture(), family, schema, registry).map_err(|e| {
        Fail::input(format!(
            "--schema {}: schema {} is for another protocol or family than --protocol {}{}",
            args.schema.as_deref().unwrap_or(""),
            e.schema,
            args.protocol
                .to_possible_value()
                .map(|v| v.get_name().to_string())
                .unwrap_or_default(),
            args.family
                .map(|f| format!(" --family {}", f.0.name()))
                .unwrap_or_default()
        ))
    })?;
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
