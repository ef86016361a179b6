//! Shade evaluation and shade gathering on the GPU against their CPU twins
//! (`render::objectspace::cpu::{shade, gather}`), one frame each:
//!
//! - shade: every texel of every tile queued this frame, read back from the
//!   atlas, against the Phong shade of its triangle (from the triangle map)
//!   at its barycentrics, within [`shade::SHADE_ULPS`]; texels no
//!   triangle covers must be black;
//! - gather: every pixel of the frame (HDR, read back) against the twin's
//!   level, taps, weights and island filter over the shades read back,
//!   within [`gather::COLOR_ULPS`] plus what the bilinear coordinate's
//!   rounding may move; background pixels must be black.
//!
//! Each failure names the stage and the first differing pixel or texel with
//! what the twin computed there. What the tests read from the GPU: the
//! visibility buffer, the shade queue (`ObjectSpace::read_mark_state`), the
//! atlas and triangle maps of the backed pages (`ObjectSpace::read_levels`)
//! and the HDR target (`Renderer::targets.hdr`, `Rgba16Float`).

use crate::common;
use std::collections::BTreeMap;

use glam::{UVec2, Vec3};
use shadespace::gpu::{GpuContext, readback};
use shadespace::render::gpu_types::GpuLight;
use shadespace::render::objectspace::cpu::gather::{self, GatherOutcome, GatherTaps, PixelGather};
use shadespace::render::objectspace::cpu::{self, LevelTexels, MarkInputs, SampleGroup, shade};
use shadespace::render::objectspace::{GatherFilter, MsaaGather, ObjectSpace};
use shadespace::render::scene_gpu::{gpu_view, order_lights};
use shadespace::render::{ObjectSpaceConfig, PipelineConfig, RenderOptions, Renderer};
use shadespace::scene::{Camera, Light, LightSpec, Scene, lights, path};

/// The least share of its bound the GPU's colour `got` uses against some
/// combination of the groups' outcomes (each group's weight in the
/// resolve, its outcomes): the weighted sum of their colours, within the
/// weighted sum of their bounds (one group of weight 1: its outcome's
/// bound alone), plus [`gather::COLOR_ULPS`] of the resolved value where
/// there are several.
fn resolve_bound_used(groups: &[(f32, &Vec<GatherOutcome>)], got: Vec3) -> f32 {
    let mut combos: Vec<(Vec3, Vec3)> = vec![(Vec3::ZERO, Vec3::ZERO)];
    for (w, outcomes) in groups {
        combos = combos
            .iter()
            .flat_map(|(c, b)| {
                outcomes
                    .iter()
                    .map(move |o| (*c + o.color().expect("checked") * *w, *b + o.bound().expect("checked") * *w))
            })
            .collect();
    }
    combos
        .into_iter()
        .map(|(want, mut bound)| {
            if groups.len() > 1 {
                bound += Vec3::from_array(want.to_array().map(|c| gather::COLOR_ULPS * cpu::f16_ulp(c)));
            }
            (0..3).map(|i| (got[i] - want[i]).abs() / bound[i]).fold(0.0, f32::max)
        })
        .fold(f32::INFINITY, f32::min)
}

/// One frame to render and check.
struct Case<'a> {
    name: &'static str,
    scene: &'a Scene,
    texture_sizes: Vec<Option<u32>>,
    camera: Camera,
    lights: Vec<Light>,
    width: u32,
    height: u32,
    mip_bias: f32,
    /// `ObjectSpaceConfig::level_blend`.
    level_blend: f32,
    /// `ObjectSpaceConfig::gather_filter`.
    gather_filter: GatherFilter,
    /// `ObjectSpaceConfig::texel_samples`.
    texel_samples: u32,
    /// `ObjectSpaceConfig::aniso`.
    aniso: u32,
    /// Samples per pixel, and which of them are gathered as one point
    /// (`ObjectSpaceConfig::msaa_gather`).
    samples: u32,
    msaa_gather: MsaaGather,
    /// Check the shade stage too (the scene has no textures).
    shade: bool,
}

/// What a frame's check saw, to make sure it exercised something.
#[derive(Debug, Default)]
struct Report {
    /// Texels of queued tiles compared, and those no triangle covers.
    texels: usize,
    empty_texels: usize,
    /// Pixels compared, of which some taps were left out by the island filter.
    pixels: usize,
    filtered_pixels: usize,
    /// Pixels not compared: a fragile island filter, a tap not backed.
    skipped_pixels: usize,
    /// Pixels per level read (a blended pixel counts in both).
    levels: BTreeMap<u32, usize>,
    /// Pixels that blend two levels.
    blended_pixels: usize,
    /// Pixels gathered at more than one anisotropic tap.
    aniso_pixels: usize,
    /// Under MSAA: pixels gathered at more than one point.
    edge_pixels: usize,
    /// Largest shade difference, in `Rgba16Float` units in the last place.
    worst_shade: f32,
    /// Largest share of its bound a pixel's colour difference uses.
    worst_gather: f32,
}

fn describe_outcome(o: &GatherOutcome) -> String {
    let levels: Vec<String> = o.taps().map(describe).collect();
    format!("blend weight {}, {} taps along {:?}, of [{}]", o.pair.t, o.taps.count, o.taps.axis, levels.join("; "))
}

fn describe(t: &GatherTaps) -> String {
    let taps: Vec<String> = t.taps.iter().map(|p| format!("({}, {})", p.x, p.y)).collect();
    format!(
        "level {}, taps [{}], weights {:?}, kept {:?}, colour {:?}",
        t.level,
        taps.join(", "),
        t.weights,
        t.kept,
        t.color.map(|c| c.to_array())
    )
}

fn check(ctx: &GpuContext, case: Case) -> Report {
    let objectspace = ObjectSpaceConfig {
        texture_sizes: case.texture_sizes.clone(),
        mip_bias: case.mip_bias,
        level_blend: case.level_blend,
        gather_filter: case.gather_filter,
        texel_samples: case.texel_samples,
        aniso: case.aniso,
        msaa_gather: case.msaa_gather,
        ..Default::default()
    };
    let options = RenderOptions {
        width: case.width,
        height: case.height,
        pipeline: PipelineConfig::ObjectSpace(objectspace.clone()),
        samples: case.samples,
    };
    let mut renderer = Renderer::new(ctx, case.scene, &options).unwrap();
    renderer.render(ctx, &case.camera, &case.lights, 0).unwrap();
    let os = renderer.pipeline::<ObjectSpace>().unwrap();
    let gpu = os.read_mark_state(ctx).unwrap();
    let hdr: Vec<half::f16> =
        bytemuck::pod_collect_to_vec(&readback::read_texture(ctx, &renderer.targets.hdr, 8).unwrap());
    let name = case.name;

    let view = gpu_view(&case.camera, case.width, case.height);
    let entries = os.layout.gpu_entries();
    let params = os.mark_params(&gpu);
    let inputs = MarkInputs { scene: case.scene, view: &view, entries: &entries, params };
    let islands = common::chart_islands(case.scene);

    // The levels the pixels gather from and the queued tiles lie in, read at once.
    let pixel = |i: usize| UVec2::new(i as u32 % case.width, i as u32 / case.width);
    // Each pixel's groups of samples gathered as one point (one group at its
    // centre with one sample).
    let n = case.samples as usize;
    let groups: Vec<Vec<SampleGroup>> =
        gpu.visibility.chunks_exact(n).map(|s| cpu::sample_groups(&islands, s, case.msaa_gather)).collect();
    let mut wanted: Vec<(usize, u32)> = groups
        .iter()
        .enumerate()
        .flat_map(|(i, g)| g.iter().flat_map(move |g| gather::pixel_levels_at(&inputs, pixel(i), g.at, g.ids)))
        .collect();
    let queued: Vec<(usize, u32, u32)> =
        gpu.queue.iter().map(|&[tile, code]| ((code >> 8) as usize, code & 0xff, tile)).collect();
    if case.shade {
        wanted.extend(queued.iter().map(|&(object, level, _)| (object, level)));
    }
    wanted.sort_unstable();
    wanted.dedup();
    let read: Vec<(usize, usize)> = wanted.iter().map(|&(o, l)| (o, l as usize)).collect();
    let levels: BTreeMap<(usize, u32), LevelTexels> =
        wanted.into_iter().zip(os.read_levels(ctx, &read).unwrap()).collect();
    let mut report = Report::default();

    if case.shade {
        let (ordered, _) = order_lights(&case.lights);
        let lights: Vec<GpuLight> = ordered.iter().map(GpuLight::from).collect();
        let tile = params.tile_size;
        for &(object, level, global_tile) in &queued {
            let l = entries[object].levels[level as usize];
            let texels = &levels[&(object, level)];
            let per_row = l.size / tile;
            let local = global_tile - l.tile_base;
            let origin = UVec2::new(local % per_row, local / per_row) * tile;
            for i in 0..tile * tile {
                let texel = origin + UVec2::new(i % tile, i / tile);
                let at = texels.index(texel.as_ivec2());
                let where_ =
                    format!("shade ({name}): texel ({}, {}) of object {object} level {level}", texel.x, texel.y);
                let id = texels.triangles[at].unwrap_or_else(|| panic!("{where_}: queued, but its page is not backed"));
                let got = texels.shades[at].expect("backed");
                // The alpha codes the texel's chart island for the gather.
                let code = if id == 0 { 0.0 } else { cpu::island_code(islands[object][id as usize - 1]) };
                assert_eq!(got[3], code, "{where_}: alpha");
                let got = Vec3::from_slice(&got[..3]);
                report.texels += 1;
                if id == 0 {
                    report.empty_texels += 1;
                    assert_eq!(got, Vec3::ZERO, "{where_}: no triangle covers it, yet it is not black");
                    continue;
                }
                // The texel's centre, for the failure message.
                let s = shade::texel_surface(case.scene, object, l.size, texel, id as usize - 1);
                let side = objectspace.texel_sample_side();
                let want = shade::texel_shade(
                    case.scene,
                    object,
                    (l.size, side),
                    texel,
                    id as usize - 1,
                    &lights,
                    case.camera.position,
                );
                let ulps = shade::shade_ulps(got, want);
                report.worst_shade = report.worst_shade.max(ulps);
                assert!(
                    ulps <= shade::SHADE_ULPS,
                    "{where_} (triangle {}, barycentrics {:?}, position {:?}, normal {:?}): GPU {:?}, twin {:?}: {ulps} \
                     units in the last place apart, more than {}",
                    s.triangle,
                    s.b.to_array(),
                    s.position.to_array(),
                    s.normal.to_array(),
                    got.to_array(),
                    want.to_array(),
                    shade::SHADE_ULPS
                );
            }
        }
    }

    let mut first_difference = None;
    let mut differing = 0;
    for (i, groups) in groups.iter().enumerate() {
        let p = pixel(i);
        let got = Vec3::new(hdr[4 * i].to_f32(), hdr[4 * i + 1].to_f32(), hdr[4 * i + 2].to_f32());
        // Each group on a surface: its weight in the resolve and its gather.
        let gathers: Vec<(f32, [u32; 2], PixelGather)> = groups
            .iter()
            .filter(|g| g.ids[0] != 0)
            .map(|g| {
                let gathered = gather::gather_pixel_at(&inputs, &islands, p, g.at, g.ids, |o, l| &levels[&(o, l)]);
                (g.count as f32 / n as f32, g.ids, gathered)
            })
            .collect();
        if gathers.is_empty() {
            assert_eq!(got, Vec3::ZERO, "gather ({name}): background pixel ({}, {}) is not black", p.x, p.y);
            continue;
        }
        let mut outcomes: Vec<(f32, &Vec<GatherOutcome>)> = Vec::new();
        for (w, _, g) in &gathers {
            match g {
                PixelGather::Atlas(o) => outcomes.push((*w, o)),
                // Shaded forward (not twinned), or a background group.
                _ => break,
            }
        }
        if outcomes.len() < gathers.len() {
            continue;
        }
        if outcomes.iter().any(|(_, o)| o.iter().any(|o| o.fragile() || o.color().is_none())) {
            report.skipped_pixels += 1;
            continue;
        }
        report.pixels += 1;
        report.edge_pixels += usize::from(groups.len() > 1);
        let first = &outcomes[0].1[0];
        for level in first.pair.levels() {
            *report.levels.entry(level).or_default() += 1;
        }
        report.blended_pixels += usize::from(first.pair.levels().len() == 2);
        report.aniso_pixels += usize::from(first.taps.count > 1);
        report.filtered_pixels += usize::from(first.taps().any(|t| t.kept.iter().any(|k| !k)));
        let error = resolve_bound_used(&outcomes, got);
        if error <= 1.0 {
            report.worst_gather = report.worst_gather.max(error);
            continue;
        }
        differing += 1;
        if first_difference.is_none() {
            let twin: Vec<String> = outcomes
                .iter()
                .map(|(w, o)| {
                    format!("weight {w}: {}", o.iter().map(describe_outcome).collect::<Vec<_>>().join(" or "))
                })
                .collect();
            let ids: Vec<[u32; 2]> = gathers.iter().map(|g| g.1).collect();
            first_difference = Some(format!(
                "pixel ({}, {}) (ids {ids:?}): GPU {:?}, twin {}",
                p.x,
                p.y,
                got.to_array(),
                twin.join("; ")
            ));
        }
    }
    if let Some(first) = first_difference {
        panic!("gather ({name}): {differing} of {} pixels differ from the twin; first: {first}", report.pixels);
    }
    eprintln!("{name}: {report:?}");
    // The twin must have checked nearly every pixel, or its slack would hide faults.
    assert!(report.skipped_pixels * 100 <= report.pixels, "{name}: {report:?}");
    report
}

/// The floor scene (checker texture: neighbouring texels differ, which a
/// wrong filter cannot hide) seen from its camera, at two levels, with
/// trilinear gathering (level blend 1: two levels per pixel but where the
/// last level clamps), with the Mitchell cubic, and with anisotropic
/// gathering (the floor recedes: up to 8 taps a pixel, alone and with
/// trilinear and the B-spline).
#[test]
fn gather_on_the_floor() {
    let ctx = common::gpu();
    let (scene, camera, lights) = common::floor_scene();
    let mut levels = BTreeMap::new();
    let cases = [
        ("floor", 0.0, 0.0, GatherFilter::Bilinear, 1),
        ("floor, mip bias -2.5", -2.5, 0.0, GatherFilter::Bilinear, 1),
        ("floor, mip bias -2.5, trilinear", -2.5, 1.0, GatherFilter::Bilinear, 1),
        // Negative lobes on a checker: a wrong weight or tap shows.
        ("floor, mip bias -2.5, Mitchell", -2.5, 0.0, GatherFilter::Mitchell, 1),
        ("floor, aniso 8", 0.0, 0.0, GatherFilter::Bilinear, 8),
        ("floor, aniso 4, trilinear, B-spline", 0.0, 1.0, GatherFilter::Bspline, 4),
    ];
    for (name, mip_bias, level_blend, gather_filter, aniso) in cases {
        let report = check(
            &ctx,
            Case {
                name,
                scene: &scene,
                texture_sizes: vec![Some(2048)],
                camera,
                lights: lights.clone(),
                width: 128,
                height: 96,
                mip_bias,
                level_blend,
                gather_filter,
                texel_samples: 1,
                aniso,
                samples: 1,
                msaa_gather: MsaaGather::Pixel,
                shade: false,
            },
        );
        assert!(report.pixels > 5000, "{report:?}");
        // The receding floor's footprints are long: most pixels read several taps.
        if aniso > 1 {
            assert!(report.aniso_pixels * 2 > report.pixels, "{name}: {report:?}");
        } else {
            assert_eq!(report.aniso_pixels, 0, "{name}: {report:?}");
        }
        // Trilinear reads two levels wherever the last level does not clamp
        // (with bias -2.5 on lavapipe, all but 432 of 7151 pixels without
        // blending); without blending, never.
        if level_blend > 0.0 {
            assert!(report.blended_pixels * 10 > report.pixels * 8, "{name}: {report:?}");
        } else {
            assert_eq!(report.blended_pixels, 0, "{name}: {report:?}");
        }
        levels.extend(report.levels);
    }
    assert!(levels.len() >= 2, "{levels:?}");
}

/// The floor without its texture, shaded and gathered.
#[test]
fn shade_and_gather_on_the_untextured_floor() {
    let ctx = common::gpu();
    let (mut scene, camera, lights) = common::floor_scene();
    scene.materials[0].base_color_texture = None;
    scene.materials[0].base_color = glam::Vec4::new(0.8, 0.6, 0.4, 1.0);
    assert_eq!(shade::unsupported(&scene, &lights), None);
    let report = check(
        &ctx,
        Case {
            name: "untextured floor",
            scene: &scene,
            texture_sizes: vec![Some(2048)],
            camera,
            lights,
            width: 96,
            height: 64,
            mip_bias: 0.0,
            level_blend: 0.0,
            gather_filter: GatherFilter::Bilinear,
            texel_samples: 1,
            aniso: 1,
            samples: 1,
            msaa_gather: MsaaGather::Pixel,
            shade: true,
        },
    );
    // The floor is one chart island, so its levels go on below 128 texels
    // (levels 4-7 of 2048 here, 3,584 texels; 10,000+ when they stopped at 128).
    assert!(report.texels > 3000 && report.pixels > 3000 && report.levels.len() >= 3, "{report:?}");
}

/// The atrium without textures (many objects, chart islands and levels) at
/// frame `frame` of its path, gathered with `filter` and up to `aniso` taps
/// a pixel, (with `shade`) shaded with `texel_samples` points a texel, at
/// `samples` per pixel gathered as `msaa_gather` says.
fn atrium(
    name: &'static str,
    frame: u32,
    gather_filter: GatherFilter,
    aniso: u32,
    (shade, texel_samples): (bool, u32),
    (samples, msaa_gather): (u32, MsaaGather),
) -> Report {
    let ctx = common::gpu();
    let mut scene = common::load("atrium");
    for m in &mut scene.materials {
        m.base_color_texture = None;
        m.normal_texture = None;
        m.metallic_roughness_texture = None;
        m.emissive_texture = None;
        m.occlusion_texture = None;
    }
    let (width, height) = (128, 72);
    let camera = path::cameras_for_scene("atrium", &scene, width as f32 / height as f32)
        .unwrap()
        .select(path::CameraChoice::Path)
        .unwrap()
        .camera_at(frame);
    let spec: LightSpec = "small:8+big:1".parse().unwrap();
    let lights = lights::build_lights(&spec, &scene.bounds(), &camera, width as f32 / height as f32, 7).unwrap();
    assert_eq!(shade::unsupported(&scene, &lights), None);
    let (scene, texture_sizes) = common::charted(&scene);
    let report = check(
        &ctx,
        Case {
            name,
            scene: &scene,
            texture_sizes,
            camera,
            lights,
            width,
            height,
            mip_bias: 0.0,
            // Half the pixels between two levels blend them: both kinds of
            // pixel, and island filtering in both levels of a blend.
            level_blend: 0.5,
            gather_filter,
            texel_samples,
            aniso,
            samples,
            msaa_gather,
            shade,
        },
    );
    // Several levels, blends, and island filtering at chart borders, were exercised.
    assert!(report.levels.len() >= 3 && report.filtered_pixels > 20, "{report:?}");
    assert!(report.blended_pixels > 100 && report.blended_pixels < report.pixels, "{report:?}");
    report
}

#[test]
fn shade_and_gather_in_the_atrium() {
    atrium("atrium", 0, GatherFilter::Bilinear, 1, (true, 1), (1, MsaaGather::Pixel));
}

/// At 4 samples per pixel each group of samples on one chart surface is
/// gathered at its centroid (and with `--os-msaa-gather sample` each
/// sample at its position), and the pixel is their mean weighted by their
/// samples: against the twin's groups and gathers, with the edges of the
/// atrium's objects and chart islands (lavapipe, 128x72: 1,711 of 9,214
/// pixels gathered at more than one point, and 99,520 texels shaded;
/// per sample all 9,216, and 109,888 texels).
#[test]
fn gather_at_four_samples_in_the_atrium() {
    for (name, mode) in
        [("atrium, 4 samples", MsaaGather::Pixel), ("atrium, 4 samples, per sample", MsaaGather::Sample)]
    {
        let report = atrium(name, 0, GatherFilter::Bilinear, 1, (true, 1), (4, mode));
        assert!(report.edge_pixels > 200, "{name}: {report:?}");
        if mode == MsaaGather::Pixel {
            assert!(report.edge_pixels * 3 < report.pixels, "{name}: {report:?}");
        }
    }
}

/// Up to 8 anisotropic taps a pixel, at the frame of the atrium's path where
/// a silhouette pixel's footprint reaches most of its chart (capped at the
/// coarsest level by `aniso_taps`; the gather only, the atlas as the GPU
/// shaded it).
#[test]
fn anisotropic_gather_in_the_atrium() {
    let report = atrium("atrium, aniso 8", 12, GatherFilter::Bilinear, 8, (false, 1), (1, MsaaGather::Pixel));
    assert!(report.aniso_pixels > 100, "{report:?}");
}

/// The B-spline gather (4x4 taps a level, island-filtered, across page
/// edges) and pre-filtered shading (2x2 points a texel) against their twins.
#[test]
fn bspline_gather_and_four_points_a_texel_in_the_atrium() {
    atrium("atrium, B-spline, 4 points a texel", 0, GatherFilter::Bspline, 1, (true, 4), (1, MsaaGather::Pixel));
}
