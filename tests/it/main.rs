//! The integration tests, one module per area, linked into one binary so that
//! the suite builds and links once (each file under `tests/` used to be its
//! own binary: 23 links of the whole renderer). `cargo test --test it NAME`
//! runs a part, for example `cargo test --test it golden::`.

mod common;

mod agreement;
mod aniso;
mod blending;
mod bloom;
mod breakdown;
mod cameras;
mod city;
mod cli;
mod compute_visibility;
mod corpus;
mod culling;
mod deferred;
mod density;
mod doc_links;
mod drawfall;
mod environment;
mod examples;
mod experiments;
mod exposure;
mod faces;
mod forward;
mod forward_multipass;
mod fuzz_regressions;
mod golden;
mod hwcull;
mod layered_materials;
mod layers;
mod light_grid;
mod light_sets;
mod mark_twin;
mod materials;
mod msaa;
mod objectspace;
mod osperf;
mod page_directory;
mod reference;
mod seams;
mod shadows;
mod sponza;
mod stability;
mod stage_twins;
mod terrain;
mod trimap;
mod trimap_share;
mod viewer;
