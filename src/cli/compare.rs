//! `shadespace compare`: two images' mean FLIP error, PSNR, SSIM and largest
//! channel difference.

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;

use super::output::write_file;
use super::{Failure, input};

/// `compare`'s images and output.
#[derive(Args)]
pub struct CompareArgs {
    /// The reference image (e.g. forward shading).
    pub reference: PathBuf,
    /// The image under test (e.g. object-space shading).
    pub test: PathBuf,
    /// Also write the FLIP error map here.
    #[arg(long)]
    pub flip_map: Option<PathBuf>,
}

/// Compares the images and prints the metrics (and writes the FLIP map).
pub fn run(a: CompareArgs) -> Result<(), Failure> {
    let load = |p: &Path| {
        input(image::open(p).map(|i| i.to_rgba8()).with_context(|| format!("{}: cannot read image", p.display())))
    };
    let (reference, test) = (load(&a.reference)?, load(&a.test)?);
    if reference.dimensions() != test.dimensions() {
        return input(Err(anyhow::anyhow!(
            "{} is {:?} but {} is {:?}",
            a.reference.display(),
            reference.dimensions(),
            a.test.display(),
            test.dimensions()
        )));
    }
    let (err, map) = shadespace::metrics::compare(&reference, &test);
    println!(
        "FLIP mean {:.4}  PSNR {:.2} dB  SSIM {:.4}  max channel difference {}",
        err.flip_mean, err.psnr_db, err.ssim, err.max_abs
    );
    if let Some(path) = &a.flip_map {
        let mut bytes = Vec::new();
        map.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png).context("encoding PNG")?;
        write_file(path, &bytes)?;
    }
    Ok(())
}
