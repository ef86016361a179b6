//! Back faces by the material's rule (`Material::double_sided`, glTF's
//! `doubleSided`): a glTF of two quads, the left one single-sided and the
//! right one double-sided, seen from behind. In every pipeline (object space
//! and deferred-compute with both visibility methods, the raster pipelines
//! drawing plain and culled clusters) the single-sided quad vanishes, showing
//! the quad behind it, and the double-sided one is drawn as with both faces
//! of everything: the image is the one of the scene without the
//! single-sided quad's triangles.

use crate::common::{self, gltf::MeshData};

use glam::Vec3;
use shadespace::gpu::GpuContext;
use shadespace::render::objectspace::ObjectSpace;
use shadespace::render::{
    ClusterDraws, ClusteredConfig, Culling, DeferredComputeConfig, DeferredConfig, ForwardConfig,
    ForwardMultipassConfig, ObjectSpaceConfig, PipelineConfig, RenderOptions, Renderer, VisibilityMethod,
};
use shadespace::scene::{self, BackFaces, Camera, Light, LightKind, Scene};

const SIZE: (u32, u32) = (96, 64);

/// A quad from `x0` to `x1` in x and -1 to 1 in y at z = 0, facing +z
/// (counter-clockwise seen from +z).
fn quad(x0: f32, x1: f32) -> MeshData {
    MeshData {
        positions: vec![
            Vec3::new(x0, -1.0, 0.0),
            Vec3::new(x1, -1.0, 0.0),
            Vec3::new(x1, 1.0, 0.0),
            Vec3::new(x0, 1.0, 0.0),
        ],
        normals: vec![Vec3::Z; 4],
        indices: vec![0, 1, 2, 0, 2, 3],
    }
}

/// A strip from `x0` to `x1`: its left half faces +z ([`quad`]), its right
/// half -z, so that seen from z < 0 only the right half is a front face.
/// One cluster with both facings, so that its normal cone culls nothing and
/// the raster passes' cull modes decide.
fn quad_and_back(x0: f32, x1: f32) -> MeshData {
    let xm = 0.5 * (x0 + x1);
    let mut m = quad(x0, xm);
    m.positions.extend(quad(xm, x1).positions);
    m.normals.extend([Vec3::NEG_Z; 4]);
    m.indices.extend([4, 6, 5, 4, 7, 6]);
    m
}

/// The quads as a glTF file whose first material is single-sided (no
/// `doubleSided`: the default, false; [`quad_and_back`]) and whose second is
/// `doubleSided` ([`quad`]), loaded.
fn two_quads() -> Scene {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("faces");
    std::fs::create_dir_all(&dir).unwrap();
    let meshes = [quad_and_back(-2.0, -0.2), quad(0.2, 2.0)];
    let path = common::gltf::write_gltf(&dir, "two-quads", &meshes, &Default::default());
    let mut doc: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let single = doc["materials"][0].clone();
    let mut double = single.clone();
    double["name"] = "double".into();
    double["doubleSided"] = true.into();
    doc["materials"] = serde_json::json!([single, double]);
    doc["meshes"][1]["primitives"][0]["material"] = 1.into();
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    scene::load(path.to_str().unwrap()).unwrap()
}

/// From behind (z < 0, looking along +z), lit from that side.
fn behind() -> (Camera, Vec<Light>) {
    let camera = Camera {
        position: Vec3::new(0.0, 0.0, -4.0),
        forward: Vec3::Z,
        up: Vec3::Y,
        fov_y: 60f32.to_radians(),
        near: 0.1,
        far: 50.0,
    };
    let point = Light {
        kind: LightKind::Point,
        color: Vec3::ONE,
        intensity: 6.0,
        position: Vec3::new(0.5, 0.5, -1.5),
        direction: Vec3::Z,
        radius: 8.0,
        cos_inner: 0.9,
        cos_outer: 0.8,
        casts_shadows: false,
    };
    let ambient = Light { kind: LightKind::Ambient, intensity: 0.2, ..point };
    (camera, vec![ambient, point])
}

/// Every pipeline, with the visibility methods and cluster culling that
/// take other paths through the rule.
fn pipelines(texture_sizes: &[Option<u32>]) -> Vec<(PipelineConfig, Culling, ClusterDraws)> {
    let compute = VisibilityMethod::Compute;
    let os = |visibility| ObjectSpaceConfig { texture_sizes: texture_sizes.to_vec(), visibility, ..Default::default() };
    let (none, frustum) = (Culling::None, Culling::Frustum);
    let (indexed, list) = (ClusterDraws::Indexed, ClusterDraws::List);
    let compute_lit = DeferredComputeConfig { visibility: compute, ..Default::default() };
    vec![
        (PipelineConfig::Forward(ForwardConfig::default()), none, indexed),
        // Both cull modes in one cluster list: each pipeline skips the other's objects.
        (PipelineConfig::Forward(ForwardConfig::default()), frustum, indexed),
        (PipelineConfig::Forward(ForwardConfig::default()), frustum, list),
        (PipelineConfig::ForwardMultipass(ForwardMultipassConfig::default()), none, indexed),
        (PipelineConfig::Clustered(ClusteredConfig::default()), none, indexed),
        (PipelineConfig::Deferred(DeferredConfig::default()), frustum, indexed),
        (PipelineConfig::DeferredCompute(DeferredComputeConfig::default()), none, indexed),
        (PipelineConfig::DeferredCompute(compute_lit), frustum, indexed),
        (PipelineConfig::ObjectSpace(os(VisibilityMethod::Raster)), none, indexed),
        (PipelineConfig::ObjectSpace(os(compute)), frustum, indexed),
    ]
}

fn render(
    ctx: &GpuContext,
    scene: &Scene,
    (pipeline, culling, draws): (PipelineConfig, Culling, ClusterDraws),
) -> image::RgbaImage {
    let (camera, lights) = behind();
    let options = RenderOptions { width: SIZE.0, height: SIZE.1, pipeline, samples: 1 };
    let mut r = Renderer::new(ctx, scene, &options).unwrap();
    r.culling = culling;
    r.cluster_draws = draws;
    r.render(ctx, &camera, &lights, 0).unwrap();
    let image = r.read_image(ctx).unwrap();
    ctx.check_errors().unwrap();
    image
}

#[test]
fn single_sided_quads_vanish_from_behind_in_every_pipeline() {
    let ctx = common::gpu();
    let loaded = two_quads();
    let sides: Vec<bool> = loaded.materials.iter().map(|m| m.double_sided).collect();
    assert_eq!(sides, [false, true], "the loader read doubleSided (and its default) wrongly");
    let (rule, sizes) = common::charted(&loaded);
    let mut both = rule.clone();
    both.set_back_faces(BackFaces::Draw);
    // What the rule must draw: the double-sided quad, and of the
    // single-sided strip only its half that faces the camera.
    let mut alone = rule.clone();
    let single = alone.objects[0].mesh;
    alone.meshes[single].indices.drain(..6);
    let out = common::out_dir();
    for (k, (run, alone_run)) in pipelines(&sizes).into_iter().zip(pipelines(&sizes)).enumerate() {
        let label = format!("faces-{k}-{}-{:?}-{:?}", run.0.name(), run.1, run.2);
        let with_rule = render(&ctx, &rule, run.clone());
        let expected = render(&ctx, &alone, alone_run);
        let with_both = render(&ctx, &both, run);
        let (err, map) = shadespace::metrics::compare(&expected, &with_rule);
        let (drawn, _) = shadespace::metrics::compare(&expected, &with_both);
        eprintln!("{label}: rule against the scene without the back quad {err:?}; both faces against it {drawn:?}");
        // Object space shades the quad behind from an atlas laid out with the
        // back quad in it: one 8-bit step apart in places.
        if err.flip_mean > 1e-3 {
            with_rule.save(out.join(format!("{label}.png"))).unwrap();
            map.save(out.join(format!("{label}-flip.png"))).unwrap();
            panic!("{label}: the rule's image is not the one without the single-sided back quad: {err:?}");
        }
        assert!(
            drawn.flip_mean > 0.01,
            "{label}: with both faces drawn the single-sided quad does not show: {drawn:?}"
        );
    }
}

/// The visibility ids (object + 1, triangle per pixel) of object space
/// with `method`, seen from behind.
fn ids(ctx: &GpuContext, scene: &Scene, sizes: &[Option<u32>], method: VisibilityMethod) -> Vec<[u32; 2]> {
    let objectspace = ObjectSpaceConfig { texture_sizes: sizes.to_vec(), visibility: method, ..Default::default() };
    let options =
        RenderOptions { width: SIZE.0, height: SIZE.1, pipeline: PipelineConfig::ObjectSpace(objectspace), samples: 1 };
    let mut renderer = Renderer::new(ctx, scene, &options).unwrap();
    renderer.render(ctx, &behind().0, &[], 0).unwrap();
    renderer.pipeline::<ObjectSpace>().unwrap().read_mark_state(ctx).unwrap().visibility
}

/// With the rule, the compute rasterizer and the hardware keep the same
/// triangles: identical ids, the double-sided quad's and none of the
/// single-sided one's.
#[test]
fn ids_are_identical_between_compute_and_raster_visibility_with_the_rule() {
    let ctx = common::gpu();
    let (scene, sizes) = common::charted(&two_quads());
    let raster = ids(&ctx, &scene, &sizes, VisibilityMethod::Raster);
    let compute = ids(&ctx, &scene, &sizes, VisibilityMethod::Compute);
    let differ = raster.iter().zip(&compute).filter(|(r, c)| r != c).count();
    assert_eq!(differ, 0, "{differ} pixels' ids differ between raster and compute visibility");
    assert!(raster.iter().any(|id| id[0] == 2), "the double-sided quad is not drawn");
    // Triangles 0 and 1 of the single-sided mesh face away: never seen.
    assert!(raster.iter().any(|id| id[0] == 1), "the single-sided mesh's quad behind is not drawn");
    assert!(raster.iter().all(|id| id[0] != 1 || id[1] >= 2), "the single-sided quad's back is drawn");
}
