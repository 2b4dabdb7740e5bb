//! `driveset schema pull --port P --address A [--family vf1000|mc6000]
//! [--params 1-99 | LIST] -o FILE`: a schema file learned from a LUSTBUS
//! drive's own parameter descriptions. A thin command over
//! `driveset_engine::learn` (which reads the descriptions, units and value
//! substitution texts, tells the description layout and type characters
//! apart, and downgrades descriptions that contradict themselves); the file
//! extends the built-in schema of the family and passes `driveset schema
//! check`. Nothing but the RAM selector 108-STEXT is written, and it is set
//! back to what it held.

use std::fmt::Write as _;
use std::path::PathBuf;

use driveset_engine::learn::{ParamsError, PullSchemaError, params_to_ask, pull_schema};
use driveset_engine::session::Session;

use crate::EXIT_OK;
use crate::output;
use crate::output::OutputFormat;
use crate::port::{self, Fail};
use crate::port_args::{LearnFlags, Need, Port, PortCommand, Takes};

/// Arguments of `driveset schema pull`.
#[derive(clap::Args)]
#[command(after_help = "\
Asks every parameter of the range for its description (a NAK: no such
parameter, skipped) and writes a schema file that extends the family's
built-in schema: the spec's facts stand, the drive's fill in type, unit,
min, max, factory default, storage kind, width, read-only for actual values,
CardWriteable (MC activity area), and on MC6000/7000 the value substitution
texts as [code.values]. Only the RAM selector 108-STEXT is written (and set
back afterwards).

MC6000/7000 descriptions are read in the layout their length and content
say (52, 43, 42 or 34 characters; errata L22) and the type characters in
the reading that fits them (driveset's or section 2.3.2's table order;
errata L23); --description-layout and --type-chars override the guesses. A
description that contradicts itself (minimum above maximum, default outside
the range, bounds the type cannot hold, an unknown type character) is
downgraded, one that does not decode is left out; each is listed with the
reason. Where a description contradicts the built-in schema (another
kind, type, range or unit; an actual value where the spec has a command),
the spec's fact stands, the drive's is recorded as `# drive says:` beside
the code, and a line names the code, both facts and the spec section. The
file's [schema.learned] asked lists the parameters asked for; commands given
the file use it as it is (learning only parameters outside it). Without
--family the family is found by read-only probes.

Exit codes: 0 written, 2 usage or input error, 3 bus or device failure.

Examples:
  driveset schema pull --port sim://mc6000?addresses=1 --address 1 --family mc6000 --params 1-200 -o pulled-mc.toml
  driveset schema pull --port 'sim://mc6000?layout=43&types=table' --address 1 -o mc-43.toml
  driveset schema pull --port /dev/ttyUSB0 --address 2 --family vf1000 -o vf1000-live.toml")]
pub struct Args {
    /// The port, the address and how the descriptions read.
    #[command(flatten)]
    pub at: Port<Args>,
    /// The drive family (decides the description format; default: probed).
    #[arg(long, value_enum)]
    pub family: Option<crate::args::LustFamilyArg>,
    /// Parameters to ask for: ranges and numbers, e.g. `1-99` or `1,5,100-120`
    /// (default VF1000 1-99, MC6000/7000 1-999).
    #[arg(long, value_name = "LIST")]
    pub params: Option<String>,
    /// The schema file to write.
    #[arg(short = 'o', long = "output", value_name = "FILE")]
    pub output: PathBuf,
    /// The schema id to write (default `pulled-<family>-<address>`).
    #[arg(long)]
    pub id: Option<String>,
    /// Output format of the report on stdout.
    #[arg(long, value_parser = output::formats(output::BUS_FORMATS), default_value = "human")]
    pub format: OutputFormat,
}

impl PortCommand for Args {
    const TAKES: Takes = Takes {
        port: Need::Required,
        port_help: "The port.",
        address: Need::Required,
        address_help: "Bus address (1..30).",
        learn: LearnFlags::Reading,
        ..Takes::NONE
    };
}

/// Run `driveset schema pull`.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    // a FIFO or device as -o is refused before the port is opened
    crate::files::check_output("-o", &args.output)?;
    schema_pull(&args)
}

fn schema_pull(args: &Args) -> Result<u8, Fail> {
    let address = args.at.address()?;
    let mut opts = args.at.learn.options()?;
    // the drive's family by the read-only probes (an MC answers its own
    // CODE form of 91-TYPE, a VF1000 NAKs it), on every port; --family
    // names what the user expects, and another family answering is
    // identify's finding (exit 1), nothing written
    let (opened, found) = args.at.open_resolved(address)?;
    let other = args.family.and_then(|f| {
        driveset_engine::identify::other_family(
            found.choice.schema.family,
            found.evidence.as_deref().unwrap_or_default(),
            f.0,
        )
    });
    if let Some(other) = other {
        return Err(Fail {
            code: crate::EXIT_FINDINGS,
            msg: format!(
                "{} address {}: {other}; nothing written (give --family {} or leave it out)",
                opened.name,
                address,
                found.choice.schema.family.name()
            ),
        });
    }
    let base = found.choice.schema;
    let params = params_to_ask(base.family, args.params.as_deref()).map_err(|e| match e {
        ParamsError::NoDescriptions(_) => {
            Fail::input(format!("{} address {address}: {e}", opened.name))
        }
        e => Fail::input(e.to_string()),
    })?;
    opts.params = Some(params.clone());
    port::check_fit(&opened, &base)?;
    let port_name = opened.name.clone();
    let mut client = Session::lustbus(opened, base.clone(), address)?;
    let id = args
        .id
        .clone()
        .unwrap_or_else(|| format!("pulled-{}-{address}", base.family.name()));
    let registry = port::registry(&[])?;
    let pulled = pull_schema(
        &mut client,
        &base,
        &opts,
        Some(&id),
        format!("{port_name} address {}", address),
        &registry,
    )
    .map_err(|e| match e {
        PullSchemaError::Engine(e) => Fail::from(e),
        PullSchemaError::Render(e) => Fail::bus(format!("{port_name} address {}: {e}", address)),
    })?;
    let (rendered, learned) = (pulled.rendered, pulled.learned);
    crate::files::write_output("-o", &args.output, rendered.text.as_bytes())?;

    let report = driveset_engine::session::LearnSummary {
        id: id.clone(),
        file: Some(args.output.clone()),
        base: base.id.clone(),
        codes: rendered.codes,
        learned,
    };
    match args.format {
        OutputFormat::Json => {
            let doc = report.doc().at(&port_name, address, base.family);
            output::emit(&format!(
                "{}\n",
                serde_json::to_string_pretty(&doc).unwrap_or_default()
            ));
        }
        // `human`, the other value a bus command takes
        _ => {
            let mut out = String::new();
            let _ = writeln!(
                out,
                "pulled {} parameter descriptions ({} substitution texts) from {port_name} address {} into {} (schema id {id})",
                rendered.codes,
                report.learned.texts_read,
                address,
                args.output.display()
            );
            let _ = writeln!(
                out,
                "{} of {} parameters asked for are not on the drive (NAK)",
                report.learned.absent,
                params.len()
            );
            for l in report.lines().iter().skip(1) {
                let _ = writeln!(out, "{l}");
            }
            output::emit(&out);
        }
    }
    Ok(EXIT_OK)
}
