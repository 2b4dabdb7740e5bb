//! `driveset validate` (under construction).

#[derive(clap::Args)]
pub struct Args {}

pub fn run(_args: Args) -> anyhow::Result<u8> {
    anyhow::bail!("`driveset validate` is not implemented yet")
}
