//! `driveset sim`: serve simulated drives in real time on a pseudo terminal
//! or a TCP port, so every bus command can be tried without hardware.
//!
//! ```text
//! driveset sim --family mc6000 --address 1 --address 2 [--pty | --tcp 127.0.0.1:PORT]
//!              [--baud 9600] [--bitrate 500000] [--keypad] [--c0001 N] [--refuse CODES]
//!              [--layout 52|43|42|34] [--types READING] [--describe N:ITEM...] [--faults PLAN]
//!              [--seed N] [--log FILE] [--dump FILE] [--state FILE]
//! ```
//!
//! The first line on stdout is for scripts, exactly one of:
//!
//! ```text
//! pty /dev/pts/7
//! tcp 127.0.0.1:40123
//! ```
//!
//! Everything else (what is served, how to connect) goes to stderr. The
//! simulator serves until SIGINT (Ctrl-C) or SIGTERM, then writes the
//! `--dump` file (and the `--state` file) and exits 0; a second Ctrl-C
//! while it is stopping exits at once with 1.
//!
//! - LUSTBUS / LECOM families (mc6000, vf1000, tmd) serve the character
//!   line: on `--pty` (the default) a client opens the printed path as a
//!   serial port (`--port /dev/pts/7?baud=9600`), on `--tcp` it connects
//!   like to a serial device server in raw mode (`--port
//!   tcp://127.0.0.1:40123`), one connection at a time: a client that
//!   connects while another holds the line waits until that one closes or
//!   is dropped after `--idle-timeout` seconds without sending anything
//!   (default 30; 0 never drops), as device servers do. Waiting, serving
//!   and dropping are printed on stderr (`sim: ...`) and logged (`--log`:
//!   `connect`, `wait`, `idle`, `disconnect`). Replies leave at
//!   the line rate (10 bit times a character) after the family's reaction
//!   time (LUSTBUS section 10; `--keypad` for the slower ranges with a
//!   KEYPAD attached).
//! - ecs (CAN) serves a simulated slcan USB-CAN adapter on a pty:
//!   `--port slcan:///dev/pts/7?bitrate=500000`, or python-can's `slcan`
//!   interface. `--tcp` is refused for ecs: no TCP transport for CAN
//!   exists in driveset to talk to it (slcan over TCP would need a client
//!   as well).
//!
//! `--tcp` binds to loopback unless the address says otherwise: `--tcp
//! 4001` and `--tcp 127.0.0.1:4001` are loopback, `--tcp 0.0.0.0:4001`
//! serves the network (with a warning: the simulator has no access
//! control).
//!
//! The work is the simulator's ([`driveset_sim::command`]: the options
//! checked into a bus and an endpoint, the power cycle of a state file,
//! serving until stopped and what it says meanwhile, what is saved when
//! serving stops); this module keeps the arguments, the stop flag and
//! signals, and prints what it is told: the line announced on stdout, the
//! rest on stderr.

use std::io::LineWriter;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use anyhow::Context;
use driveset_sim::command::{self, Served, SimCommandError, SimOptions, Told};
use driveset_sim::log::EventLog;

use crate::{EXIT_BUS, EXIT_OK};

/// Serve simulated drives on a pseudo terminal or a TCP port.
#[derive(clap::Args)]
#[command(after_help = "\
The first line on stdout is `pty PATH` or `tcp IP:PORT` (for scripts); the rest goes to stderr.
On --tcp one client at a time has the line, as on a serial device server: others wait
(`sim: host ... waits`) until it closes or has sent nothing for --idle-timeout seconds.
Stop with Ctrl-C or SIGTERM; --dump then writes every drive's family, address, schema,
fingerprint and canonical state as JSON.

Examples:
  driveset sim --family mc6000 --address 1 --address 2
  driveset sim --family mc6000 --factory 3 --bench --state bench.json
  driveset sim --family lustbus --factory mc6000*4,vf1000*3
  driveset sim --family tmd --address 1 --tcp 127.0.0.1:4001 --log bus.jsonl
  driveset sim --family mc6000 --address 1 --tcp 4001 --idle-timeout 10
  driveset sim --family ecs --address 1 --pty --bitrate 500000")]
pub struct Args {
    /// Drive family: mc6000 (MC7000 too), vf1000, tmd, ecs.
    #[arg(long, value_name = "FAMILY", required_unless_present_any = ["twin", "power_cycle", "eds"])]
    family: Option<String>,

    /// Serve a twin (`NAME.twin.toml`, captured with `driveset twin
    /// capture`) instead of factory drives, or every twin of a directory on
    /// one bus by address (docs/twins.md).
    #[arg(long, value_name = "FILE|DIR", conflicts_with_all = ["family", "addresses", "c0001", "keypad"])]
    twin: Option<PathBuf>,

    /// Serve the CANopen device a CiA 306 EDS / DCF describes at each
    /// --address (its objects, types, access, limits, defaults; 0x1010
    /// "save" when the sheet declares it), as `sim://eds?file=FILE` does
    /// (docs/ports.md).
    #[arg(long, value_name = "FILE", conflicts_with_all = ["family", "twin", "factory", "c0001", "keypad"])]
    eds: Option<PathBuf>,

    /// Bus address of a simulated drive; repeat (or give a comma list) for
    /// several. LUSTBUS 1..30, LECOM 1..99 except 10, 20, ... 90, CAN 1..127.
    #[arg(
        long = "address",
        value_name = "N",
        value_delimiter = ',',
        required_unless_present_any = ["twin", "factory", "power_cycle"]
    )]
    addresses: Vec<u8>,

    /// Factory-fresh drives, as a `sim://` port's `factory=`: a count on
    /// one family (`--factory 3`), `FAMILY*N,...` on `--family lustbus`
    /// (`mc6000*4,vf1000*3`). Each at its family's factory address (1) and
    /// 9600 baud; several answer at once (docs/ports.md).
    #[arg(long, value_name = "N|FAMILY*N,...", conflicts_with = "twin")]
    factory: Option<String>,

    /// The service bench (with --factory): the line holds only the first
    /// factory drive not yet given an address; once every one has one,
    /// all drives. Decided when the server starts (use --state to carry
    /// the drives from one start to the next).
    #[arg(long, requires = "factory")]
    bench: bool,

    /// Serve on a new pseudo terminal (the default).
    #[arg(long, conflicts_with = "tcp")]
    pty: bool,

    /// Serve on a TCP port: PORT or IP:PORT (loopback unless an address
    /// says otherwise; 0 picks a free port).
    #[arg(long, value_name = "[IP:]PORT")]
    tcp: Option<String>,

    /// With --tcp: drop a client that has sent nothing for this many
    /// seconds so the next waiting client gets the line (0: never).
    #[arg(long, value_name = "SECONDS", default_value_t = 30, requires = "tcp")]
    idle_timeout: u64,

    /// Line rate of the LUSTBUS / LECOM line (7E1).
    #[arg(long, value_name = "BAUD")]
    baud: Option<u32>,

    /// CAN bit rate (ecs).
    #[arg(long, value_name = "BIT/S")]
    bitrate: Option<u32>,

    /// LUSTBUS drives with a KEYPAD attached (slower reactions, LUSTBUS
    /// section 10).
    #[arg(long)]
    keypad: bool,

    /// Tmd: C0001 as set at the drive's keypad (0..=11, §4e). Default 0,
    /// the factory setting (LECOM may only read); 2 lets LECOM write
    /// parameters, 3 also the control word C0135.
    #[arg(long, value_name = "N")]
    c0001: Option<u8>,

    /// Codes every drive refuses to read (`11,17.2`): LUSTBUS NAK, LECOM
    /// EOT, CAN SDO abort 0x06010001 (docs/twins.md "Refused reads").
    #[arg(long, value_name = "CODES")]
    refuse: Option<String>,

    /// MC6000/7000: the layout the drives send their parameter descriptions
    /// in (52, 43, 42 or 34; errata L22), as a `sim://` port's `layout=`.
    #[arg(long, value_name = "52|43|42|34", conflicts_with = "twin")]
    layout: Option<String>,

    /// MC6000/7000: the type characters of their descriptions (`driveset`,
    /// `table` or `C=TYPE,...`; errata L23), as a `sim://` port's `types=`.
    #[arg(long, value_name = "READING", conflicts_with = "twin")]
    types: Option<String>,

    /// LUSTBUS: parameters whose description says something other than the
    /// drive does (`N:ITEM[:ITEM...][;N:...]`, e.g. `11:actual:binary8`),
    /// as a `sim://` port's `describe=` (docs/ports.md).
    #[arg(long, value_name = "N:ITEM...", conflicts_with = "twin")]
    describe: Option<String>,

    /// Faults to inject, e.g. `flip=0.01,lose=0.02,power-cycle@40:addr=1`.
    #[arg(long, value_name = "PLAN")]
    faults: Option<String>,

    /// Seed of every random choice (reaction times, faults).
    #[arg(long, value_name = "N", default_value_t = 0)]
    seed: u64,

    /// Write the event log (every telegram and fault) as JSON lines.
    #[arg(long, value_name = "FILE")]
    log: Option<PathBuf>,

    /// On exit, write every drive's state (family, address, schema,
    /// fingerprint, canonical values) as JSON.
    #[arg(long, value_name = "FILE")]
    dump: Option<PathBuf>,

    /// Load the drives' state from this dump at start (if it exists) and
    /// save it back on exit (the same file `sim://...` ports use).
    #[arg(long, value_name = "FILE")]
    state: Option<PathBuf>,

    /// Power-cycle every drive of the --state file and exit (nothing is
    /// served): each comes back with what its kind of drive keeps (RAM
    /// values lost; CAN writes not yet stored lost where its schema keeps
    /// writes only on command, `[schema.store]`). The family and addresses
    /// are the state file's unless given.
    #[arg(long, requires = "state", conflicts_with_all = ["twin", "factory", "tcp", "pty"])]
    power_cycle: bool,
}

impl Args {
    /// The options as the simulator takes them ([`SimOptions`]).
    fn options(&self) -> SimOptions {
        SimOptions {
            family: self.family.clone(),
            twin: self.twin.clone(),
            eds: self.eds.clone(),
            addresses: self.addresses.clone(),
            factory: self.factory.clone(),
            bench: self.bench,
            tcp: self.tcp.clone(),
            baud: self.baud,
            bitrate: self.bitrate,
            keypad: self.keypad,
            c0001: self.c0001,
            refuse: self.refuse.clone(),
            layout: self.layout.clone(),
            types: self.types.clone(),
            describe: self.describe.clone(),
            faults: self.faults.clone(),
            seed: self.seed,
            state: self.state.clone(),
            power_cycle: self.power_cycle,
        }
    }
}

/// A simulator error as `anyhow` prints it (the error and its causes), the
/// way this command has always printed its failures.
fn chain(e: SimCommandError) -> String {
    format!("{:#}", anyhow::Error::from(e))
}

/// The stop flag, set by SIGINT / SIGTERM. A second SIGINT or SIGTERM
/// while stopping ends the process at once (exit 1).
fn stop_flag() -> anyhow::Result<Arc<AtomicBool>> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    let stop = Arc::new(AtomicBool::new(false));
    for sig in [SIGINT, SIGTERM] {
        // Order matters: the conditional shutdown sees the flag before
        // this signal sets it, so only a second signal exits.
        signal_hook::flag::register_conditional_shutdown(sig, 1, Arc::clone(&stop))
            .context("cannot install the signal handlers")?;
        signal_hook::flag::register(sig, Arc::clone(&stop))
            .context("cannot install the signal handlers")?;
    }
    Ok(stop)
}

/// Print the one machine-readable line.
fn announce(line: &str) {
    crate::output::emit(&format!("{line}\n"));
}

pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    let (config, endpoint) =
        command::configure(&args.options()).map_err(|e| crate::fail::Fail::input(chain(e)))?;
    if args.power_cycle {
        let n = command::power_cycle(&config).map_err(|e| crate::fail::Fail::input(chain(e)))?;
        eprintln!(
            "power-cycled {n} simulated {} drive{} of {}",
            config.bus_name(),
            if n == 1 { "" } else { "s" },
            config.state.as_deref().unwrap_or(Path::new("")).display()
        );
        return Ok(EXIT_OK);
    }
    let log = match &args.log {
        Some(path) => {
            // 0600: the log is a bus capture (secrets are masked in it,
            // the rest of the traffic is not); a FIFO or device is refused
            let file = driveset_schema::output::create_log(path).map_err(|e| {
                crate::fail::Fail::input(format!("--log {}: {}", path.display(), e.detail()))
            })?;
            EventLog::writer(LineWriter::new(file))
        }
        None => EventLog::off(),
    };
    let stop = stop_flag()?;
    let served = command::serve(
        &config,
        endpoint,
        &log,
        &stop,
        args.idle_timeout,
        &mut |t| match t {
            Told::Endpoint(line) => announce(&line),
            Told::Note(line) => eprintln!("{line}"),
        },
    )
    .map_err(|e| crate::fail::Fail::input(format!("{:#}", anyhow::Error::from(e))))?;
    let Served { outcome, dump } = served;
    let saved = command::save(&config, &dump, &log, args.dump.as_deref(), |path| {
        eprintln!("wrote the drives' state to {}", path.display());
    });
    match (outcome, saved) {
        (Ok(()), Ok(())) => {
            eprintln!(
                "stopped after {} host telegrams",
                dump.telegrams.unwrap_or(0)
            );
            Ok(EXIT_OK)
        }
        (Err(e), saved) => {
            if let Err(s) = saved {
                eprintln!("error: {}", chain(s));
            }
            Err(crate::fail::Fail {
                code: EXIT_BUS,
                msg: format!("{:#}", anyhow::Error::from(e)),
            })
        }
        (Ok(()), Err(e)) => Err(crate::fail::Fail::input(chain(e))),
    }
}
