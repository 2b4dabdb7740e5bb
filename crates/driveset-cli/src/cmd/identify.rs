//! `driveset identify --port P --address A [--schema ID|PATH | --protocol P]`:
//! what the drive at an address says it is (family, TYPE / identification
//! codes, software version) and whether the schema fits it.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use driveset_engine::client::DriveClient;
use driveset_engine::error::LinkFailure;
use driveset_engine::session;
use driveset_proto::lustbus::Dialect;
use driveset_schema::{Family, Learning};

use crate::output::{self, OutputFormat};
use crate::port::{self, Fail};
use crate::port_args::{LearnFlags, Need, Port, PortCommand, SchemaCount, Takes};
use crate::{EXIT_FINDINGS, EXIT_OK};

/// Arguments of `driveset identify`.
#[derive(clap::Args)]
#[command(after_help = "\
The protocol comes from --schema, else from
--protocol (with its built-in schema: lustbus -> lust-mc6000 or lust-vf1000,
told apart by whether the drive answers an MC6000/7000 CODE, lecom ->
lenze-tmd, sdo -> lenze-ecs), else from read-only probes as scan does
(LUSTBUS ENQUIRY of 91-TYPE, LECOM RECEIVE of C0093 / C0200; a CAN port
speaks lenze-ecs), the same on every port, sim:// too. `uses:` says
which schema pull / diff / upload would talk with and whether it is learned
from the drive's descriptions (a learned-<family>-type<TYPE>-... file in
--schema-dir, or learned on the next pull). Nothing is written to the drive.

Exit codes: 0 identified and the schema fits, 1 identified but the schema
does not fit (another family or TYPE), 2 usage or input error, 3 bus or
device failure (no answer, ...).

Examples:
  driveset identify --port sim://mc6000?addresses=1 --address 1
  driveset identify --port /dev/ttyUSB0?baud=9600 --address 3 --protocol lecom
  driveset identify --port tcp://10.0.0.7:4001 --address 1 --schema lust-vf1000 --format json")]
pub struct Args {
    /// The port, the address, the schema and where learned schemas are
    /// looked for (default: the current directory).
    #[command(flatten)]
    pub at: Port<Args>,
    /// Output format.
    #[arg(long, value_parser = output::formats(output::BUS_FORMATS), default_value = "human")]
    pub format: OutputFormat,
}

impl PortCommand for Args {
    const TAKES: Takes = Takes {
        port: Need::Required,
        address: Need::Required,
        schema: SchemaCount::One,
        schemas: true,
        protocol: Need::Optional,
        learn: LearnFlags::Dir,
        ..Takes::NONE
    };
}

/// Run `driveset identify`.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    identify(&args)
}

fn identify(args: &Args) -> Result<u8, Fail> {
    let address = args.at.address()?;
    let (mut opened, resolved) = args.at.open_resolved(address)?;
    let (choice, note) = (resolved.choice, resolved.evidence);
    let port_name = opened.name.clone();
    let schema = choice.schema;
    // A LUSTBUS schema named: the drive's own family by the read-only
    // probes, as when none is named; another family is the finding (exit
    // 1), the same on every port.
    let mut other = None;
    if note.is_none() && schema.family.descriptor().dialect.is_some() {
        let (found, evidence) = session::detect(
            &mut opened.link,
            &port_name,
            address,
            opened.connect.latency,
        )?;
        other = driveset_engine::identify::other_family(found, &evidence, schema.family);
    }
    let mut client = port::into_client(opened, schema.clone(), address)?;
    report(
        args,
        &port_name,
        client.as_mut(),
        note,
        choice.path.as_deref(),
        other,
    )
}

/// Which schema a bus command would talk with, and whether it is learned:
/// a learned schema named (`learned-...`), a learned file of this drive's
/// family and TYPE in the schema directory, or the schema as it is /
/// learned from the drive when a command needs it.
fn learned_status(
    schema: &driveset_schema::Schema,
    identity: &driveset_engine::client::Identity,
    path: Option<&Path>,
    dir: &Path,
) -> (String, bool, Option<PathBuf>) {
    if (schema.learned.is_some() || Learning::is_learned_id(&schema.id))
        && !driveset_engine::learn::needs_learning(schema)
    {
        return (schema.id.clone(), true, path.map(Path::to_path_buf));
    }
    if !driveset_engine::learn::needs_learning(schema) {
        return (schema.id.clone(), false, None);
    }
    // The descriptor's learned-file scheme (a schema that needs learning is
    // of a family that has one; any other is looked for as an MC file, as
    // before). The TYPE is slugged as the learned file's name holds it
    // (`Learning::file_prefix`, the slug of `Learning::file_id`).
    let d = Some(schema.family.descriptor())
        .filter(|d| d.learning.is_some())
        .unwrap_or_else(|| Family::from_dialect(Dialect::Mc).descriptor());
    let ty = identity
        .value_of(d.device_type_code())
        .map(ToString::to_string);
    let prefix = d
        .learning
        .map(|l| l.file_prefix(ty.as_deref()))
        .unwrap_or_default();
    let mut found: Vec<PathBuf> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with(&prefix) && n.ends_with(".toml"))
        })
        .collect();
    found.sort();
    match found.pop() {
        Some(f) => (
            f.file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or_default()
                .to_string(),
            true,
            Some(f),
        ),
        None => (format!("{prefix}*"), true, None),
    }
}

/// `identify --format json`'s document (keys in alphabetical order, as
/// it always had them).
#[derive(serde::Serialize)]
struct IdentifyDoc<'a> {
    address: Option<u8>,
    codes: Vec<output::CodeValue<'a>>,
    fits: bool,
    learned: bool,
    learned_file: Option<String>,
    note: Option<String>,
    port: &'a str,
    protocol: &'a str,
    reason: Option<&'a String>,
    schema: &'a str,
    schema_title: &'a str,
    software: &'a Option<String>,
    would_use: &'a str,
}

fn report(
    args: &Args,
    port_name: &str,
    client: &mut dyn DriveClient,
    mut note: Option<String>,
    path: Option<&Path>,
    other_family: Option<String>,
) -> Result<u8, Fail> {
    let schema = client.schema().clone();
    let identity = match client.identify() {
        Ok(i) => i,
        // A servo that activates rates online may have been left at a
        // transfer rate (--transfer-baud): search every rate (LUSTBUS 5.1).
        Err(e)
            if matches!(e.link_failure(), Some(LinkFailure::NoAnswer { .. }))
                && schema.family.descriptor().line_rates.online.is_some() =>
        {
            let port_rate = client.line_rate().unwrap_or(0);
            match driveset_engine::transfer::search(client, &[])? {
                Some(r) => {
                    note = Some(format!(
                        "the drive answers at {r} baud, not at the port's {port_rate} (left at a transfer rate by an interrupted --transfer-baud? `driveset recover JOURNAL` switches it back; or add ?baud={r} to the port)"
                    ));
                    client.identify()?
                }
                None => return Err(e.into()),
            }
        }
        Err(e) => return Err(e.into()),
    };
    let dir = args
        .at
        .learn
        .schema_dir
        .clone()
        .unwrap_or_else(|| PathBuf::from("."));
    let (would_use, learned, learned_file) = learned_status(&schema, &identity, path, &dir);
    let fits = match (
        other_family,
        driveset_engine::identify::check_family(client),
    ) {
        (Some(other), _) => Err(other),
        (None, Ok(_)) => Ok(()),
        (None, Err(e)) => match e.refusal() {
            Some(refusal) => Err(refusal.to_string()),
            None => return Err(e.into()),
        },
    };
    client.finish()?;
    match args.format {
        OutputFormat::Json => {
            let doc = IdentifyDoc {
                address: args.at.address,
                codes: identity.codes.iter().map(output::CodeValue::of).collect(),
                fits: fits.is_ok(),
                learned,
                learned_file: learned_file.as_ref().map(|p| p.display().to_string()),
                note,
                port: port_name,
                protocol: identity.protocol.name(),
                reason: fits.as_ref().err(),
                schema: &schema.id,
                schema_title: &schema.title,
                software: &identity.software,
                would_use: &would_use,
            };
            output::emit(&format!(
                "{}\n",
                serde_json::to_string_pretty(&doc).unwrap_or_default()
            ));
        }
        // `human`, the other value a bus command takes
        _ => {
            let mut out = String::new();
            let _ = writeln!(out, "port:     {port_name}");
            let _ = writeln!(out, "address:  {}", args.at.address()?);
            let _ = writeln!(out, "family:   {}", identity.protocol);
            for c in &identity.codes {
                let _ = writeln!(out, "{}: {}", c.name, c.value);
            }
            let _ = writeln!(
                out,
                "software: {}",
                identity.software.as_deref().unwrap_or("(not reported)")
            );
            match &fits {
                Ok(()) => {
                    let _ = writeln!(out, "schema:   {} (fits)", schema.id);
                }
                Err(r) => {
                    let _ = writeln!(out, "schema:   {} does NOT fit: {r}", schema.id);
                }
            }
            let learned_text = match (&learned_file, learned, schema.id == would_use) {
                (_, false, _) => format!("{would_use} (not learned: the schema gives every fact)"),
                (Some(f), true, _) => format!("{would_use} (learned, {})", f.display()),
                (None, true, true) => format!("{would_use} (learned)"),
                (None, true, false) => format!(
                    "{would_use} (learned from the drive's descriptions on pull / diff / upload; {} lacks types and ranges)",
                    schema.id
                ),
            };
            let _ = writeln!(out, "uses:     {learned_text}");
            if let Some(n) = &note {
                let _ = writeln!(out, "note:     {n}");
            }
            output::emit(&out);
        }
    }
    Ok(if fits.is_ok() { EXIT_OK } else { EXIT_FINDINGS })
}

#[cfg(test)]
mod tests {
    use driveset_engine::client::{IdentCode, IdentProtocol, IdentValue, Identity};
    use driveset_schema::{CodeKey, Registry};

    use super::*;

    /// A drive whose TYPE has characters a file name does not keep (`MC
    /// 6000/A`) finds the learned file the engine named for it
    /// (`learned-mc6000-typeMC6000A-...`): the search slugs the TYPE as
    /// the learned id does.
    #[test]
    fn a_type_with_spaces_and_a_slash_finds_its_learned_file() {
        let reg = Registry::builtin().expect("built-in schemas");
        let schema = reg.get("lust-mc6000").expect("mc6000");
        assert!(driveset_engine::learn::needs_learning(&schema));
        let d = schema.family.descriptor();
        let ty = "MC 6000/A";
        let mut identity = Identity::of(IdentProtocol::Family(schema.family));
        identity.codes.push(IdentCode::new(
            CodeKey::new(d.device_type_code()),
            "91-TYPE",
            IdentValue::Text(ty.into()),
        ));
        let id = d
            .learned_id(Some(ty), None, 0x1234)
            .expect("a learning family");
        assert_eq!(id, "learned-mc6000-typeMC6000A-d00001234");
        let dir = tempfile::tempdir().expect("tmp");
        let file = dir.path().join(format!("{id}.toml"));
        std::fs::write(&file, "").expect("write");
        let (uses, learned, found) = learned_status(&schema, &identity, None, dir.path());
        assert_eq!(
            (uses.as_str(), learned, found.as_deref()),
            (id.as_str(), true, Some(file.as_path()))
        );
        // none there: the pattern it would be found by, slugged the same way
        std::fs::remove_file(&file).expect("remove");
        let (uses, _, found) = learned_status(&schema, &identity, None, dir.path());
        assert_eq!(
            (uses.as_str(), found),
            ("learned-mc6000-typeMC6000A-*", None)
        );
    }
}
