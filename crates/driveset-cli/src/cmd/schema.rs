//! `driveset schema ...` (under construction).

#[derive(clap::Subcommand)]
pub enum SchemaCommand {
    /// Validate the schema files themselves.
    Check {},
}

pub fn run(_cmd: SchemaCommand) -> anyhow::Result<u8> {
    anyhow::bail!("`driveset schema check` is not implemented yet")
}
