//! `driveset schema import FILE.eds|FILE.dcf [-o OUT] [--id ID]`: a Lenze
//! ECS schema from the CiA 306 data sheet shipped for the axis
//! (driveset_schema::eds; docs/file-formats.md, "Imported schemas"), with a
//! lint for every object skipped or downgraded (what it says on stderr:
//! `driveset_report::import`).

use driveset_schema::input::{InputKind, read_input};
use std::path::PathBuf;

use driveset_report::import::Form;
use driveset_schema::eds::{ImportOptions, import};

use crate::output;
use crate::output::OutputFormat;

/// Arguments of `driveset schema import`.
#[derive(clap::Args)]
#[command(after_help = "\
Reads a CiA 306 EDS or DCF and writes a schema for the Lenze ECS family
(protocol lenze-can-sdo): Lenze codes at index 24575 - code (0x2000..0x5FFF)
as FIX32 (value x 10000), C0135 / C0150 as BITCODED, strings as VS;
subindexes as subcodes; AccessType ro/const -> ro, rw/rwr/rww -> rw;
LowLimit / HighLimit / DefaultValue as exact engineering values. CiA 301
objects (0x1000..0x1FFF, 0x6000..) are kept by index (`index = 0x1017`,
number 65536 + index, set key C69655 or the name). The schema passes
`driveset schema check`; load it with `--schemas DIR` or name it by path.

Every object skipped or downgraded (PDO / SDO channel objects, DOMAIN,
write-only, $NODEID or empty values, types a Lenze code cannot have, ...) is
a lint on stderr: FILE:LINE: OBJECT: what was done. With --format json the
lints are one JSON document on stderr.

Exit codes: 0 imported without lints, 1 imported with lints (the schema is
written), 2 the file is unreadable or not an EDS / DCF (with its location).

Examples:
  driveset schema import tests/data/eds/fictional-ecs-axis.eds -o schemas-local/axis.toml
  driveset pull --port slcan:///dev/ttyACM0 --address 1 --schema schemas-local/axis.toml -o axis.toml")]
pub struct Args {
    /// The EDS or DCF file.
    #[arg(value_name = "FILE")]
    pub file: PathBuf,
    /// Write the schema here instead of stdout.
    #[arg(short = 'o', long = "output", value_name = "OUT")]
    pub output: Option<PathBuf>,
    /// Schema id (default: the file name without extension, lowercase; an
    /// id starting with `fictional-` makes a fixture schema).
    #[arg(long, value_name = "ID")]
    pub id: Option<String>,
    /// Format of the lint report on stderr.
    #[arg(long, value_parser = output::formats(output::BUS_FORMATS), default_value = "human")]
    pub format: OutputFormat,
}

/// Run `driveset schema import`.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    if let Some(out) = &args.output {
        crate::files::check_output("-o", out)?;
    }
    let shown = args.file.display().to_string();
    // regular files only, size checked before reading (a FIFO or
    // /dev/zero is refused at once)
    let bytes = match read_input(&args.file, InputKind::EDS) {
        Ok(b) => b,
        Err(e) => {
            return Err(crate::fail::Fail::input(format!(
                "{}\n  = help: {}",
                e.message, e.help
            )));
        }
    };
    let opts = ImportOptions {
        id: args.id.clone(),
        file: shown.clone(),
    };
    let form = match args.format {
        OutputFormat::Json => Form::Json,
        // `human`, the other value import takes
        _ => Form::Human,
    };
    let imported = match import(&bytes, &opts) {
        Ok(i) => i,
        Err(e) => {
            eprint!("{}", driveset_report::import::refused(&e, &shown, form));
            return Err(crate::fail::Fail::reported(crate::EXIT_INPUT));
        }
    };
    if let Some(out) = &args.output {
        crate::files::write_output("-o", out, imported.toml.as_bytes())?;
    } else {
        output::emit(&imported.toml);
    }
    eprint!(
        "{}",
        driveset_report::import::imported(&imported, &shown, args.output.as_deref(), form)
    );
    Ok(if imported.lints.is_empty() {
        crate::EXIT_OK
    } else {
        crate::EXIT_FINDINGS
    })
}
