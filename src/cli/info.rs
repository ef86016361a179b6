//! `shadespace info`: the pipelines, the GPU adapters, and the chosen
//! adapter's features and limits.

use clap::ValueEnum;

use super::Failure;
use super::options::{GpuArgs, PipelineName};
use super::setup::open_gpu;

/// Prints the pipelines, the adapters and the chosen adapter's report.
pub fn run(a: GpuArgs) -> Result<(), Failure> {
    println!("pipelines (--pipeline):");
    for p in PipelineName::value_variants().iter().filter_map(|v| v.to_possible_value()) {
        println!("  {:<18} {}", p.get_name(), p.get_help().map(|h| h.to_string()).unwrap_or_default());
    }
    println!("adapters:");
    for line in shadespace::gpu::list_adapters() {
        println!("  {line}");
    }
    let ctx = open_gpu(&a)?;
    print!("{}", ctx.report());
    Ok(())
}
