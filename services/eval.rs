//! `shipcast eval`: placeholder, being written.

#[derive(clap::Args, Debug)]
pub struct Args {}

pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("'shipcast eval' is not implemented yet")
}
