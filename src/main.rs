//! The `shadespace` command line: parse, dispatch to the command's module in
//! `cli/`, print its error and exit with its status (2 for bad input).

mod cli;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

use cli::{bench, charts, compare, experiment, info, options, render};

#[derive(Parser)]
#[command(name = "shadespace", version, about = "Object-space shading renderer and testbed", long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render one frame to a PNG image (and optionally its statistics to JSON).
    // A flag given twice keeps its last value, so that a script's defaults
    // (`scripts/render`) yield to the user's flags after them.
    #[command(args_override_self = true)]
    Render(render::RenderArgs),
    /// Render many frames along a camera path and report GPU time per pass
    /// (median and p95 after warm-up) as JSON.
    Bench(bench::BenchArgs),
    /// List the pipelines, the GPU adapters, and the features and limits of the chosen adapter.
    Info(options::GpuArgs),
    /// Print, per object, where its unique UV layout (chart) comes from, its
    /// overlap, surface area, texel density and shading-texture size.
    Charts(charts::ChartsArgs),
    /// Compare two images: mean FLIP error, PSNR, SSIM, largest channel difference.
    Compare(compare::CompareArgs),
    /// Run one of the studies behind the project (overshading, overlap,
    /// reuse, lights, speedup) and write its data, summary, plots and report
    /// into a folder.
    #[command(long_about = experiment::ABOUT)]
    Experiment(experiment::ExperimentArgs),
    /// Open a window that renders the scene with the same options as
    /// `render`: fly, orbit or path camera, pipelines and options switched
    /// from a panel, live GPU timings, screenshots (F12). With --script,
    /// --frames or --screenshot it plays, saves and exits (for tests).
    #[cfg(feature = "viewer")]
    View(cli::view::ViewArgs),
    /// The interactive viewer: not in this build; it says the cargo command
    /// that builds it in (`--features viewer`).
    #[cfg(not(feature = "viewer"))]
    View(cli::view_missing::ViewArgs),
}

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| "warn,wgpu_hal=error,wgpu_core=error,naga=error".into()),
        )
        .with_writer(std::io::stderr)
        .init();
    let result = match Cli::parse().command {
        Command::Render(a) => render::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Info(a) => info::run(a),
        Command::Charts(a) => charts::run(a),
        Command::Compare(a) => compare::run(a),
        Command::Experiment(a) => experiment::run(a),
        #[cfg(feature = "viewer")]
        Command::View(a) => cli::view::run(a),
        #[cfg(not(feature = "viewer"))]
        Command::View(a) => cli::view_missing::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(failure) => {
            let status = failure.exit_status();
            eprintln!("error: {:#}", failure.into_error());
            ExitCode::from(status)
        }
    }
}
