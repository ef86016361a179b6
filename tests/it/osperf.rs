//! The object-space variants of issue 25's remaining overhead change what is
//! recorded, not what is computed: the fused paging chain (`--os-paging
//! fused`), the triangle-map pass with several lanes per texel
//! (`--os-trimap-lanes`), the triangle maps of levels up to a size copied
//! from maps stored once per mesh (`--os-trimap-store`) and the gather
//! reading marking's pixel records (`--os-gather record`) mark, back, build
//! and shade what the default does,
//! frame by frame along a path (tile stamps, shade queue, counters, every
//! backed texel's triangle and shade, the image bit for bit), and the fused
//! chain records three dispatches fewer in each frame that backs pages.

use crate::common;

use shadespace::gpu::GpuContext;
use shadespace::render::objectspace::debug::BackedPages;
use shadespace::render::objectspace::{GatherInput, ObjectSpace, PagingChain, TileCounter};
use shadespace::render::{ObjectSpaceConfig, PipelineConfig, RenderOptions, Renderer};
use shadespace::scene::{Camera, Light, Scene};

/// The passes the fused chain does not record (its paging writes the shade
/// pass's dispatch, the queue stage's).
const SPLIT_ONLY: [&str; 2] = ["object space/mark backed", "object space/queue"];
/// The stage that builds the stored triangle maps, in the first frame.
const STORE_STAGE: &str = "object space/stored triangle maps";

/// One frame's state: tile stamps per virtual tile, the queue sorted, the
/// counters, and the triangle maps and shades of the backed pages.
struct FrameState {
    tile_visible: Vec<u32>,
    tile_shaded: Vec<u32>,
    queue: Vec<[u32; 2]>,
    counters: Vec<u32>,
    pages: BackedPages,
}

/// A run's states after each frame, its last image, and the passes each
/// frame recorded (names, in order).
struct RunResult {
    states: Vec<FrameState>,
    image: image::RgbaImage,
    passes: Vec<Vec<String>>,
}

struct Case<'a> {
    name: &'static str,
    scene: &'a Scene,
    texture_sizes: Vec<Option<u32>>,
    cameras: Vec<Camera>,
    lights: Vec<Light>,
}

const WIDTH: u32 = 160;
const HEIGHT: u32 = 90;

/// A variant: paging chain, triangle-map lanes, gather input, widest level
/// of stored triangle maps.
type Variant = (PagingChain, u32, GatherInput, u32);

fn run(ctx: &GpuContext, case: &Case, (paging_chain, trimap_lanes, gather_input, store): Variant) -> RunResult {
    let config = ObjectSpaceConfig {
        reuse: 2,
        texture_sizes: case.texture_sizes.clone(),
        paging_chain,
        trimap_lanes: Some(trimap_lanes),
        trimap_store: Some(store),
        gather_input,
        ..Default::default()
    };
    let options =
        RenderOptions { width: WIDTH, height: HEIGHT, pipeline: PipelineConfig::ObjectSpace(config), samples: 1 };
    let mut renderer = Renderer::new(ctx, case.scene, &options).unwrap();
    let mut states = Vec::new();
    for (frame, camera) in case.cameras.iter().enumerate() {
        renderer.render(ctx, camera, &case.lights, frame as u64).unwrap();
        let os = renderer.pipeline::<ObjectSpace>().unwrap();
        let mark = os.read_mark_state(ctx).unwrap();
        let mut queue = mark.queue;
        queue.sort_unstable();
        let pages = os.read_backed_pages(ctx).unwrap();
        let (tile_visible, tile_shaded, counters) = (mark.tile_visible, mark.tile_shaded, mark.counters.to_vec());
        states.push(FrameState { tile_visible, tile_shaded, queue, counters, pages });
    }
    let image = renderer.read_image(ctx).unwrap();
    let timings = renderer.collect_timings(ctx, true);
    ctx.check_errors().unwrap();
    let passes = timings.into_iter().map(|t| t.passes.into_iter().map(|(name, _)| name).collect()).collect();
    RunResult { states, image, passes }
}

/// Each of `variants` against the default, frame by frame.
fn compare(ctx: &GpuContext, case: &Case, variants: &[Variant]) {
    let name = case.name;
    let default = run(ctx, case, (PagingChain::Split, 1, GatherInput::Surface, 0));
    let backed = |s: &FrameState| s.counters[TileCounter::PagesBacked as usize];
    assert!(default.states.iter().all(|s| backed(s) > 0), "{name}: a frame backed no page (nothing to compare)");
    for &(chain, lanes, gather, store) in variants {
        let at = format!(
            "{name}, --os-paging {chain:?} --os-trimap-lanes {lanes} --os-gather {gather:?} --os-trimap-store {store}"
        );
        let variant = run(ctx, case, (chain, lanes, gather, store));
        for (frame, (a, b)) in default.states.iter().zip(&variant.states).enumerate() {
            assert!(a.tile_visible == b.tile_visible, "{at}, frame {frame}: tile_visible differs");
            assert!(a.tile_shaded == b.tile_shaded, "{at}, frame {frame}: tile_shaded differs");
            assert!(a.queue == b.queue, "{at}, frame {frame}: the shade queues differ");
            // Every counter but the triangle-map pass's, which count work,
            // not state: the ring search's lanes each stop on their own
            // share, and two instances' pages backed in one frame with the
            // same map may both build it or one copy it (the same maps).
            let state = |c: &[u32]| {
                let mut c = c.to_vec();
                for work in [TileCounter::TrimapWeighed, TileCounter::TrimapPages, TileCounter::TrimapShared] {
                    c[work as usize] = 0;
                }
                c
            };
            assert_eq!(state(&a.counters), state(&b.counters), "{at}, frame {frame}: the counters differ");
            assert!(a.pages.keys().eq(b.pages.keys()), "{at}, frame {frame}: the backed pages differ");
            for ((page, (ta, sa)), (tb, sb)) in a.pages.iter().zip(b.pages.values()) {
                assert!(ta == tb, "{at}, frame {frame}: virtual page {page}'s triangle map differs");
                assert!(sa == sb, "{at}, frame {frame}: virtual page {page}'s shades differ");
            }
        }
        assert!(default.image == variant.image, "{at}: the last frame's image differs");
        // The passes and stages each frame recorded: the fused chain lacks
        // mark backed and the queue, and with stored maps the first frame
        // builds them.
        for (frame, (a, b)) in default.passes.iter().zip(&variant.passes).enumerate() {
            let expected: Vec<&String> = if chain == PagingChain::Fused {
                a.iter().filter(|p| !SPLIT_ONLY.contains(&p.as_str())).collect()
            } else {
                a.iter().collect()
            };
            let built = |p: &&String| p.as_str() != STORE_STAGE;
            assert_eq!(b.iter().any(|p| p == STORE_STAGE), store > 0 && frame == 0, "{at}, frame {frame}");
            assert_eq!(expected, b.iter().filter(built).collect::<Vec<_>>(), "{at}: the recorded passes");
        }
        eprintln!(
            "{at}: same state over {} frames; passes per frame {} (default {})",
            variant.states.len(),
            variant.passes[0].len(),
            default.passes[0].len()
        );
    }
    assert!(default.passes.iter().all(|p| SPLIT_ONLY.iter().all(|s| p.iter().any(|q| q == s))));
}

/// The atrium along its path (frames 0, 12, 24), and Sponza where the
/// shared scenes are present.
#[test]
fn fused_paging_and_triangle_map_lanes_change_nothing() {
    let ctx = common::gpu();
    let aspect = WIDTH as f32 / HEIGHT as f32;
    let scene = common::load("atrium");
    let (cameras, lights) = common::path_views("atrium", &scene, aspect, 3, "small:4");
    let (charted, texture_sizes) = common::charted(&scene);
    // Each shader variant once: the fused chain's marking in the one-lane
    // and in the several-lane triangle-map pass.
    let variants = [
        (PagingChain::Fused, 1, GatherInput::Surface, 64),
        (PagingChain::Split, 4, GatherInput::Record, 0),
        (PagingChain::Fused, 8, GatherInput::Record, 0),
        (PagingChain::Fused, 2, GatherInput::Record, 64),
    ];
    compare(&ctx, &Case { name: "atrium", scene: &charted, texture_sizes, cameras, lights }, &variants);

    const SPONZA: &str = "../shared/scenes/sponza-thesis";
    if !std::path::Path::new(SPONZA).is_dir() {
        eprintln!("SKIPPED (Sponza part): {SPONZA} is absent");
        return;
    }
    let scene = common::load(SPONZA);
    let (cameras, lights) = common::path_views(SPONZA, &scene, aspect, 2, "small:4");
    let (charted, texture_sizes) = common::charted_for(&scene, &cameras[0], WIDTH, HEIGHT);
    // Sponza's charts and pages, with the fused chain and 8 lanes, and with
    // maps stored up to 64 texels (one lane: lavapipe builds them slowly).
    let variants = [variants[2], (PagingChain::Fused, 1, GatherInput::Record, 64)];
    compare(&ctx, &Case { name: "sponza", scene: &charted, texture_sizes, cameras, lights }, &variants);
}
