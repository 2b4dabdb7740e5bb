//! `driveset encode`: build one telegram from a readable description, for
//! bench tests with a terminal program. The description language is the
//! engine's (`driveset_engine::decode::encode`, its grammar in its module
//! docs and in `--help`; the telegram's text too, `Telegram::text`); this
//! command loads the schemas and prints.
//!
//! Output: the bytes in hex and in escaped ASCII (`<EOT>@00112<ENQ>`, `<xx>`
//! for other bytes; `driveset decode --ascii` reads it back); for SDO the CAN
//! frame and its slcan line. `--raw` writes only the bytes (SDO: the slcan
//! line with CR). Errors name the bad key or value and list the valid ones
//! (exit 2).

use driveset_engine::decode::encode::{Request, Telegram, encode};

use crate::EXIT_OK;
use crate::args::LustFamilyArg as FamilyArg;
use crate::offline::{builtin_registry, load_schema};

#[derive(clap::Args)]
#[command(after_help = "\
Grammar: VERB key=value ... (quote values with spaces: key=\"a b\")

  --protocol lustbus
    enquiry address=A (code=NNNNN | param=P)
    select  address=A (code=NNNNN | param=P) value=V
    reply   address=A (code=NNNNN | param=P) value=V
    ack address=A | nak address=A | eot
      A 0..31 (0 all, 31 broadcast); code = the five CODE digits (00112, 20428);
      param = parameter number with family=vf1000|mc6000 (or --family/--schema):
      MC 20ppp, VF1000 0 0 d pp (device=1 unless device=0), 81..85/91 -> 000pp;
      value = 0x842666 raw hex, or a decimal converted exactly with the schema's
      type (refused with the nearest values when not representable).
  --protocol lecom
    receive address=NN code=C[/S]
    send address=NN code=C[/S] value=V
    broadcast address=NN code=C[/S] value=V      (NN = 00 or x0)
      code 46, C46, C0046, C1002/1; value 95.2 (VD), H0900 or 0x0900 (VH),
      Stext (VS), O0102 (VO)
  --protocol sdo
    read  node=N code=C [subindex=S]
    write node=N code=C [subindex=S] value=V
      node 1..127; value decimal -> FIX32 (x10000, exact), 0x... -> 32-bit raw

Examples:
  driveset encode --protocol lustbus \"enquiry address=0 code=00112\"
  driveset encode --protocol lustbus \"select address=1 family=mc6000 param=428 value=0x842666\"
  driveset encode --protocol lecom \"send address=34 code=11 value=95.2\"
  driveset encode --protocol sdo \"write node=1 code=11 value=50.0\"")]
pub struct Args {
    /// Family of the telegram.
    #[arg(long, value_enum)]
    pub protocol: crate::args::BusArg,
    /// LUSTBUS device family (for param= and decimal values).
    #[arg(long, value_enum)]
    pub family: Option<FamilyArg>,
    /// Schema for decimal values: a built-in id or a schema file.
    #[arg(long, value_name = "ID_OR_PATH")]
    pub schema: Option<String>,
    /// Write only the raw bytes to stdout.
    #[arg(long)]
    pub raw: bool,
    /// The telegram, e.g. "enquiry address=0 code=00112".
    #[arg(value_name = "DESCRIPTION")]
    pub description: String,
}

/// Runs `driveset encode`.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    let telegram = build(&args)?;
    if args.raw {
        crate::output::emit_bytes(telegram.raw());
    } else {
        crate::output::emit(&telegram.text());
    }
    Ok(EXIT_OK)
}

/// The telegram the description gives.
fn build(args: &Args) -> anyhow::Result<Telegram> {
    let mut registry = builtin_registry()?;
    let schema = match &args.schema {
        Some(s) => Some(load_schema(&mut registry, s)?),
        None => None,
    };
    let req = Request {
        protocol: args.protocol.0,
        family: args.family.map(FamilyArg::dialect),
        description: &args.description,
    };
    encode(&req, &registry, schema).map_err(|e| anyhow::anyhow!("{e}"))
}
