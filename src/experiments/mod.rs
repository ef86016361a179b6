//! Each study of the sources as one named, reproducible experiment, writing
//! CSV, JSON, plots and a Markdown report.

pub mod marking;
pub mod plot;
pub mod stats;
pub mod study_path;
pub mod tile_set;
pub mod visibility;
