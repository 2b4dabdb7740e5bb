//! Owns the one set of port arguments (`--port`, `--address`, `--schema`,
//! `--schemas`, `--protocol`, `--allow-family` and the learning options
//! `--schema-dir`, `--description-layout`, `--type-chars`, `--no-learn`):
//! each flag is defined here once ([`augment`]) and read here once
//! ([`PortArgs::read`]); every command that opens a drive port flattens
//! [`Port<C>`], `C` saying which of them the command takes and which it
//! requires ([`Takes`]), and hands [`PortArgs`] to the engine's one
//! resolver ([`PortArgs::ask`] for [`driveset_engine::session::Catalog::resolve`])
//! (docs/architecture.md, "One path from a port to a drive").

use std::marker::PhantomData;
use std::ops::Deref;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use clap::builder::EnumValueParser;
use clap::{Arg, ArgAction, ArgMatches, Command};
use driveset_engine::learn::LearnOptions;
use driveset_engine::session::{
    self, LearnRequest, OpenedPort, Resolved, SchemaAsk, Session, SetOnDrive, SetOnDriveError,
};
use driveset_schema::Schema;

use crate::args::BusArg;
use crate::fail::Fail;

/// Whether a command takes an argument, and whether it must be given.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Need {
    /// Not taken: the flag does not exist for the command.
    No,
    /// Taken, optional.
    Optional,
    /// Taken, required (clap says so when it is missing).
    Required,
}

/// How many `--schema` a command takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SchemaCount {
    /// None.
    No,
    /// At most one.
    One,
    /// Any number (`address`: one per family it may meet).
    Many,
}

/// Which learning options a command takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LearnFlags {
    /// None.
    No,
    /// `--schema-dir` only (`identify`: where learned files are looked for).
    Dir,
    /// The description layout and type characters (`schema pull`, which
    /// always reads the descriptions).
    Reading,
    /// All of them.
    All,
}

/// Which port arguments a command takes, with their help where the
/// command words it its own way.
#[derive(Debug, Clone, Copy)]
pub struct Takes {
    /// `--port`.
    pub port: Need,
    /// Its help.
    pub port_help: &'static str,
    /// `--address`.
    pub address: Need,
    /// Its help.
    pub address_help: &'static str,
    /// `--port` and `--address` only together (`diff --port`).
    pub together: bool,
    /// `--schema`.
    pub schema: SchemaCount,
    /// Its help.
    pub schema_help: &'static str,
    /// `--schemas DIR`.
    pub schemas: bool,
    /// `--protocol`.
    pub protocol: Need,
    /// Its help.
    pub protocol_help: &'static str,
    /// `--allow-family`.
    pub allow_family: bool,
    /// The learning options.
    pub learn: LearnFlags,
}

impl Takes {
    /// Nothing taken; the helps of the common case.
    pub const NONE: Takes = Takes {
        port: Need::No,
        port_help: "The port (/dev/ttyUSB0?baud=9600, tcp://host:port?latency=80ms, slcan://..., sim://FAMILY?addresses=...).",
        address: Need::No,
        address_help: "Bus address (LUSTBUS 1..30, LECOM 1..99, CAN node id 1..127).",
        together: false,
        schema: SchemaCount::No,
        schema_help: "Schema id or file to talk with (decides the protocol).",
        schemas: false,
        protocol: Need::No,
        protocol_help: "Protocol, when --schema does not say it (default: found by the read-only probes).",
        allow_family: false,
        learn: LearnFlags::No,
    };
}

/// A command's choice of port arguments ([`Takes`]).
pub trait PortCommand {
    /// What the command takes.
    const TAKES: Takes;
}

/// The port arguments as given (fields not taken by the command stay
/// empty).
#[derive(Debug, Clone, Default)]
pub struct PortArgs {
    /// `--port`.
    pub port: Option<String>,
    /// `--address`.
    pub address: Option<u8>,
    /// `--schema ID|PATH` (at most one but for `address`).
    pub schema: Vec<String>,
    /// `--schemas DIR`.
    pub schemas: Vec<PathBuf>,
    /// `--protocol`.
    pub protocol: Option<BusArg>,
    /// `--allow-family`.
    pub allow_family: bool,
    /// The learning options.
    pub learn: LearnArgs,
}

/// The learning options (`--schema-dir`, `--description-layout`,
/// `--type-chars`, `--no-learn`); `commission` and `status`, which reach
/// their drives through a line manifest, flatten these alone.
#[derive(Debug, Clone, Default)]
pub struct LearnArgs {
    /// Where a learned schema file is written and looked for.
    pub schema_dir: Option<PathBuf>,
    /// MC6000/7000: the layout of the drive's parameter descriptions.
    pub description_layout: Option<String>,
    /// MC6000/7000: how the descriptions' type characters read.
    pub type_chars: Option<String>,
    /// Use the schema as it is: do not read the drive's descriptions.
    pub no_learn: bool,
}

/// Adds the arguments `takes` names to `cmd`: the one definition of each.
pub fn augment(cmd: Command, takes: &Takes) -> Command {
    let mut cmd = cmd;
    let need = |a: Arg, n: Need| a.required(n == Need::Required);
    let with = |a: Arg, other: &'static str| {
        if takes.together { a.requires(other) } else { a }
    };
    if takes.port != Need::No {
        cmd = cmd.arg(need(
            with(
                Arg::new("port")
                    .long("port")
                    .value_name("PORT")
                    .help(takes.port_help),
                "address",
            ),
            takes.port,
        ));
    }
    if takes.address != Need::No {
        cmd = cmd.arg(need(
            with(
                Arg::new("address")
                    .long("address")
                    .value_name("ADDRESS")
                    .value_parser(clap::value_parser!(u8))
                    .help(takes.address_help),
                "port",
            ),
            takes.address,
        ));
    }
    if takes.schema != SchemaCount::No {
        let action = if takes.schema == SchemaCount::Many {
            ArgAction::Append
        } else {
            ArgAction::Set
        };
        cmd = cmd.arg(
            Arg::new("schema")
                .long("schema")
                .value_name("ID|PATH")
                .action(action)
                .help(takes.schema_help),
        );
    }
    if takes.schemas {
        cmd = cmd.arg(
            Arg::new("schemas")
                .long("schemas")
                .value_name("DIR")
                .action(ArgAction::Append)
                .value_parser(clap::value_parser!(PathBuf))
                .help("Load every *.toml schema of DIR in addition to the built-in ones (repeatable)."),
        );
    }
    if takes.protocol != Need::No {
        cmd = cmd.arg(need(
            Arg::new("protocol")
                .long("protocol")
                .value_parser(EnumValueParser::<BusArg>::new())
                .help(takes.protocol_help),
            takes.protocol,
        ));
    }
    if takes.allow_family {
        cmd = cmd.arg(
            Arg::new("allow_family")
                .long("allow-family")
                .action(ArgAction::SetTrue)
                .help("Go on even if the drive's identity does not fit the schema."),
        );
    }
    augment_learn(cmd, takes.learn)
}

/// Adds the learning options `flags` names to `cmd`.
fn augment_learn(mut cmd: Command, flags: LearnFlags) -> Command {
    if matches!(flags, LearnFlags::Dir | LearnFlags::All) {
        cmd = cmd.arg(
            Arg::new("schema_dir")
                .long("schema-dir")
                .value_name("DIR")
                .value_parser(clap::value_parser!(PathBuf))
                .help("Where a learned schema file is written and looked for (default: beside the set file for `pull` / `schema pull`; the report directory for `commission` / `status`; the current directory for `identify`)."),
        );
    }
    if matches!(flags, LearnFlags::Reading | LearnFlags::All) {
        cmd = cmd
            .arg(
                Arg::new("description_layout")
                    .long("description-layout")
                    .value_name("52|43|42|34")
                    .help("MC6000/7000: the layout of the drive's parameter descriptions (default: told by length and content; errata L22)."),
            )
            .arg(
                Arg::new("type_chars")
                    .long("type-chars")
                    .value_name("READING")
                    .help("MC6000/7000: how the descriptions' type characters read: `driveset`, `table` (section 2.3.2 order, '1' = PT_USIGN8 .. '8' = PT_PASSWORD) or a map `1=PT_USIGN8,2=PT_USIGN16,...` (default: guessed from the content; errata L23)."),
            );
    }
    if flags == LearnFlags::All {
        cmd = cmd.arg(
            Arg::new("no_learn")
                .long("no-learn")
                .action(ArgAction::SetTrue)
                .help("Use the schema as it is: do not read the drive's descriptions."),
        );
    }
    cmd
}

/// One value of `id`, if the command defines it and it was given.
fn one<T: Clone + Send + Sync + 'static>(m: &ArgMatches, id: &str) -> Option<T> {
    m.try_get_one::<T>(id).ok().flatten().cloned()
}

/// Every value of `id` given.
fn many<T: Clone + Send + Sync + 'static>(m: &ArgMatches, id: &str) -> Vec<T> {
    m.try_get_many::<T>(id)
        .ok()
        .flatten()
        .map(|v| v.cloned().collect())
        .unwrap_or_default()
}

/// Whether the flag `id` was given.
fn flag(m: &ArgMatches, id: &str) -> bool {
    one::<bool>(m, id).unwrap_or(false)
}

impl PortArgs {
    /// The arguments as given: the one reading of each.
    pub fn read(m: &ArgMatches) -> PortArgs {
        PortArgs {
            port: one(m, "port"),
            address: one(m, "address"),
            schema: many(m, "schema"),
            schemas: many(m, "schemas"),
            protocol: one(m, "protocol"),
            allow_family: flag(m, "allow_family"),
            learn: LearnArgs::read(m),
        }
    }

    /// `--port`, which clap required (an input error if a command that
    /// does not require it asks).
    pub fn port(&self) -> Result<&str, Fail> {
        self.port
            .as_deref()
            .ok_or_else(|| Fail::input("give the port: --port PORT"))
    }

    /// `--address`, which clap required (an input error if a command that
    /// does not require it asks).
    pub fn address(&self) -> Result<u8, Fail> {
        self.address
            .ok_or_else(|| Fail::input("give the drive's address: --address N"))
    }

    /// The one `--schema` of a command that takes one.
    pub fn schema(&self) -> Option<&str> {
        self.schema.first().map(String::as_str)
    }

    /// What the command asks the engine's resolver for
    /// ([`driveset_engine::session::Catalog::resolve`] /
    /// [`driveset_engine::session::Catalog::chosen`]).
    pub fn ask(&self) -> SchemaAsk<'_> {
        SchemaAsk {
            schema: self.schema(),
            protocol: self.protocol.map(|p| p.0),
        }
    }
}

impl LearnArgs {
    /// The learning options as given.
    fn read(m: &ArgMatches) -> LearnArgs {
        LearnArgs {
            schema_dir: one(m, "schema_dir"),
            description_layout: one(m, "description_layout"),
            type_chars: one(m, "type_chars"),
            no_learn: flag(m, "no_learn"),
        }
    }

    /// The engine's options (parameters: the default range).
    pub fn options(&self) -> Result<LearnOptions, Fail> {
        LearnOptions::reading(
            self.description_layout.as_deref(),
            self.type_chars.as_deref(),
        )
        .map_err(|e| Fail::input(e.to_string()))
    }
}

impl LearnArgs {
    /// The engine's learning request, the learned file written to `dir`.
    pub fn request(&self, dir: Option<PathBuf>) -> Result<LearnRequest<'static>, Fail> {
        Ok(LearnRequest {
            options: self.options()?,
            learn: !self.no_learn,
            dir,
            env: &crate::env::SystemEnv,
        })
    }
}

impl PortArgs {
    /// The schema the drive at `address` of `opened` is talked with: the
    /// engine's one resolution ([`driveset_engine::session::Catalog::resolve`]:
    /// `--schema`, else `--protocol`'s built-in schema, else the built-in
    /// schema of the family the drive answers the read-only probes as).
    /// The same on every port; the port stays open for the command.
    pub fn resolve(&self, opened: &mut OpenedPort, address: u8) -> Result<Resolved, Fail> {
        Ok(crate::port::catalog(&self.schemas).resolve(opened, address, self.ask())?)
    }

    /// What a one-drive command opens and which schema it talks with,
    /// resolved once: the port opened and its bus locked for the drive at
    /// `address` ([`crate::port::open_port_at`]), then [`PortArgs::resolve`].
    pub fn open_resolved(&self, address: u8) -> Result<(OpenedPort, Resolved), Fail> {
        let mut opened = crate::port::open_port_at(self.port()?, Some(address))?;
        let resolved = self.resolve(&mut opened, address)?;
        Ok((opened, resolved))
    }

    /// The drive at `address` of `opened`, speaking `schema`, learned from
    /// first where the schema lacks facts (unless `--no-learn`), the
    /// learned file written to `dir` (the engine's
    /// [`driveset_engine::session::open_learning`]).
    pub fn open_learning(
        &self,
        opened: OpenedPort,
        schema: Arc<Schema>,
        address: u8,
        dir: Option<PathBuf>,
    ) -> Result<Session, Fail> {
        let request = self.learn.request(dir)?;
        Ok(session::open_learning(
            &crate::port::catalog(&self.schemas),
            opened,
            schema,
            address,
            &request,
        )?)
    }

    /// `set` brought to the drive at `--port` / `address` (the engine's
    /// [`driveset_engine::session::set_on_drive`]): what was learned on
    /// stderr; a set that does not load or has findings rendered there,
    /// the failure saying `SET: {what}` (`not uploaded`).
    pub fn set_on_drive(&self, set: &Path, address: u8, what: &str) -> Result<SetOnDrive, Fail> {
        let refused = |code: u8| Fail {
            code,
            msg: format!("{}: {what}", set.display()),
        };
        let request = self.learn.request(self.learn.schema_dir.clone())?;
        let learned_lines = |r: &driveset_engine::session::LearnedReport| {
            for l in r.lines() {
                eprintln!("{l}");
            }
        };
        match session::set_on_drive(
            &crate::port::catalog(&self.schemas),
            &crate::port::CliPorts,
            set,
            self.port()?,
            address,
            &request,
        ) {
            Ok(on) => {
                if let Some(r) = &on.session.learned {
                    learned_lines(r);
                }
                Ok(on)
            }
            Err(SetOnDriveError::Input(e)) => Err(refused(crate::output::fail_input(&e))),
            Err(SetOnDriveError::Findings { loaded, learned }) => {
                if let Some(r) = &learned {
                    learned_lines(r);
                }
                let code = crate::output::valid_set(set, *loaded)
                    .err()
                    .unwrap_or(crate::EXIT_INPUT);
                Err(refused(code))
            }
            Err(SetOnDriveError::Session(e)) => Err(e.into()),
        }
    }
}

impl clap::FromArgMatches for LearnArgs {
    fn from_arg_matches(m: &ArgMatches) -> Result<Self, clap::Error> {
        Ok(LearnArgs::read(m))
    }

    fn update_from_arg_matches(&mut self, m: &ArgMatches) -> Result<(), clap::Error> {
        *self = LearnArgs::read(m);
        Ok(())
    }
}

impl clap::Args for LearnArgs {
    fn augment_args(cmd: Command) -> Command {
        augment_learn(cmd, LearnFlags::All)
    }

    fn augment_args_for_update(cmd: Command) -> Command {
        augment_learn(cmd, LearnFlags::All)
    }
}

/// The port arguments of command `C` (flattened into its clap `Args`).
pub struct Port<C> {
    /// The arguments as given.
    pub args: PortArgs,
    command: PhantomData<C>,
}

impl<C> std::fmt::Debug for Port<C> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.args.fmt(f)
    }
}

impl<C> Clone for Port<C> {
    fn clone(&self) -> Self {
        Port {
            args: self.args.clone(),
            command: PhantomData,
        }
    }
}

impl<C> Deref for Port<C> {
    type Target = PortArgs;

    fn deref(&self) -> &PortArgs {
        &self.args
    }
}

impl<C: PortCommand> clap::FromArgMatches for Port<C> {
    fn from_arg_matches(m: &ArgMatches) -> Result<Self, clap::Error> {
        Ok(Port {
            args: PortArgs::read(m),
            command: PhantomData,
        })
    }

    fn update_from_arg_matches(&mut self, m: &ArgMatches) -> Result<(), clap::Error> {
        self.args = PortArgs::read(m);
        Ok(())
    }
}

impl<C: PortCommand> clap::Args for Port<C> {
    fn augment_args(cmd: Command) -> Command {
        augment(cmd, &C::TAKES)
    }

    fn augment_args_for_update(cmd: Command) -> Command {
        augment(cmd, &C::TAKES)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::{Args as _, FromArgMatches as _};

    struct Both;
    impl PortCommand for Both {
        const TAKES: Takes = Takes {
            port: Need::Required,
            address: Need::Optional,
            schema: SchemaCount::Many,
            schemas: true,
            protocol: Need::Optional,
            allow_family: true,
            learn: LearnFlags::All,
            ..Takes::NONE
        };
    }
    struct PortOnly;
    impl PortCommand for PortOnly {
        const TAKES: Takes = Takes {
            port: Need::Required,
            ..Takes::NONE
        };
    }

    fn parse<C: PortCommand>(argv: &[&str]) -> Result<PortArgs, clap::Error> {
        let cmd = Port::<C>::augment_args(Command::new("t"));
        let m = cmd.try_get_matches_from(argv)?;
        Ok(Port::<C>::from_arg_matches(&m)?.args)
    }

    #[test]
    fn every_flag_is_read_as_given_and_only_where_taken() {
        let a = parse::<Both>(&[
            "t",
            "--port",
            "/dev/ttyUSB0?baud=9600",
            "--address",
            "7",
            "--schema",
            "a",
            "--schema",
            "b.toml",
            "--schemas",
            "d",
            "--protocol",
            "lecom",
            "--allow-family",
            "--schema-dir",
            "s",
            "--description-layout",
            "43",
            "--type-chars",
            "table",
            "--no-learn",
        ])
        .expect("parses");
        assert_eq!(a.port.as_deref(), Some("/dev/ttyUSB0?baud=9600"));
        assert_eq!(a.address, Some(7));
        assert_eq!(a.schema, ["a", "b.toml"]);
        assert_eq!(a.schemas, [PathBuf::from("d")]);
        assert_eq!(
            a.protocol,
            Some(BusArg(driveset_schema::BusProtocol::Lecom))
        );
        assert!(a.allow_family && a.learn.no_learn);
        assert_eq!(a.learn.schema_dir, Some(PathBuf::from("s")));
        assert_eq!(a.learn.description_layout.as_deref(), Some("43"));
        assert_eq!(a.learn.type_chars.as_deref(), Some("table"));
        assert!(a.learn.options().is_ok());

        // a flag the command does not take does not exist for it
        let e = parse::<PortOnly>(&["t", "--port", "p", "--schema", "x"]).expect_err("no --schema");
        assert_eq!(e.kind(), clap::error::ErrorKind::UnknownArgument);
        // a required one missing: clap's usage error
        let e = parse::<PortOnly>(&["t"]).expect_err("no --port");
        assert_eq!(e.kind(), clap::error::ErrorKind::MissingRequiredArgument);
        let a = parse::<PortOnly>(&["t", "--port", "p"]).expect("parses");
        assert_eq!(
            (a.port().ok(), a.address, a.schema(), a.allow_family),
            (Some("p"), None, None, false)
        );
        assert!(a.address().is_err());
    }
}
