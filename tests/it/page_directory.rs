//! Object space's page directory (issue 27, item 3): page-table space for
//! the instances in view only, a slot each, given back after they leave it
//! (`objectspace::slots`). On the tiny city (`city:2`, 248 instances) at
//! 64x64, seen down a street (a few blocks) and from above (all of it).

use crate::common;
use std::path::Path;

use shadespace::gpu::GpuContext;
use shadespace::render::objectspace::ObjectSpace;
use shadespace::render::objectspace::atlas::BLOCK_PAGES;
use shadespace::render::{Counters, ObjectSpaceConfig, PipelineConfig, RenderOptions, Renderer};
use shadespace::scene::{self, Camera, Light, Scene, path};

const SIZE: u32 = 64;

/// The tiny city charted for two cameras (also `trimap_share`'s).
pub(crate) struct City {
    pub(crate) scene: Scene,
    pub(crate) sizes: Vec<Option<u32>>,
    pub(crate) street: Camera,
    pub(crate) above: Camera,
    pub(crate) lights: Vec<Light>,
}

/// The tiny city charted for both cameras (as the CLI sizes for a path),
/// made once for the tests that use it (a second each).
pub(crate) fn city() -> &'static City {
    static CITY: std::sync::OnceLock<City> = std::sync::OnceLock::new();
    CITY.get_or_init(make_city)
}

fn make_city() -> City {
    use shadespace::charts::{self, ChartCache, ChartSettings};
    let scene = common::load("city:2");
    let cameras = path::cameras_for_scene("city:2", &scene, 1.0).unwrap();
    // Down the cross street (its second leg): 44 of the 248 instances in view.
    let street = cameras.select(path::CameraChoice::Path).unwrap().camera_at(500);
    let above = cameras.select(path::CameraChoice::Flyover).unwrap().camera_at(0);
    let cache = ChartCache::in_dir(Path::new(env!("CARGO_TARGET_TMPDIR")).join("charts"));
    let sizings = charts::screen_sizings(&scene, &[street, above], SIZE, SIZE, 64, 8192);
    let c = charts::chart_scene_sized(&scene, &sizings, &charts::PACKING_SIZING, &ChartSettings::default(), &cache)
        .unwrap();
    let spec = "small:8".parse().unwrap();
    let lights = scene::lights::build_lights(&spec, &scene.bounds(), &street, 1.0, 3).unwrap();
    City { scene: c.apply(&scene), sizes: c.texture_sizes(), street, above, lights }
}

fn renderer(ctx: &GpuContext, city: &City, slot_timeout: u32) -> Renderer {
    let config = ObjectSpaceConfig { texture_sizes: city.sizes.clone(), slot_timeout, ..Default::default() };
    let options = RenderOptions::new(SIZE, SIZE, PipelineConfig::ObjectSpace(config));
    Renderer::new(ctx, &city.scene, &options).unwrap()
}

fn counters(ctx: &GpuContext, r: &mut Renderer) -> Counters {
    let mut c = r.collect_counters(ctx, true);
    c.pop().expect("the frame's counters").1
}

/// The slots (first page, end) of the objects holding one.
fn slots(r: &Renderer) -> Vec<(usize, [u32; 2])> {
    let os = r.pipeline::<ObjectSpace>().unwrap();
    (os.layout.objects.iter().enumerate())
        .filter_map(|(o, a)| a.as_ref().and_then(|a| a.slot.map(|s| (o, [s, s + a.span]))))
        .collect()
}

/// Every page-directory word in use and every backed page lies in the slot
/// of an object holding one, and the page table is consistent.
fn check_table_within_slots(ctx: &GpuContext, r: &Renderer, at: &str) {
    let table = r.pipeline::<ObjectSpace>().unwrap().read_page_table(ctx).unwrap();
    let problems = table.inconsistencies();
    assert!(problems.is_empty(), "{at}: {problems:?}");
    let slotted = slots(r);
    let in_slot = |page: u32| slotted.iter().any(|(_, [s, e])| (*s..*e).contains(&page));
    for (block, &word) in table.directory.iter().enumerate() {
        assert!(word == 0 || in_slot(block as u32 * BLOCK_PAGES), "{at}: directory word {block} outside every slot");
    }
    for &owner in &table.owners {
        assert!(owner == 0 || in_slot(owner - 1), "{at}: page {} backed outside every slot", owner - 1);
    }
}

/// Down the cross street a few blocks are in view, from above the whole
/// city: the objects given a slot follow what each camera's frustum holds,
/// and the virtual pages in slots the levels its pixels can pick (from
/// above, only coarse ones); every page-table word in use and every backed
/// page lies in a slot, and no page fails.
#[test]
fn the_page_directory_holds_the_instances_in_view() {
    let ctx = common::gpu();
    let city = city();
    let in_atlas = city.sizes.iter().flatten().count();
    let mut seen = Vec::new();
    for (name, camera) in [("street", city.street), ("above", city.above)] {
        let mut r = renderer(&ctx, city, 60);
        r.render(&ctx, &camera, &city.lights, 0).unwrap();
        ctx.check_errors().unwrap();
        let c = counters(&ctx, &mut r);
        let slotted = slots(&r);
        let os = r.pipeline::<ObjectSpace>().unwrap();
        let every: u64 = os.layout.objects.iter().flatten().map(|a| a.span as u64).sum();
        let pages: u64 = slotted.iter().map(|(_, [s, e])| (e - s) as u64).sum();
        eprintln!(
            "{name}: {} of {in_atlas} objects slotted, {pages} of {every} virtual pages, directory {} pages, {c:?}",
            slotted.len(),
            os.layout.page_count
        );
        assert_eq!(c["slotted_objects"] as usize, slotted.len(), "{name}");
        assert_eq!(c["slot_pages"] as u64, pages, "{name}");
        assert_eq!((c["pages_failed"], c["unslotted_objects"]), (0.0, 0.0), "{name}");
        assert!(c["pages_in_use"] > 0.0, "{name}");
        check_table_within_slots(&ctx, &r, name);
        seen.push((slotted.len(), pages, every));
    }
    let [(street, street_pages, every), (above, above_pages, _)] = seen[..] else { unreachable!() };
    assert!(street * 4 < above, "street {street} objects, above {above}");
    // From above every object is far: its slot holds only its coarse levels.
    assert!(above_pages * 10 < every, "{above_pages} of {every} pages from above");
    // Down the street the nearest facades need their finest levels.
    assert!(street_pages > 10 * above_pages, "{street_pages} pages down the street");
}

/// From above, then down the street with a slot timeout of 2 frames: the
/// objects out of the street's view keep their slots two frames, give them
/// back on the third (their pages freed, the table still consistent), and
/// back above they take slots again and the image is the one a fresh
/// renderer gives.
#[test]
fn an_instance_out_of_view_gives_its_slot_back_after_its_timeout() {
    let ctx = common::gpu();
    let city = city();
    let mut r = renderer(&ctx, city, 2);
    r.render(&ctx, &city.above, &city.lights, 0).unwrap();
    let above: Vec<usize> = slots(&r).iter().map(|(o, _)| *o).collect();
    let mut kept = Vec::new();
    for frame in 1..=3 {
        r.render(&ctx, &city.street, &city.lights, frame).unwrap();
        kept.push(slots(&r).len());
        check_table_within_slots(&ctx, &r, &format!("street frame {frame}"));
    }
    r.collect_counters(&ctx, true);
    let street = kept[2];
    eprintln!("slotted: {} above, then down the street {kept:?}", above.len());
    // The street's own objects join the slots; those from above stay two frames.
    assert!(kept[0] >= above.len() && kept[1] == kept[0], "slots kept for the timeout");
    assert!(street * 2 < above.len(), "slots given back: {street} of {}", above.len());
    r.render(&ctx, &city.above, &city.lights, 4).unwrap();
    check_table_within_slots(&ctx, &r, "back above");
    let again: Vec<usize> = slots(&r).iter().map(|(o, _)| *o).collect();
    assert!(above.iter().all(|o| again.contains(o)), "every object in view from above has a slot again");
    let c = counters(&ctx, &mut r);
    assert_eq!(c["pages_failed"], 0.0);
    let image = r.read_image(&ctx).unwrap();
    let mut fresh = renderer(&ctx, city, 2);
    fresh.render(&ctx, &city.above, &city.lights, 0).unwrap();
    let expected = fresh.read_image(&ctx).unwrap();
    ctx.check_errors().unwrap();
    assert!(image == expected, "the image back above differs from a fresh renderer's");
}
