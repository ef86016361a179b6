//! Triangle maps shared by a mesh's instances (issue 27, item 3): a page
//! copies the map of a page already holding the same mesh, level and page
//! instead of building it (`objectspace::trimap`). On the tiny city
//! (`city:2`) at 64x64, a renderer sharing maps and one building every map
//! are driven through the same frames: above the city, a jump down the
//! street (the instances seen only from above give their slots back at
//! once, their pages freed) and back above. Every frame
//! both give the same image and the same map on every backed page, and
//! from above the sharing one copies most maps. (That a renderer sharing
//! maps gives a fresh renderer's image after such frames is
//! `page_directory`'s test of slots given back.)

use crate::common;
use crate::page_directory::{City, city};

use shadespace::gpu::GpuContext;
use shadespace::render::objectspace::ObjectSpace;
use shadespace::render::{Counters, ObjectSpaceConfig, PipelineConfig, RenderOptions, Renderer};

const SIZE: u32 = 64;

fn renderer(ctx: &GpuContext, city: &City, trimap_share: bool) -> Renderer {
    // A slot timeout of 0 frames: the street's frame gives back the slots
    // of the instances seen only from above.
    let config =
        ObjectSpaceConfig { texture_sizes: city.sizes.clone(), slot_timeout: 0, trimap_share, ..Default::default() };
    Renderer::new(ctx, &city.scene, &RenderOptions::new(SIZE, SIZE, PipelineConfig::ObjectSpace(config))).unwrap()
}

fn counters(ctx: &GpuContext, r: &mut Renderer) -> Counters {
    r.collect_counters(ctx, true).pop().expect("the frame's counters").1
}

#[test]
fn instances_share_triangle_maps_and_nothing_else_changes() {
    let ctx = common::gpu();
    let city = city();
    let (mut shared, mut own) = (renderer(&ctx, city, true), renderer(&ctx, city, false));
    let frames = [("above", city.above), ("street", city.street), ("above again", city.above)];
    for (frame, &(name, camera)) in frames.iter().enumerate() {
        shared.render(&ctx, &camera, &city.lights, frame as u64).unwrap();
        own.render(&ctx, &camera, &city.lights, frame as u64).unwrap();
        let (s, o) = (counters(&ctx, &mut shared), counters(&ctx, &mut own));
        eprintln!(
            "{name}: pages backed {}, maps built {} and copied {} (each page building its own: {} built)",
            s["pages_backed"], s["trimap_pages"], s["trimap_shared"], o["trimap_pages"]
        );
        assert_eq!(s["pages_backed"], o["pages_backed"], "{name}");
        assert_eq!((o["trimap_pages"], o["trimap_shared"]), (o["pages_backed"], 0.0), "{name}");
        assert_eq!(s["trimap_pages"] + s["trimap_shared"], s["pages_backed"], "{name}");
        assert_eq!(s["pages_failed"], 0.0, "{name}");
        if camera == city.above {
            // Most of the city's pages from above are another instance's.
            assert!(s["trimap_shared"] > s["trimap_pages"], "{name}: too few maps copied");
        }
        let pages = |r: &Renderer| r.pipeline::<ObjectSpace>().unwrap().read_backed_pages(&ctx).unwrap();
        let (s_pages, o_pages) = (pages(&shared), pages(&own));
        assert_eq!(s_pages.len(), o_pages.len(), "{name}: backed pages");
        for ((page, (s_map, _)), (o_page, (o_map, _))) in s_pages.iter().zip(&o_pages) {
            assert_eq!(page, o_page, "{name}: backed pages");
            assert!(s_map == o_map, "{name}: virtual page {page}'s triangle map differs from the one it builds");
        }
        assert!(shared.read_image(&ctx).unwrap() == own.read_image(&ctx).unwrap(), "{name}: the images differ");
    }
    ctx.check_errors().unwrap();
}
