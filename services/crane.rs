//! `shipcast crane`: placeholder, being written.

#[derive(clap::Args, Debug)]
pub struct Args {}

pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("'shipcast crane' is not implemented yet")
}
