//! The renderer's shaders as one set: the shared modules its passes add to
//! `shaders/shared/`, the constants WGSL shares with its Rust (generated
//! into `shadespace::contract`), every pass shader, and the tests that check
//! them all without a GPU: every shader composes and validates, and every
//! host-shared struct matches its WGSL struct member by member.

use crate::render::deferred::volumes::VolumeList;
use crate::render::gpu_types::{GpuLightKind, NO_TEXTURE, ShadingModel};
use crate::render::objectspace::atlas::{BLOCK_SIDE, MAX_LEVELS};
use crate::render::objectspace::{DebugView, TileCounter};
use crate::render::{clustered, deferred, deferred_compute, forward, forward_multipass, objectspace, passes};
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

/// Shared modules of the render layer, in dependency order (after those of
/// `shaders/shared/`, which they may import).
pub const SHARED: &[ShaderSource] = &[
    passes::light_grid::SHARED_WGSL[0],
    passes::light_grid::SHARED_WGSL[1],
    objectspace::SHARED_WGSL[0],
    objectspace::SHARED_WGSL[1],
    objectspace::SHARED_WGSL[2],
    passes::gbuffer::SHARED_WGSL,
    passes::visibility::compute::SHARED_WGSL,
    passes::cluster_draws::SHARED_WGSL,
    deferred::SHARED_WGSL,
];

/// The shader library every pass of the renderer composes its shaders with.
pub fn library() -> Result<ShaderLibrary, ShaderError> {
    ShaderLibrary::new(&contract_constants(), SHARED)
}

/// (WGSL name, value) of every `u32` constant WGSL shares with Rust.
pub fn contract_constants() -> Vec<(&'static str, u32)> {
    let mut c = vec![("MAX_LEVELS", MAX_LEVELS as u32), ("TILE_COUNTER_SLOTS", TileCounter::SLOTS as u32)];
    c.push(("TILE_COUNTER_WORDS", TileCounter::WORDS as u32));
    c.push(("COUNTER_STRIPES", TileCounter::STRIPES as u32));
    c.push(("PAIR_EMISSION", forward_multipass::EMISSION));
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
    c.extend(crate::materials::wgsl_constants());
    c
}

/// Every pass shader, for the test that validates them all.
pub fn pass_shaders() -> Vec<ShaderSource> {
    let mut all =
        vec![forward::SHADER, passes::depth_prepass::SHADER, passes::visibility::SHADER, passes::tonemap::SHADER];
    all.extend([passes::shadows::SHADER, passes::blended::COMPOSITE_SHADER]);
    all.extend([forward_multipass::SHADER, passes::bloom::SHADER, passes::exposure::SHADER]);
    {
        use passes::visibility::compute::*;
        all.extend([RASTER, RASTER_CULLING, RASTER_COUNTING, RASTER_CULLING_COUNTING, CLEAR, RESOLVE, CULL, HIZ]);
        let msaa = &[crate::shaders::MSAA];
        let all_defs = &["CULL_BACK", "COUNT", crate::shaders::MSAA];
        all.extend([RASTER.with_defs(msaa), RASTER.with_defs(all_defs), RESOLVE.with_defs(msaa)]);
    }
    all.extend_from_slice(objectspace::PASS_SHADERS);
    all.extend(objectspace::mark::VARIANTS);
    all.extend(objectspace::paging::VARIANTS);
    all.extend(objectspace::trimap::VARIANTS);
    all.extend_from_slice(&passes::light_grid::PASS_SHADERS);
    all.push(clustered::SHADER);
    all.extend([
        passes::gbuffer::SHADER,
        deferred_compute::SHADER,
        deferred_compute::SHADER_VISIBILITY,
        deferred_compute::SHADER_MSAA,
        deferred_compute::SHADER_VISIBILITY_MSAA,
        deferred_compute::SHADER.with_defs(&["VISIBILITY_BUFFER", deferred_compute::SMALL_TILES]),
        deferred_compute::SHADER.with_defs(&[crate::shaders::MSAA, deferred_compute::SMALL_TILES]),
    ]);
    all.extend([
        objectspace::mark::SHADER.with_defs(&[crate::shaders::MSAA]),
        objectspace::gather::SHADER.with_defs(&[crate::shaders::MSAA]),
        objectspace::mark::SHADER.with_defs(&[crate::shaders::MSAA, crate::shaders::VISIBILITY_LAYERS]),
        objectspace::gather::SHADER.with_defs(&[crate::shaders::MSAA, crate::shaders::VISIBILITY_LAYERS]),
        objectspace::gather::SHADER.with_defs(&[objectspace::mark::PIXEL_RECORD]),
        objectspace::gather::SHADER.with_defs(&[objectspace::mark::PIXEL_RECORD, objectspace::gather::FORWARD_LIST]),
        objectspace::gather::SHADER.with_defs(&[
            objectspace::mark::PIXEL_RECORD,
            objectspace::gather::FORWARD_LIST,
            objectspace::gather::BILINEAR_ONLY,
        ]),
        objectspace::gather::SHADER.with_defs(&[
            objectspace::mark::PIXEL_RECORD,
            objectspace::gather::FORWARD_LIST,
            objectspace::gather::BILINEAR_ONLY,
            objectspace::gather::ISLAND_IN_ALPHA,
        ]),
        objectspace::gather::SHADER.with_defs(&[objectspace::gather::ISLAND_IN_ALPHA, crate::shaders::MSAA]),
        objectspace::shade::SHADER.with_defs(&[objectspace::shade::TILE_LIGHTS]),
        objectspace::gather::SHADER.with_defs(&[objectspace::gather::PIXEL_CLASSES]),
        objectspace::gather::SHADER.with_defs(&[objectspace::gather::PIXEL_CLASSES, crate::shaders::MSAA]),
        objectspace::gather::SHADER.with_defs(&[
            objectspace::gather::PIXEL_CLASSES,
            crate::shaders::MSAA,
            crate::shaders::VISIBILITY_LAYERS,
        ]),
        deferred::GLOBALS_SHADER.with_defs(&[crate::shaders::MSAA]),
        deferred::volumes::VOLUMES_SHADER.with_defs(&[crate::shaders::MSAA]),
    ]);
    all.extend_from_slice(deferred::PASS_SHADERS);
    all.push(passes::environment::SHADER);
    {
        use passes::cluster_draws::*;
        all.extend([ARGS, HIZ_DEPTH]);
        // The cluster-draw variants of the passes that cull.
        let draw: &'static [&'static str] = &["CLUSTER_DRAW"];
        all.extend([forward::SHADER, clustered::SHADER, passes::gbuffer::SHADER].map(|s| s.with_defs(draw)));
        all.extend([passes::depth_prepass::SHADER, passes::visibility::SHADER].map(|s| s.with_defs(draw)));
        // Scenes with both cull modes: each variant skips the other's objects.
        let indexed_single: &'static [&'static str] = &["CLUSTER_DRAW", INDEXED_DRAWS, SINGLE_SIDED_DRAW];
        let list_double: &'static [&'static str] = &["CLUSTER_DRAW", DOUBLE_SIDED_DRAW];
        all.extend([forward::SHADER.with_defs(indexed_single), forward::SHADER.with_defs(list_double)]);
        // The culling's indexed draws, for the camera and for the shadow faces.
        use passes::shadows::cull::SHADOW_FACES;
        let cull = passes::visibility::compute::CULL;
        all.extend([cull.with_defs(&[INDEXED_DRAWS]), cull.with_defs(&[INDEXED_DRAWS, SHADOW_FACES])]);
        all.push(passes::shadows::SHADER.with_defs(&[passes::shadows::cull::CLUSTER_DRAW]));
    }
    {
        use passes::background::*;
        all.extend([SHADER, SHADER_SAMPLES, SHADER_IDS, SHADER_ID_LAYERS]);
    }
    all
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::clusters::GpuCluster;
    use crate::render::deferred::volumes::GpuVolumeParams;
    use crate::render::forward_multipass::LightPair;
    use crate::render::gpu_types::{GpuLight, GpuObject, GpuVertex, GpuView};
    use crate::render::objectspace::atlas::{GpuAtlasEntry, GpuAtlasLevel};
    use crate::render::objectspace::atlas_view::GpuAtlasPages;
    use crate::render::objectspace::resources::GpuParams;
    use crate::render::objectspace::trimap::GpuChartGrid;
    use crate::render::passes::gbuffer::GpuUnproject;
    use crate::render::passes::light_grid::GpuLightGridParams;
    use crate::render::passes::visibility::compute::{
        GpuCullParams, GpuHizLevel, GpuListParams, GpuRasterParams, GpuResolveParams,
    };
    use crate::shaders::layout::check;
    use crate::shaders::{ALPHA_MASK, ENVIRONMENT, LAYERS, MATERIAL_TEXTURES};
    use wgpu::naga;

    /// Every pass shader, composed (with layers, so that their structs are in).
    fn modules() -> Vec<naga::Module> {
        let mut library = library().unwrap();
        library.define(LAYERS);
        pass_shaders().into_iter().map(|s| library.compose(s).unwrap()).collect()
    }

    /// Every pass shader composes and passes naga's validation, without a GPU,
    /// with and without the material textures, layers and an environment, and
    /// the scene raster passes' alpha-mask variants too.
    #[test]
    fn all_shaders_compose_and_validate() {
        let masked = passes::alpha_masked_shaders();
        let bits = |i: u32| (i & 1 != 0, i & 2 != 0, i & 4 != 0);
        let flags = [0, 1, 2, 3, 4, 7].map(bits);
        for (materials, layers, environment) in flags {
            let mut lib = library().expect("shared modules compose");
            if materials {
                lib.define(MATERIAL_TEXTURES);
            }
            if layers {
                lib.define(LAYERS);
            }
            if environment {
                lib.define(ENVIRONMENT);
            }
            let variants =
                pass_shaders().into_iter().map(|s| (s, &[][..])).chain(masked.iter().map(|s| (*s, &[ALPHA_MASK][..])));
            for (shader, extra) in variants {
                let module = lib.compose_with(shader, extra).unwrap_or_else(|e| panic!("{e}"));
                naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
                    .validate(&module)
                    .unwrap_or_else(|e| {
                        panic!(
                            "{} {extra:?} (material textures: {materials}, layers: {layers}, environment: {environment}): {e:?}",
                            shader.file
                        )
                    });
            }
        }
    }

    /// Every host-shared struct matches its WGSL struct member by member.
    #[test]
    fn rust_structs_match_wgsl_member_by_member() {
        let modules = modules();
        check::<GpuVertex>(&modules);
        check::<GpuObject>(&modules);
        check::<GpuView>(&modules);
        check::<GpuLight>(&modules);
        check::<GpuAtlasLevel>(&modules);
        check::<GpuAtlasEntry>(&modules);
        check::<GpuParams>(&modules);
        check::<GpuAtlasPages>(&modules);
        check::<GpuChartGrid>(&modules);
        check::<LightPair>(&modules);
        check::<GpuLightGridParams>(&modules);
        check::<GpuUnproject>(&modules);
        check::<GpuVolumeParams>(&modules);
        check::<GpuRasterParams>(&modules);
        check::<GpuResolveParams>(&modules);
        check::<GpuCullParams>(&modules);
        check::<GpuHizLevel>(&modules);
        check::<GpuListParams>(&modules);
        check::<GpuCluster>(&modules);
        check::<crate::materials::GpuLayer>(&modules);
        check::<crate::render::passes::environment::GpuEnvParams>(&modules);
        check::<crate::render::passes::background::GpuBackground>(&modules);
    }

    #[test]
    fn contract_names_are_unique_and_values_come_from_rust() {
        let c = contract_constants();
        let mut names: Vec<_> = c.iter().map(|(n, _)| *n).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), c.len(), "duplicate constant names: {c:?}");
        let get = |n: &str| c.iter().find(|(name, _)| *name == n).map(|(_, v)| *v);
        assert_eq!(get("MAX_LEVELS"), Some(MAX_LEVELS as u32));
        assert_eq!(get("LIGHT_SPOT"), Some(GpuLightKind::Spot as u32));
        assert_eq!(get("VIEW_CACHE_AGE"), Some(DebugView::CacheAge as u32));
        assert_eq!(get("COUNT_NEW"), Some(TileCounter::New as u32));
    }
}
