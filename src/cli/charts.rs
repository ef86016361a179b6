//! `shadespace charts`: per object, where its unique UV layout comes from,
//! its overlap, area, texel density and shading-texture size.

use anyhow::Context;
use clap::Args;
use shadespace::charts;
use shadespace::scene::{self, path};

use super::options::ObjectSpaceArgs;
use super::parse;
use super::setup::chart;
use super::{Failure, input};

/// `charts`' options: the scene and the texture sizing.
#[derive(Args)]
pub struct ChartsArgs {
    /// `atrium`, `voxels`, or a path (see `render --help`).
    #[arg(long, default_value = "atrium")]
    pub scene: String,
    /// Image size, WIDTHxHEIGHT, that the default sizing follows along the
    /// scene's camera path (as `render --size` does).
    #[arg(long, default_value = "1280x720", value_parser = parse::size)]
    pub size: (u32, u32),
    #[command(flatten)]
    pub objectspace: ObjectSpaceArgs,
}

/// Charts the scene and prints the table.
pub fn run(a: ChartsArgs) -> Result<(), Failure> {
    let scene = input(scene::load(&a.scene))?;
    let aspect = a.size.0 as f32 / a.size.1 as f32;
    let cameras = input(path::cameras_for_scene(&a.scene, &scene, aspect).context("--scene"))?;
    let views = charts::path_cameras(&cameras.path);
    let (_, charts) = chart(&scene, &a.objectspace, &views, a.size)?;
    print!("{charts}");
    Ok(())
}
