//! Constants that WGSL shares with Rust, generated from their Rust
//! definitions as the composable module `shadespace::contract`, so the two
//! sides cannot disagree (WGSL files import them by name instead of
//! repeating the values).

use std::fmt::Write;

use crate::render::deferred::volumes::VolumeList;
use crate::render::deferred_compute;
use crate::render::gpu_types::{GpuLightKind, NO_TEXTURE, ShadingModel};
use crate::render::objectspace::atlas::{BLOCK_SIDE, MAX_LEVELS};
use crate::render::objectspace::{DebugView, TileCounter};

/// (WGSL name, value) of every shared `u32` constant.
pub fn constants() -> Vec<(&'static str, u32)> {
    let mut c = vec![("MAX_LEVELS", MAX_LEVELS as u32), ("TILE_COUNTER_SLOTS", TileCounter::SLOTS as u32)];
    c.push(("PAIR_EMISSION", crate::render::forward_multipass::EMISSION));
    c.extend(GpuLightKind::ALL.iter().map(|k| (k.wgsl_name(), *k as u32)));
    c.extend(ShadingModel::ALL.iter().map(|m| (m.wgsl_name(), *m as u32)));
    c.push(("NO_TEXTURE", NO_TEXTURE));
    c.extend(DebugView::ALL.iter().map(|v| (v.wgsl_name(), *v as u32)));
    c.extend(TileCounter::ALL.iter().map(|t| (t.wgsl_name(), *t as u32)));
    c.push(("AGE_BUCKET_BASE", TileCounter::AGE_BUCKET_BASE as u32));
    c.push(("AGE_BUCKETS", TileCounter::AGE_BUCKETS as u32));
    c.push(("BLOCK_SIDE", BLOCK_SIDE));
    c.extend(VolumeList::ALL.iter().map(|l| (l.wgsl_name(), *l as u32)));
    c.push(("VOLUME_LISTS", VolumeList::ALL.len() as u32));
    c.extend(deferred_compute::wgsl_constants());
    c
}

/// The WGSL source of `shadespace::contract`.
pub fn wgsl() -> String {
    let mut s = String::from(
        "// Generated from the Rust definitions (src/shaders/contract.rs); do not edit.\n\
         #define_import_path shadespace::contract\n\n",
    );
    for (name, value) in constants() {
        writeln!(s, "const {name}: u32 = {value}u;").expect("writing to a String");
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_unique_and_values_come_from_rust() {
        let c = constants();
        let mut names: Vec<_> = c.iter().map(|(n, _)| *n).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), c.len(), "duplicate constant names: {c:?}");
        let get = |n: &str| c.iter().find(|(name, _)| *name == n).map(|(_, v)| *v);
        assert_eq!(get("MAX_LEVELS"), Some(MAX_LEVELS as u32));
        assert_eq!(get("LIGHT_SPOT"), Some(GpuLightKind::Spot as u32));
        assert_eq!(get("VIEW_CACHE_AGE"), Some(DebugView::CacheAge as u32));
        assert_eq!(get("COUNT_NEW"), Some(TileCounter::New as u32));
        assert!(wgsl().contains("const MAX_LEVELS: u32 = "));
    }
}
