//! Paging that costs nothing when nothing is requested (issue 25): the
//! passes of the paging chain whose work follows the atlas's pages or the
//! table's chunks are dispatched indirectly, with arguments the GPU writes
//! from the frame's requests, so a frame that requests no page dispatches no
//! workgroup of them; a frame that requests pages dispatches all of them.

use crate::common;

use shadespace::render::objectspace::ObjectSpace;
use shadespace::render::objectspace::debug::PagingDispatches;
use shadespace::render::{Counters, ObjectSpaceConfig, PipelineConfig, RenderOptions, Renderer};
use shadespace::scene::Camera;

/// The floor at 160x120, every visible tile shaded every frame (`--reuse 1`:
/// no frame is quiet, so paging is recorded in every frame), as
/// `objectspace.rs` renders it.
fn options() -> RenderOptions {
    let config = ObjectSpaceConfig { reuse: 1, texture_sizes: vec![Some(512)], ..Default::default() };
    RenderOptions { width: 160, height: 120, pipeline: PipelineConfig::ObjectSpace(config), samples: 1 }
}

/// Renders frame `number` seen by `camera`; returns its counters and the
/// workgroups its paging chain dispatched.
fn frame(
    ctx: &shadespace::GpuContext,
    os: &mut Renderer,
    camera: &Camera,
    lights: &[shadespace::scene::Light],
    number: u64,
) -> (Counters, PagingDispatches) {
    os.render(ctx, camera, lights, number).unwrap();
    let mut counters = os.collect_counters(ctx, true);
    assert_eq!(counters.len(), 1, "frame {number}: one frame's counters");
    let dispatches = os.pipeline::<ObjectSpace>().unwrap().read_paging_dispatches(ctx).unwrap();
    ctx.check_errors().unwrap();
    (counters.pop().unwrap().1, dispatches)
}

/// A frame that requested pages dispatches every paging pass: the ranking
/// over every physical page, the offsets, the allocation over the requests,
/// and the chunk release over the chunks below the mark (every chunk in use
/// lies below it).
fn assert_pages_dispatched(c: &Counters, d: &PagingDispatches, what: &str) {
    let requested = c["pages_requested"] as u32;
    let pages = c["atlas_pages"] as u32;
    assert_eq!(d.rank, pages.div_ceil(64), "{what}: ranking {d:?}");
    assert_eq!(d.offsets, 1, "{what}: offsets {d:?}");
    assert!(d.release <= d.chunk_mark.div_ceil(64), "{what}: chunk release past the mark {d:?}");
    let chunks = c["table_chunks"] as u32;
    assert!(chunks > 0 && chunks <= d.chunk_mark, "{what}: {chunks} chunks in use, {d:?}");
    assert_eq!(d.allocate, requested.div_ceil(64), "{what}: allocation {d:?}");
    assert_eq!(d.backed, c["pages_backed"] as u32, "{what}: backed pages' passes {d:?}");
}

#[test]
fn paging_dispatches_nothing_while_no_page_is_requested() {
    const STATIC: u64 = 6;
    let ctx = common::gpu();
    let (scene, camera, lights) = common::floor_scene();
    let mut os = Renderer::new(&ctx, &scene, &options()).unwrap();
    let mut frames = Vec::new();
    for f in 0..STATIC {
        frames.push(frame(&ctx, &mut os, &camera, &lights, f));
    }
    let get = |name: &str| frames.iter().map(|(c, _)| c[name]).collect::<Vec<_>>();
    let (requested, atlas) = (get("pages_requested"), get("atlas_pages"));
    eprintln!("static: requested {requested:?}, atlas pages {atlas:?}");
    eprintln!("dispatches {:?}", frames.iter().map(|(_, d)| d).collect::<Vec<_>>());
    assert!(requested[0] > 0.0, "the first frame requests its pages");
    assert_pages_dispatched(&frames[0].0, &frames[0].1, "frame 0");
    // No chunk was taken before: none to free, whatever the table's size.
    assert_eq!(frames[0].1.release, 0, "frame 0 looked for chunks to free");
    // After the first frames (the atlas shrinks to the floor's pages, which
    // may evict some to be requested again) nothing is requested.
    assert!(requested[STATIC as usize - 3..].iter().all(|&r| r == 0.0), "a static view requests pages");
    for (f, (c, d)) in frames.iter().enumerate().skip(1) {
        if c["pages_requested"] > 0.0 {
            assert_pages_dispatched(c, d, &format!("frame {f}"));
        } else if atlas[f] != atlas[f - 1] {
            // A resize unbinds pages outside paging: their chunks are freed
            // this frame, with nothing else.
            assert_eq!((d.rank, d.offsets, d.allocate, d.backed), (0, 0, 0, 0), "frame {f}: resized, {d:?}");
            assert!(d.release > 0, "frame {f}: the resize's empty chunks are not freed");
        } else {
            assert_eq!(d.total(), 0, "frame {f}: no page requested, yet {d:?}");
        }
    }

    // Towards the floor: finer levels, new pages each frame, all dispatched.
    let mut requesting = 0;
    for (k, t) in [0.8f32, 0.6, 0.45].into_iter().enumerate() {
        let near = Camera { position: camera.position * t, ..camera };
        let (c, d) = frame(&ctx, &mut os, &near, &lights, STATIC + k as u64);
        eprintln!("moving {k}: requested {}, backed {}, {d:?}", c["pages_requested"], c["pages_backed"]);
        if c["pages_requested"] > 0.0 {
            requesting += 1;
            assert!(c["pages_backed"] > 0.0, "moving frame {k}: requested pages, backed none");
            assert_pages_dispatched(&c, &d, &format!("moving frame {k}"));
            assert!(d.release > 0, "moving frame {k}: the chunks in use were not looked at");
        }
    }
    assert_eq!(requesting, 3, "a camera moving towards the floor requested no page in some frame");
}
