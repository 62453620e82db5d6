//! `shipcast paper`: placeholder, being written.

#[derive(clap::Args, Debug)]
pub struct Args {}

pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("'shipcast paper' is not implemented yet")
}
