//! The schema a bus command talks with when none is given or the given one
//! lacks facts: finding the drive's protocol by read-only probes
//! (`session::detect`, as `scan` does), and learning the schema from a LUSTBUS
//! drive's own descriptions ([`learn`](driveset_engine::learn), driveset-engine's `learn` module)
//! with the options every such command shares ([`LearnArgs`]).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use driveset_engine::client::DriveClient;
use driveset_engine::learn::{LearnOptions, Learned, needs_learning};
use driveset_engine::session::{self, LearnPolicy, LearnStep, Session, SessionPolicy};
use driveset_proto::lustbus::description::{McLayout, McTypeChars};
use driveset_schema::Schema;
use serde_json::json;

use crate::port::{self, Fail, OpenPort};

/// Options of the commands that learn a schema from the drive.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct LearnArgs {
    /// Where a learned schema file is written and looked for (default:
    /// beside the set file for `pull` / `schema pull`; the report
    /// directory for `commission` / `status`).
    #[arg(long, value_name = "DIR")]
    pub schema_dir: Option<PathBuf>,
    /// MC6000/7000: the layout of the drive's parameter descriptions
    /// (default: told by length and content; errata L22).
    #[arg(long, value_name = "52|43|42|34")]
    pub description_layout: Option<String>,
    /// MC6000/7000: how the descriptions' type characters read: `driveset`,
    /// `table` (section 2.3.2 order, '1' = PT_USIGN8 .. '8' = PT_PASSWORD)
    /// or a map `1=PT_USIGN8,2=PT_USIGN16,...` (default: guessed from the
    /// content; errata L23).
    #[arg(long, value_name = "READING")]
    pub type_chars: Option<String>,
    /// Use the schema as it is: do not read the drive's descriptions.
    #[arg(long)]
    pub no_learn: bool,
}

impl LearnArgs {
    /// The engine's options (parameters: the default range).
    pub fn options(&self) -> Result<LearnOptions, Fail> {
        let layout = match &self.description_layout {
            None => None,
            Some(l) => Some(McLayout::from_name(l.trim()).ok_or_else(|| {
                Fail::input(format!(
                    "--description-layout {l}: use 52, 43, 42 or 34 (the lengths errata L22 discusses)"
                ))
            })?),
        };
        let type_chars = match &self.type_chars {
            None => None,
            Some(t) => {
                Some(McTypeChars::parse(t).map_err(|e| Fail::input(format!("--type-chars: {e}")))?)
            }
        };
        Ok(LearnOptions {
            params: None,
            layout,
            type_chars,
            no_texts: false,
        })
    }
}

/// The schema a command on the drive at `address` of `opened` talks
/// with (the engine's one resolution, [`session::Catalog::resolve`]):
/// `--schema`, else `--protocol`'s built-in schema, else the built-in schema
/// of the family the drive answers the read-only probes as, with what
/// answered. The same on every port. The port stays open for the command.
pub fn resolve(
    opened: &mut OpenPort,
    address: u8,
    schema: Option<&str>,
    protocol: Option<port::ProtocolArg>,
    dirs: &[PathBuf],
) -> Result<session::Resolved, Fail> {
    let ask = session::SchemaAsk {
        schema,
        protocol: protocol.map(|p| p.0),
    };
    Ok(port::catalog(dirs).resolve(opened, address, ask)?)
}

/// What learning did, for reports.
#[derive(Debug, Clone)]
pub struct LearnReport {
    /// The learned schema's id.
    pub id: String,
    /// The file written, if any.
    pub file: Option<PathBuf>,
    /// The base schema.
    pub base: String,
    /// Codes learned (in the file).
    pub codes: usize,
    /// What was learned, in detail.
    pub learned: Learned,
}

impl LearnReport {
    /// One line per finding, for stderr / human output.
    pub fn lines(&self) -> Vec<String> {
        let mut out = Vec::new();
        let layouts: Vec<&str> = self.learned.layouts.iter().map(|l| l.name()).collect();
        out.push(format!(
            "learned schema {} from the drive's descriptions: {} codes{}{}{}",
            self.id,
            self.codes,
            self.file
                .as_ref()
                .map_or_else(String::new, |f| format!(", written to {}", f.display())),
            if layouts.is_empty() {
                String::new()
            } else {
                format!(", description layout {}", layouts.join("/"))
            },
            self.learned
                .type_chars
                .as_ref()
                .map_or_else(String::new, |t| format!(
                    ", type characters {}{}",
                    t.name(),
                    if self.learned.type_chars_guessed {
                        " (guessed)"
                    } else {
                        ""
                    }
                ))
        ));
        for f in &self.learned.findings {
            if f.action == KEPT_SPEC {
                // the reason names the code, both facts and the spec
                out.push(f.reason.clone());
            } else {
                out.push(format!("{}: {}: {}", f.code, f.action, f.reason));
            }
        }
        out
    }

    /// JSON for `--format json`.
    pub fn json(&self) -> serde_json::Value {
        json!({
            "id": self.id,
            "file": self.file.as_ref().map(|f| f.display().to_string()),
            "base": self.base,
            "codes": self.codes,
            "layouts": self.learned.layouts.iter().map(|l| l.name()).collect::<Vec<_>>(),
            "type_chars": self.learned.type_chars.as_ref().map(McTypeChars::name),
            "type_chars_guessed": self.learned.type_chars_guessed,
            "asked": self.learned.asked,
            "absent": self.learned.absent,
            "substitution_texts": self.learned.texts_read,
            "findings": self.learned.findings,
        })
    }
}

impl From<session::LearnedReport> for LearnReport {
    fn from(r: session::LearnedReport) -> Self {
        LearnReport {
            id: r.id,
            file: r.file,
            base: r.base,
            codes: r.codes,
            learned: r.learned,
        }
    }
}

/// The action of a finding where the drive contradicts the spec.
const KEPT_SPEC: &str = driveset_engine::learn::KEPT_SPEC;

/// Whether a command should learn: a LUSTBUS schema that lacks facts,
/// unless `--no-learn`.
pub fn wants(schema: &Schema, args: &LearnArgs) -> bool {
    !args.no_learn && needs_learning(schema)
}

/// A drive reached through the engine's session ([`open`]).
pub struct OnDrive {
    /// The client (speaking the schema below).
    pub client: Box<dyn DriveClient>,
    /// The schema it speaks: the learned one, when learning ran.
    pub schema: Arc<Schema>,
    /// What learning did, when it ran.
    pub learned: Option<LearnReport>,
}

/// The drive at `address` of `opened`, speaking `schema` (refused when
/// it does not fit the port, [`session::check_fit`]), through the engine's session: a LUSTBUS schema
/// that lacks facts is learned from the drive's descriptions first
/// (unless `--no-learn`) and the learned schema written to
/// `dir/<id>.toml` when `dir` is given.
pub fn open(
    opened: OpenPort,
    schema: Arc<Schema>,
    address: u8,
    args: &LearnArgs,
    dirs: &[PathBuf],
    dir: Option<&Path>,
) -> Result<OnDrive, Fail> {
    let learning = wants(&schema, args);
    let registry = if learning {
        Some(port::registry(dirs)?)
    } else {
        None
    };
    let policy = SessionPolicy {
        learn: match &registry {
            Some(registry) => Some(LearnPolicy {
                options: args.options()?,
                registry,
                dir: dir.map(Path::to_path_buf),
                env: &crate::env::SystemEnv,
                step: LearnStep::Render,
            }),
            None => None,
        },
    };
    let s = Session::open(opened, schema, address, &policy)?;
    Ok(OnDrive {
        client: s.client,
        schema: s.schema,
        learned: s.learned.map(LearnReport::from),
    })
}

/// A set for a command against one drive, with the client to talk to it:
/// when the set's schema is a LUSTBUS schema that lacks facts, the drive's
/// descriptions are learned first and the set is resolved against the
/// learned schema (written to `--schema-dir` when given).
pub struct SetOnDrive {
    /// The client (speaking the schema below).
    pub client: Box<dyn DriveClient>,
    /// The schema the set resolved against.
    pub schema: Arc<Schema>,
    /// The set.
    pub set: driveset_schema::ResolvedSet,
    /// The port as reports name it.
    pub port_name: String,
}

/// Loads `set` and opens the drive at `address` of `port` for it (see
/// [`SetOnDrive`]). `what` completes the refusal message (`not uploaded`).
pub fn set_on_drive(
    set: &Path,
    dirs: &[PathBuf],
    port_arg: &str,
    address: u8,
    args: &LearnArgs,
    what: &str,
) -> Result<SetOnDrive, Fail> {
    let refused = |code: u8| Fail {
        code,
        msg: format!("{}: {what}", set.display()),
    };
    // The set is read once; a LUSTBUS schema that lacks facts is learned
    // from the drive and the set resolved again against what was learned.
    let registry = port::registry(dirs)?;
    let loaded = driveset_schema::load_set(set, &mut registry.clone())
        .map_err(|e| refused(crate::output::fail_input(&e)))?;
    if let Some(base) = loaded.schema.clone().filter(|s| wants(s, args)) {
        let opened = port::open_port_at(port_arg, Some(address))?;
        let port_name = opened.name.clone();
        let on = open(
            opened,
            base.clone(),
            address,
            args,
            dirs,
            args.schema_dir.as_deref(),
        )?;
        for l in on.learned.iter().flat_map(LearnReport::lines) {
            eprintln!("{l}");
        }
        let (client, schema) = (on.client, on.schema);
        let mut registry = registry;
        registry.insert_as(&base.id, schema.clone());
        let loaded = crate::output::load_valid_set(set, &mut registry).map_err(refused)?;
        let Some(resolved) = loaded.resolved else {
            return Err(refused(crate::EXIT_INPUT));
        };
        return Ok(SetOnDrive {
            client,
            schema,
            set: resolved,
            port_name,
        });
    }
    let loaded = crate::output::valid_set(set, loaded).map_err(refused)?;
    let (Some(schema), Some(resolved)) = (loaded.schema, loaded.resolved) else {
        return Err(refused(crate::EXIT_INPUT));
    };
    let opened = port::open_port_at(port_arg, Some(address))?;
    let port_name = opened.name.clone();
    let client = port::into_client(opened, schema.clone(), address)?;
    Ok(SetOnDrive {
        client,
        schema,
        set: resolved,
        port_name,
    })
}
