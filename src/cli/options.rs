//! The option groups several commands share, each defined once: the scene
//! and its lights and shading ([`SceneArgs`]), free cameras, object-space
//! shading, the GPU.

use std::str::FromStr;

use clap::{Args, ValueEnum};
use glam::Vec3;
use shadespace::render::deferred_compute::TileChoice;
use shadespace::render::objectspace::{
    DEFAULT_PAGE_SIZE, GatherFilter, GatherInput, MAX_ATLAS_BUDGET_MI, MAX_TRIMAP_GRID, Marking, MsaaGather,
    PagingChain, TrimapSearch,
};
use shadespace::render::scene_gpu::DEFAULT_SMALL_AREA;
use shadespace::render::{ClusterDraws, Culling, Exposure, ShadingModel, ShadowRefresh};
use shadespace::scene::free_camera;

use super::parse::{self, Orbit, Views, VisibilityChoice};

/// `--adapter`: which GPU.
#[derive(Args, Clone)]
#[command(next_help_heading = "GPU")]
pub struct GpuArgs {
    /// Use the first adapter whose name contains this text (case-insensitive);
    /// also read from SHADESPACE_ADAPTER. Default: the fastest kind available.
    #[arg(long)]
    pub adapter: Option<String>,
}

/// `--textures`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum TextureChoice {
    File,
    Detailed,
}

/// `--back-faces`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum BackFacesChoice {
    Material,
    Cull,
    Draw,
}

impl BackFacesChoice {
    /// The scene's rule for this choice (`--cull-back-faces` is `cull`).
    pub fn faces(self, cull_back_faces: bool) -> shadespace::scene::BackFaces {
        use shadespace::scene::BackFaces;
        match (self, cull_back_faces) {
            (_, true) | (Self::Cull, _) => BackFaces::Cull,
            (Self::Material, false) => BackFaces::Material,
            (Self::Draw, false) => BackFaces::Draw,
        }
    }
}

/// What `render`, `bench` and `view` draw and how: the scene, pipeline,
/// size, camera, lights, shading, and the groups below.
#[derive(Args, Clone)]
pub struct SceneArgs {
    /// `atrium` (default), `voxels`, `terrain`, `terrain-small`, `city` (or
    /// `city:N`, N x N blocks, `city:N:SEED`), or a path: a .gltf/.glb file,
    /// an .obj file, or a folder of .obj files (e.g. ../shared/scenes/sponza-thesis).
    #[arg(long, default_value = "atrium")]
    pub scene: String,
    /// Shading pipeline.
    #[arg(long, value_enum, default_value = "forward")]
    pub pipeline: PipelineName,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "1280x720", value_parser = parse::size)]
    pub size: (u32, u32),
    /// MSAA samples per pixel: 1 (default, none), 2, 4 or 8, at the standard
    /// sample positions, resolved (averaged in linear HDR) before exposure,
    /// bloom and tone mapping, in every pipeline (deferred-compute and object
    /// space with either --visibility). A count the adapter cannot render
    /// exits with status 2.
    #[arg(long, default_value_t = 1, value_parser = parse::msaa)]
    pub msaa: u32,
    /// Anisotropic texture filtering: the most taps (1, 2, 4, 8 or 16) a
    /// material texture sample takes along its footprint's longer axis, as
    /// any engine turns on (default 1: trilinear alone). Every pipeline that
    /// samples material textures per pixel or per sample (forward,
    /// multi-pass, clustered, deferred, deferred-compute, either
    /// --visibility; object space's objects shaded forward) uses it; object
    /// space's shading does not (its texels are isotropic footprints: see
    /// --os-aniso). An adapter without anisotropic filtering warns and
    /// filters trilinearly.
    #[arg(long, default_value_t = 1, value_parser = parse::texture_aniso)]
    pub aniso: u16,
    /// `path`: the scene's camera path (from cameras.json beside a shared
    /// scene; an orbit for atrium and voxels; for other scenes the file's
    /// first camera, or else a turntable framing the whole scene; the city's
    /// walk at street level), `flyover` (the city's flight over it), `fixed:K`
    /// (fixed camera K, from 0; framed views for other scenes), `gltf:K`
    /// (camera K of the glTF file) or `bookmark:FILE:NAME` (the view saved as
    /// NAME, the text after the last colon, in the viewer's bookmark file FILE).
    #[arg(long, default_value = "path")]
    pub camera: String,
    /// `studio` (a white key light that casts shadows, fill, rim and ambient,
    /// placed from the model's bounds and the camera), `daylight` (a sun and
    /// a sky ambient, for landscapes), or lights besides the
    /// ambient and directional light that every generated set has:
    /// `small:N` (each covers 0.25-5% of the screen), `big:N` (20-100%),
    /// `shadowed:N` (big lights that cast shadows: a quarter are spots),
    /// `mixed:N:R` (N such big lights, R small ones per big one), `none`,
    /// several joined with `+` (`small:100+big:2`), or a JSON light file.
    /// `auto` (default): `studio` for a model seen from outside (a glTF or
    /// OBJ file framed automatically or seen through its own camera),
    /// `daylight` for the terrain, `small:32` for scenes the camera moves
    /// through.
    #[arg(long, default_value = "auto")]
    pub lights: String,
    /// Seed of the light placement (same seed, same lights).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Exposure before tone mapping: a multiplier (positive, finite), or
    /// `auto`: computed on the GPU every frame, the HDR frame's log-average
    /// luminance over the pixels any light reached, mapped to mid-grey 0.18.
    /// Default: `auto` for a model seen from outside (a glTF or OBJ file
    /// framed automatically or seen through its own camera), 1 for scenes
    /// the camera moves through (the generated scenes, scenes with a camera
    /// file), as the studies and goldens use.
    #[arg(long, value_parser = parse::exposure)]
    pub exposure: Option<Exposure>,
    /// Bloom strength, 0 to 1: the fraction of the HDR image replaced by its
    /// glow (an average of blurs from half to 1/64 of the image size) before
    /// tone mapping; 0 (default) turns bloom off.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_parser = parse::bloom_strength)]
    pub bloom: f32,
    /// When shadow maps are rendered: `on-change` (default: a face again only
    /// when its view changes, i.e. its light changed or, for the sun's
    /// cascades, the camera moved; objects never move) or `every-frame` (the
    /// cost dynamic casters would have).
    #[arg(long, default_value = "on-change", value_parser = ShadowRefresh::from_str)]
    pub shadow_refresh: ShadowRefresh,
    /// `on`: the directional light (the sun) casts cascaded shadows (4
    /// cascades of 2048x2048 fitted to the view, 64 MiB, re-rendered when
    /// the camera moves). Default `off`: the generated sets' sun is a dim fill.
    #[arg(long, default_value = "off", value_parser = parse::on_off, action = clap::ArgAction::Set)]
    pub sun_shadow: bool,
    /// Lighting model, the same in every pipeline: `phong` (default, the
    /// studies' model: materials' specular strength and exponent) or `pbr`
    /// (GGX metallic-roughness, as glTF 2.0 defines it: the materials'
    /// metallic and roughness factors; OBJ materials get roughness from `Ns`).
    #[arg(long, value_enum, default_value = "phong")]
    pub shading: ShadingModel,
    /// `file` (default): the scene's own textures (generated scenes: UV
    /// checkers); `detailed`: every material gets a procedural high-frequency
    /// albedo (bricks and grain down to 4 texels, tinted with its old
    /// texture's mean colour) and the matching normal map, 512x512 per
    /// repeat of its `uv0`: texture detail that shows what object-space
    /// shading blurs.
    #[arg(long, value_enum, default_value = "file")]
    pub textures: TextureChoice,
    /// Which back faces every pipeline draws (the compute rasterizer, cluster
    /// cone culling and object space's marking too; shadow maps always draw
    /// both faces): `material` (default: each material's rule, glTF's
    /// `doubleSided`; OBJ materials are single-sided except cut-outs, the
    /// procedural scenes double-sided except the city's buildings), `cull`
    /// (every back face culled) or `draw` (every back face drawn).
    #[arg(long, value_enum, default_value = "material")]
    pub back_faces: BackFacesChoice,
    /// The same as `--back-faces cull`.
    #[arg(long, conflicts_with = "back_faces")]
    pub cull_back_faces: bool,
    /// Forward, deferred, deferred-compute: skip the depth pre-pass (shade or
    /// write the G-buffer for every rasterized fragment).
    #[arg(long)]
    pub no_depth_prepass: bool,
    /// Objectspace, deferred-compute: how pixels find their surface:
    /// `raster` (hardware visibility or G-buffer pass), `compute` (software
    /// rasterizer with 64-bit atomics; surfaces rebuilt from triangle ids) or
    /// `auto` (default: compute where the adapter has 64-bit atomics, which
    /// on the H100 is 1.7x (object space) to 2.2x (deferred-compute) faster
    /// at 1920x1080, else raster; under --msaa N the compute rasterizer
    /// takes N samples per pixel at the standard positions, the same ids as
    /// the hardware's, and on the H200 made 4x MSAA frames 1.9-2.2x faster).
    #[arg(long, default_value = "auto", value_parser = parse::visibility)]
    pub visibility: VisibilityChoice,
    /// Compute visibility: count the rasterizer's work every frame
    /// (triangles per path, 32x32 tiles, 8x8 squares that pass the edge test,
    /// pixels tested, atomics per pixel) into the `--stats`/`bench`
    /// counters. Adds atomics: for profiling, not for timing.
    #[arg(long)]
    pub count_visibility: bool,
    /// deferred-compute: the side in pixels of the lighting pass's tiles, 8
    /// or 16, one workgroup of side x side invocations a tile; the same
    /// image either way. `auto` (default) takes the one measured faster for
    /// the frame's scenario: 8 with at most 128 point and spot lights on
    /// single-layer materials at one sample a pixel (2-13 % faster on an
    /// H200 along Sponza's path), else 16 (8 was 1-160 % slower from 150
    /// lights, up to 43 % with layered materials, 6 % under 4x MSAA with 30
    /// shadowed lights), chosen again when the lights change; the side taken
    /// is the report's `tile_size` (BENCHMARKS.md, "The lighting tiles'
    /// side, chosen per scenario").
    #[arg(long, default_value = "auto")]
    pub dc_tile: TileChoice,
    /// Compute visibility: read each covered pixel before its 64-bit
    /// atomicMax and skip the atomic where the pixel already holds something
    /// nearer (the image is the same either way). Off by default: it cuts
    /// Sponza's atomics per pixel from 7.86 to 2.28 but made the H200's
    /// visibility pass 0.09 ms slower there (a load's round trip per covered
    /// pixel against a fire-and-forget atomic; docs/culling.md).
    #[arg(long)]
    pub vis_depth_test: bool,
    /// Compute visibility: the most pixels of a triangle's bounding box that
    /// one thread rasterizes alone; bigger triangles are set up once and
    /// drawn by workgroups, a 32x32 tile each (--vis-big-workgroups). The
    /// ids are the same whatever it is.
    #[arg(long, value_name = "PIXELS", default_value_t = DEFAULT_SMALL_AREA, value_parser = clap::value_parser!(u32).range(1..=65536))]
    pub vis_small_area: u32,
    /// Compute visibility: workgroups of the pass that draws big triangles,
    /// which loop over their tiles (default 32768 on GPUs, 1024 on CPU
    /// drivers such as lavapipe). The ids are the same whatever it is.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=65535))]
    pub vis_big_workgroups: Option<u32>,
    /// Compute visibility: how the meshes' clusters (up to 64 triangles) are
    /// culled on the GPU before rasterizing (objects outside the view are
    /// skipped on the CPU in every mode): `none` (every triangle of every
    /// object in view), `frustum` (clusters outside the view, and by their
    /// normal cones those of single-sided materials facing away) or
    /// `occlusion` (also two-pass
    /// occlusion against a depth pyramid of the clusters visible last
    /// frame). Default: `occlusion` for scenes of 64 objects or more (the
    /// city), `none` for fewer (Sponza, a model), the faster on each. The
    /// visibility buffer is the same in every mode; with
    /// --count-visibility the counters cull_tested, cull_frustum, cull_cone,
    /// cull_occlusion and cull_drawn (docs/culling.md).
    #[arg(long, value_name = "none|frustum|occlusion", value_parser = parse::culling)]
    pub culling: Option<Culling>,
    /// How the raster pipelines draw the clusters that --culling keeps:
    /// `indexed` (default: one indexed indirect draw per cluster, counted on
    /// the GPU; lists where the adapter lacks INDIRECT_FIRST_INSTANCE or
    /// MULTI_DRAW_INDIRECT_COUNT) or `list` (one instanced draw per list,
    /// three vertex invocations per triangle; to compare).
    #[arg(long, value_name = "indexed|list", value_parser = parse::cluster_draws, default_value = "indexed")]
    pub cluster_draws: ClusterDraws,
    /// The raster pipelines draw the plain way (every object in view, one
    /// instanced draw per run of a mesh's instances) in a frame after one
    /// whose --culling kept more than this share (0 to 1) of the clusters
    /// it tested, running the culling passes only to follow that share;
    /// 1: always draw the clusters culling keeps (the way before). Where
    /// most clusters are kept the cluster draws cost more than they save
    /// (the city's fly-over: 89 % kept, 23 % slower on the H200). Same
    /// image either way; the counter cull_plain says which way a frame drew.
    #[arg(long, value_name = "SHARE", value_parser = parse::cull_plain_above, default_value = "0.6")]
    pub cull_plain_above: f32,
    /// `default`: the scene's materials; `high`: every material with Phong
    /// exponent 1500, GGX roughness 0.05 and specular strength at least 1, to
    /// provoke specular aliasing (normal maps: the file's or --textures detailed).
    #[arg(long, value_enum, default_value = "default")]
    pub gloss: shadespace::scene::gloss::Gloss,
    /// Layered materials (every pipeline lights each layer and blends them
    /// by mask): `none` (default: the scene's materials), `layered:K` (every
    /// material with K layers, 1 to 16), `bands` (the terrain's bands as ten
    /// shaded layers by height and slope, its precals on top) or a JSON
    /// material file (docs/materials.md).
    #[arg(long, value_name = "none|layered:K|bands|FILE", default_value = "none")]
    pub materials: shadespace::materials::MaterialsSpec,
    /// Environment lighting, prefiltered on the GPU at load and added to the
    /// lights as one environment light (diffuse and GGX specular, times the
    /// material's occlusion, in every pipeline) and drawn as the background
    /// where no surface is: `none`, `sky` (a procedural clear sky with a
    /// sun, where the light set's sun is) or an equirectangular Radiance
    /// .hdr file (docs/environment.md). Default: `sky` for the city and the
    /// terrain under `--lights auto` (outdoor scenes seen against the sky),
    /// `none` otherwise (today's images, goldens and benchmarks).
    #[arg(long, value_name = "none|sky|FILE")]
    pub env: Option<shadespace::scene::environment::EnvSpec>,
    #[command(flatten)]
    pub free_camera: FreeCameraArgs,
    #[command(flatten)]
    pub objectspace: ObjectSpaceArgs,
    #[command(flatten)]
    pub gpu: GpuArgs,
}

/// `--eye`/`--target`, `--orbit`: a camera of the user's instead of the scene's.
#[derive(Args, Clone)]
#[command(next_help_heading = "Free cameras (instead of --camera)")]
pub struct FreeCameraArgs {
    /// Place the camera at X,Y,Z (world metres, +y up) looking at --target;
    /// the near and far planes hold the whole scene.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = parse::point,
          group = "free", requires = "target", conflicts_with = "camera")]
    pub eye: Option<Vec3>,
    /// The point --eye looks at, or --orbit circles (default for --orbit: the
    /// centre of the scene's bounds).
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = parse::point, requires = "free")]
    pub target: Option<Vec3>,
    /// Camera path circling --target: the eye RADIUS metres from it
    /// horizontally and HEIGHT metres above it, one turn in PERIOD frames
    /// (from the +x side towards +z).
    #[arg(long, value_name = "RADIUS,HEIGHT,PERIOD", allow_hyphen_values = true, value_parser = parse::orbit,
          group = "free", conflicts_with = "camera")]
    pub orbit: Option<Orbit>,
    /// Vertical field of view of --eye or --orbit, degrees (above 0, below 180).
    #[arg(long, value_name = "DEG", default_value_t = free_camera::DEFAULT_FOV_DEG, value_parser = parse::fov_degrees,
          requires = "free")]
    pub fov: f32,
}

/// The object-space pipeline's settings (and `charts`' texture sizing).
#[derive(Args, Clone)]
#[command(next_help_heading = "Object-space shading (--pipeline objectspace)")]
pub struct ObjectSpaceArgs {
    /// Tile side in texels: 8, 16, 32 or 64.
    #[arg(long, default_value_t = 8, value_parser = parse::tile_size)]
    pub tile_size: u32,
    /// Re-shade a visible tile when its shade is N frames old (1 = every frame).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    pub reuse: u32,
    /// Decoupled shading rate: shade each visible tile S times a second at
    /// --frame-hz frames a second (every R/S frames, rounded), spread evenly
    /// over the frames so that each frame shades about the same number of
    /// tiles. Replaces --reuse.
    #[arg(long, value_parser = parse::hertz, conflicts_with = "reuse")]
    pub shade_hz: Option<f64>,
    /// The frame rate --shade-hz divides (frames a second).
    #[arg(long, default_value_t = 60.0, value_parser = parse::hertz, requires = "shade_hz")]
    pub frame_hz: f64,
    /// Shading texels per metre of surface (above 0, at most 65536); an
    /// object's texture side is its charted area times this, rounded up to a
    /// power of two. Default: each object's side follows the screen, from
    /// the most pixels per metre it covers along the camera path at --size.
    #[arg(long, value_parser = parse::texel_density)]
    pub texel_density: Option<f32>,
    /// Give every object an S x S shading texture instead (the reference study used 4096).
    #[arg(long)]
    pub texture_size: Option<u32>,
    /// Added to every pixel's mip level (positive: coarser shading; -16 to 16).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_parser = parse::mip_bias)]
    pub mip_bias: f32,
    /// Most texels shaded per frame, in millions: above it every pixel's mip
    /// level is biased coarser (up to 8 levels, on top of --mip-bias) until
    /// the shading fits, and the bias falls back when there is room; the
    /// counters report it as `budget_bias`. Default: no limit.
    #[arg(long, value_parser = parse::shade_budget)]
    pub shade_budget: Option<f64>,
    /// Variable rate: shade up to this many mip levels coarser where a
    /// triangle's normals do not vary (0 = off; at most 16).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_parser = parse::variable_rate)]
    pub variable_rate: f32,
    /// Blend the two mip levels around each pixel's footprint over a band
    /// this wide (in levels) around each level switch, shading both: 0
    /// reads the nearest level alone (its shade jumps where the level
    /// changes), 1 is trilinear. 0 to 1.
    #[arg(long, default_value_t = 0.0, value_parser = parse::level_blend)]
    pub level_blend: f32,
    /// Most texels of the physical atlas, in Mi (12 bytes each with the
    /// triangle maps): the pages that back the objects' virtual textures
    /// where visible tiles need them. The atlas starts at this size, then
    /// follows the pages the frames need (in 32 steps, about 1.4 times
    /// them); when a frame needs more than the budget, the mip bias rises
    /// until it fits (the counters report `budget_bias` and `atlas_pages`).
    /// Default: 1 texel per pixel at 1920x1080 (2.1 Mi), growing as the
    /// square root of the pixels (4.1 Mi at 3840x2160), at least 1 Mi.
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=MAX_ATLAS_BUDGET_MI))]
    pub atlas_budget: Option<u64>,
    /// Page side of the virtual textures in texels (a power of two, at most
    /// four times the tile size; raised to the tile size). Larger pages
    /// make a smaller page table but hold more texels no pixel needs.
    #[arg(long, default_value_t = DEFAULT_PAGE_SIZE)]
    pub page_size: u32,
    /// Skip the depth pre-pass before the visibility (id) pass (with it, each
    /// pixel's ids are written once; measured faster on the H100).
    #[arg(long)]
    pub no_visibility_prepass: bool,
    /// More views marking into the same atlas in each frame, each tile shaded
    /// once for all (compute visibility): `stereo:D` (a right eye D scene
    /// units to the right of the camera) or `fixed` (the scene's fixed
    /// cameras other than --camera's). `render` writes view K beside --out
    /// as NAME-viewK.png.
    #[arg(long, value_parser = parse::views)]
    pub views: Option<Views>,
    /// How tile marking writes the tiles pixels need: `workgroup` (default:
    /// the first pixel of each 8x8 workgroup to need a tile marks it once)
    /// or `per-pixel` (every pixel marks each tile of its footprint: the
    /// former pass, for comparison) or `subgroup` (as `workgroup`, but a
    /// subgroup's pixels that need one tile elect one of them to claim it in
    /// the workgroup's table; needs subgroup operations; on the H200 it cut
    /// the claims 8.7x and made the pass 0.004-0.007 ms slower, so it is not
    /// the default). All mark the same tiles.
    #[arg(long, value_enum, default_value = "workgroup")]
    pub marking: Marking,
    /// Count tile marking's global tile marks and atomics every frame into
    /// the `--stats`/`bench` counters `mark_tiles`, `mark_atomics` and
    /// `mark_claims` (claims of a tile in the workgroup table; adds
    /// workgroup atomics: for profiling, not for timing).
    #[arg(long)]
    pub count_marks: bool,
    /// How the passes that back requested pages are recorded: `fused`
    /// (default: the triangle-map pass marks the backed pages, and the
    /// dispatch arguments are written with paging's) or `split` (backed
    /// args, mark backed and the shade pass's arguments each a dispatch of
    /// their own: three dispatches more a frame). Both give the same pages,
    /// tiles and image.
    #[arg(long, value_enum, default_value = "fused")]
    pub os_paging: PagingChain,
    /// Invocations weighing each texel's triangles in the triangle-map pass
    /// (1, 2, 4 or 8): on a GPU more lanes shorten the slowest page, whose
    /// cells hold the most triangles; on a CPU adapter (lavapipe) the lanes
    /// take turns and their barriers cost more than they save. The maps are
    /// the same. Default: 4 on a GPU, 1 on a CPU adapter
    #[arg(long, value_parser = parse::trimap_lanes)]
    pub os_trimap_lanes: Option<u32>,
    /// The widest level whose triangle maps are built once per mesh, the
    /// first frame, and copied into pages backed later instead of searched
    /// (0 or a power of two up to 2048; 0: none): the middle levels hold
    /// the slowest pages, and the pass lasts as long as its slowest. The
    /// maps are the same. Default: 512 on a GPU (350,000 texels, 1.4 MB, a
    /// mesh), 0 on a CPU adapter
    #[arg(long, value_parser = parse::trimap_store)]
    pub os_trimap_store: Option<u32>,
    /// How the triangle-map pass searches a texel's cells of the chart grid
    /// when its centre's cell does not settle it: `rings` (default: ring by
    /// ring round the centre's cell, stopping once no cell left can hold a
    /// nearer triangle: far fewer triangles at the coarse levels of the
    /// city's buildings; the pass took 0.26 ms instead of 4.6 on its street
    /// on the H200) or `neighbourhood` (every cell of its 3x3 texels). The
    /// maps are the same.
    #[arg(long, value_enum, default_value = "rings")]
    pub os_trimap_search: TrimapSearch,
    /// The chart grids' cells per side, this many times the default (about
    /// two triangles per cell), 1 to 4: finer cells list fewer triangles for
    /// the texels of fine levels to weigh. The maps are the same.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=MAX_TRIMAP_GRID as i64))]
    pub os_trimap_grid: u32,
    /// Whether a page copies the triangle map of a page already holding the
    /// map of the same mesh, level and page (another instance's) instead of
    /// building it: `on` (default; the city's instances build each map
    /// once) or `off` (every page builds its own). The maps are the same.
    #[arg(long, default_value = "on", value_parser = parse::on_off, action = clap::ArgAction::Set)]
    pub os_trimap_share: bool,
    /// What the gather reads for each pixel's chart UV and levels: `record`
    /// (marking writes them, 16 bytes a pixel, and the gather reads them; one
    /// view, no MSAA, --os-aniso 1), `surface` (it rebuilds the pixel's
    /// surface as marking did) or `auto` (default: `record` where it can,
    /// else `surface`). All give the same image.
    #[arg(long, value_enum, default_value = "auto")]
    pub os_gather: GatherInput,
    /// How the gather filters each level's shades: `bilinear` (default: the
    /// 2x2 texels around the point), `bspline` (the cubic B-spline over the
    /// 4x4 around it: a blur that changes less with the texel grid's phase
    /// as the camera moves) or `mitchell` (the Mitchell-Netravali cubic over
    /// the 4x4: sharper); the cubics mark one texel more each side.
    #[arg(long, value_enum, default_value = "bilinear")]
    pub os_filter: GatherFilter,
    /// Anisotropic gathering: the most filter taps (1, 2, 4, 8 or 16) a
    /// pixel reads along its footprint's longer axis. The mip level then
    /// follows the shorter axis, limited so that the longer needs at most
    /// this many taps, as hardware anisotropic filtering does: grazing and
    /// distant surfaces are shaded and read less blurred along their
    /// shorter axis, at the cost of more tiles shaded and more taps read.
    /// Default 1: the level follows the longer axis, one tap. Not with
    /// `--os-gather record`.
    #[arg(long, default_value_t = 1, value_parser = parse::aniso)]
    pub os_aniso: u32,
    /// Under `--msaa`: `pixel` (default) gathers once per group of a
    /// pixel's samples that see one chart surface (object and chart
    /// island), at the group's centroid, so the gather's cost follows the
    /// surfaces in a pixel, not its samples; `sample` gathers every sample
    /// at its own position (the per-sample reference; slower).
    #[arg(long, value_enum, default_value = "pixel")]
    pub os_msaa_gather: MsaaGather,
    /// Points each shaded texel averages: 1 (its centre, default) or 4
    /// (2x2 over the texel: shading pre-filtered over the texel's footprint,
    /// against specular aliasing; 4x the shading work, the same tiles).
    #[arg(long, default_value_t = 1, value_parser = parse::texel_samples)]
    pub os_texel_samples: u32,
    /// Shade these objects (comma-separated names) forward instead of in object space.
    #[arg(long, value_delimiter = ',')]
    pub forward_only: Vec<String>,
}

/// The shading pipelines, for `--pipeline`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum PipelineName {
    /// Single-pass forward: one draw per object, fragments loop over its CPU light list (the reference).
    Forward,
    /// Multi-pass forward: depth pre-pass, then one additive pass per light over the objects it reaches.
    ForwardMultipass,
    /// Clustered forward: fragments lit by GPU-built view-space light clusters.
    Clustered,
    /// Deferred shading: G-buffer, then light volumes (spheres, cones) blended per light.
    Deferred,
    /// Tiled deferred shading: G-buffer, then one compute pass culls and shades 16x16 tiles.
    DeferredCompute,
    /// Object-space (texel) shading: visible tiles shaded by compute into an atlas, reused, gathered.
    Objectspace,
}
