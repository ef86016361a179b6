//! `shadespace charts`: per object, where its unique UV layout comes from,
//! its overlap, area, texel density and shading-texture size.

use clap::Args;
use shadespace::scene;

use super::options::ObjectSpaceArgs;
use super::setup::chart;
use super::{Failure, input};

/// `charts`' options: the scene and the texture sizing.
#[derive(Args)]
pub struct ChartsArgs {
    /// `atrium`, `voxels`, or a path (see `render --help`).
    #[arg(long, default_value = "atrium")]
    pub scene: String,
    #[command(flatten)]
    pub objectspace: ObjectSpaceArgs,
}

/// Charts the scene and prints the table.
pub fn run(a: ChartsArgs) -> Result<(), Failure> {
    let scene = input(scene::load(&a.scene))?;
    let (_, charts) = chart(&scene, &a.objectspace)?;
    print!("{charts}");
    Ok(())
}
