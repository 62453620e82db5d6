//! `shipcast bench`: placeholder, being written.

#[derive(clap::Args, Debug)]
pub struct Args {}

pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("'shipcast bench' is not implemented yet")
}
