//! The tile-marking rules the tile studies count with: the reference study's
//! (one tile per pixel, its level from the largest UV derivative component,
//! floored) beside ours (the bilinear footprint at the rounded level of the
//! derivative vectors' length, as `mark.wgsl` does; through the CPU twin in
//! `render::objectspace::cpu`), and the flat tile index spaces they mark in.

use std::fmt;
use std::str::FromStr;

use glam::UVec2;
use serde::Serialize;

use crate::render::objectspace::atlas::MAX_TEXTURE_SIZE;
use crate::render::objectspace::atlas::{AtlasError, AtlasLayout, GpuAtlasEntry};
use crate::render::objectspace::cpu::{self, ChartFootprint, MarkParams};
use crate::render::objectspace::{COARSEST_LEVEL, DEFAULT_PAGE_SIZE, GatherFilter};

/// The study's shading-texture side for every object (12 levels).
pub const STUDY_TEXTURE_SIZE: u32 = 4096;

/// How a pixel picks the tiles it needs (`--marking`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Marking {
    /// The reference study's rule ([`study_level`], [`StudyLayout::tile`]).
    Study,
    /// Ours: the bilinear footprint at the rounded level (`mark.wgsl`).
    Bilinear,
}

impl Marking {
    pub const ALL: [Self; 2] = [Self::Study, Self::Bilinear];

    pub fn name(self) -> &'static str {
        match self {
            Self::Study => "study",
            Self::Bilinear => "bilinear",
        }
    }
}

impl FromStr for Marking {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL.into_iter().find(|m| m.name() == s).ok_or_else(|| format!("'{s}' is not study or bilinear"))
    }
}

/// The shading-texture sizes tiles are counted at.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
pub enum Texture {
    /// Every object [`STUDY_TEXTURE_SIZE`] square, as in the study.
    #[serde(rename = "4096")]
    Study,
    /// Ours: sized from the charted area at the texel density, fitted to the
    /// default atlas budget (what `--pipeline objectspace` shades).
    #[serde(rename = "density")]
    Density,
}

impl Texture {
    pub fn name(self) -> &'static str {
        match self {
            Self::Study => "4096",
            Self::Density => "density",
        }
    }
}

/// One way of counting a view's tiles: a marking rule at a texture sizing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
pub struct Variant {
    pub marking: Marking,
    pub texture: Texture,
}

impl Variant {
    /// The variants `markings` ask for: each at the study's 4096, and ours
    /// (bilinear) also at our texel density. The study's rule is defined at
    /// 4096 only.
    pub fn for_markings(markings: &[Marking]) -> Vec<Variant> {
        let mut out: Vec<Variant> =
            markings.iter().map(|&marking| Variant { marking, texture: Texture::Study }).collect();
        if markings.contains(&Marking::Bilinear) {
            out.push(Variant { marking: Marking::Bilinear, texture: Texture::Density });
        }
        out.sort();
        out.dedup();
        out
    }
}

impl fmt::Display for Variant {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} marking, {} textures", self.marking.name(), self.texture.name())
    }
}

/// The study's mip level: `floor(log2(size * max(|du/dx|, |dv/dx|, |du/dy|,
/// |dv/dy|)))`, the largest absolute component (not a vector length), no
/// bias, clamped below at 0 (magnification shades level 0).
pub fn study_level(texture_size: u32, f: &ChartFootprint) -> u32 {
    let largest = f.du_dx.abs().max_element().max(f.du_dy.abs().max_element());
    let level = (texture_size as f32 * largest).log2().floor();
    // log2(0) is -inf and NaN compares false: both give level 0.
    if level > 0.0 { level as u32 } else { 0 }
}

/// One level of an object in the study's tile space.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct StudyLevel {
    side: u32,
    tile_base: u32,
}

/// The study's tiles: every object's texture of one side, each level down to
/// the last whose grid holds a whole tile, numbered object by object, level
/// by level, row by row.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StudyLayout {
    pub tile_size: u32,
    pub texture_size: u32,
    /// Per object, the levels that hold at least one tile.
    objects: Vec<Vec<StudyLevel>>,
    pub tile_count: u32,
}

impl StudyLayout {
    pub fn new(objects: usize, texture_size: u32, tile_size: u32) -> Self {
        let mut next = 0u32;
        let levels = (0..objects)
            .map(|_| {
                (0..)
                    .map(|level| texture_size >> level)
                    .take_while(|&side| side >= tile_size)
                    .map(|side| {
                        let l = StudyLevel { side, tile_base: next };
                        next += (side / tile_size) * (side / tile_size);
                        l
                    })
                    .collect()
            })
            .collect();
        Self { tile_size, texture_size, objects: levels, tile_count: next }
    }

    /// The one tile a pixel of `object` with footprint `f` marks: the tile
    /// holding its UV point on the grid of its level; none where that grid is
    /// smaller than a tile. UVs outside the unit square are clamped into it.
    pub fn tile(&self, object: usize, f: &ChartFootprint) -> Option<u32> {
        let level = study_level(self.texture_size, f) as usize;
        let l = self.objects[object].get(level)?;
        let texel =
            (f.uv * l.side as f32).floor().as_ivec2().clamp(glam::IVec2::ZERO, glam::IVec2::splat(l.side as i32 - 1));
        let t = texel.as_uvec2() / self.tile_size;
        Some(l.tile_base + t.y * (l.side / self.tile_size) + t.x)
    }

    /// The first tile of `object`'s level `level`, and the level's tiles per row.
    pub fn level_tiles(&self, object: usize, level: usize) -> Option<(u32, u32)> {
        self.objects[object].get(level).map(|l| (l.tile_base, l.side / self.tile_size))
    }
}

/// Our marking's parameters: no bias, no variable rate (the renderer's defaults).
const OUR_MARKING: MarkParams = MarkParams {
    stamp: 1,
    reuse: 1,
    view_since: 1,
    tile_size: 8,
    mip_bias: 0.0,
    variable_rate: 0.0,
    level_blend: 0.0,
    gather_filter: GatherFilter::Bilinear,
    aniso: 1,
};

/// The atlas tiles our marking gives a pixel of an object (entry `e`) with
/// footprint `f`: the tiles of its bilinear footprint at its rounded level,
/// exactly the twin's formulas without its rounding tolerance.
pub fn bilinear_tiles(e: &GpuAtlasEntry, tile_size: u32, f: &ChartFootprint, mut mark: impl FnMut(u32)) {
    if e.size == 0 {
        return;
    }
    let level = cpu::select_level(cpu::level_of_detail(e, &OUR_MARKING, f, 0.0), e.level_count);
    let l = &e.levels[level as usize];
    let b = cpu::bilinear(l.size, f.uv);
    let (lo, hi) = (b.texel.as_uvec2() / tile_size, b.texel_hi.as_uvec2() / tile_size);
    let per_row = l.size / tile_size;
    let tile = |t: UVec2| l.tile_base + t.y * per_row + t.x;
    // As `cpu::footprint_tiles`, without a Vec per pixel.
    mark(tile(lo));
    if hi.x != lo.x {
        mark(tile(UVec2::new(hi.x, lo.y)));
    }
    if hi.y != lo.y {
        mark(tile(UVec2::new(lo.x, hi.y)));
        if hi.x != lo.x {
            mark(tile(hi));
        }
    }
}

/// The tile index space of one variant at one tile size.
#[derive(Clone, Debug)]
pub enum TileSpace {
    Study(StudyLayout),
    /// Our atlas numbering (`AtlasLayout`), levels down to [`COARSEST_LEVEL`].
    Atlas {
        entries: Vec<GpuAtlasEntry>,
        tile_size: u32,
        tile_count: u32,
    },
}

impl TileSpace {
    /// The space of `variant` at `tile_size` for `objects` objects, whose
    /// density-sized textures are `density_sizes` (already fitted to the budget).
    pub fn new(variant: Variant, tile_size: u32, density_sizes: &[Option<u32>]) -> Result<Self, AtlasError> {
        let n = density_sizes.len();
        if variant.marking == Marking::Study {
            return Ok(Self::Study(StudyLayout::new(n, STUDY_TEXTURE_SIZE, tile_size)));
        }
        let sizes = match variant.texture {
            Texture::Study => vec![Some(STUDY_TEXTURE_SIZE); n],
            Texture::Density => density_sizes.to_vec(),
        };
        let layout =
            AtlasLayout::new(&sizes, tile_size, DEFAULT_PAGE_SIZE.max(tile_size), MAX_TEXTURE_SIZE, COARSEST_LEVEL)?;
        Ok(Self::Atlas { entries: layout.gpu_entries(), tile_size, tile_count: layout.tile_count })
    }

    pub fn tile_count(&self) -> u32 {
        match self {
            Self::Study(s) => s.tile_count,
            Self::Atlas { tile_count, .. } => *tile_count,
        }
    }

    pub fn tile_size(&self) -> u32 {
        match self {
            Self::Study(s) => s.tile_size,
            Self::Atlas { tile_size, .. } => *tile_size,
        }
    }

    /// Marks the tiles a pixel of `object` with footprint `f` needs.
    pub fn mark(&self, object: usize, f: &ChartFootprint, mut mark: impl FnMut(u32)) {
        match self {
            Self::Study(s) => {
                if let Some(t) = s.tile(object, f) {
                    mark(t);
                }
            }
            Self::Atlas { entries, tile_size, .. } => bilinear_tiles(&entries[object], *tile_size, f, mark),
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::{Mat4, UVec2, Vec2, Vec3, Vec4};

    use super::*;
    use crate::render::gpu_types::GpuView;
    use crate::render::objectspace::cpu::{chart_footprint, sample_pixel};
    use crate::scene::{Camera, Mesh, Object, Scene};

    /// A 2 m square quad facing the camera at distance `d`, its chart the unit
    /// square, seen by a 60-degree camera at `width` x `width` pixels.
    fn quad_at(d: f32, width: u32) -> (Scene, GpuView) {
        let positions = vec![
            Vec3::new(-1.0, 1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(-1.0, -1.0, 0.0),
        ];
        let uv = vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)];
        let scene = Scene {
            meshes: vec![Mesh {
                positions,
                normals: vec![Vec3::Z; 4],
                uv0: uv.clone(),
                uv1: Some(uv),
                indices: vec![0, 1, 2, 0, 2, 3],
                ..Default::default()
            }],
            objects: vec![Object {
                name: "quad".into(),
                mesh: 0,
                material: 0,
                transform: Mat4::IDENTITY,
                forward_only: false,
            }],
            ..Default::default()
        };
        let camera = Camera {
            position: Vec3::new(0.0, 0.0, d),
            forward: Vec3::NEG_Z,
            up: Vec3::Y,
            fov_y: 60f32.to_radians(),
            near: 0.3,
            far: 1000.0,
        };
        let w = width as f32;
        let view = GpuView {
            view_proj: camera.view_projection(1.0),
            viewport: Vec4::new(w, w, 1.0 / w, 1.0 / w),
            ..Default::default()
        };
        (scene, view)
    }

    #[test]
    fn a_quad_at_a_known_distance_marks_a_known_level_and_tile() {
        // At distance d the 60-degree view spans 2 d tan 30° = 3 m for
        // d = 1.5 sqrt(3): the 2 m quad covers 2/3 of the 512 pixels, one
        // pixel steps 1.5/512 in u and v, 4096 * 1.5 / 512 = 12 texels of
        // level 0: level floor(log2 12) = 3, a 512-texel grid of 64 x 64 tiles.
        let (scene, view) = quad_at(1.5 * 3f32.sqrt(), 512);
        let layout = StudyLayout::new(1, 4096, 8);
        let level3 = 512 * 512 + 256 * 256 + 128 * 128;
        assert_eq!(layout.level_tiles(0, 3), Some((level3, 64)));
        // Pixel (100, 300): NDC (100.5/256 - 1, 1 - 300.5/256) = (-0.6074, -0.1738),
        // times 1.5 m: (-0.9111, -0.2607); uv = ((x + 1)/2, (1 - y)/2) =
        // (0.04443, 0.63037); texel (22.75, 322.75) of 512: tile (2, 40).
        let p = sample_pixel(&scene, &view, UVec2::new(100, 300), [1, 0]);
        let f = chart_footprint(&scene, &p);
        assert!((f.uv - Vec2::new(0.044434, 0.630371)).abs().max_element() < 1e-5, "{f:?}");
        assert!((f.du_dx - Vec2::new(1.5 / 512.0, 0.0)).abs().max_element() < 1e-6, "{f:?}");
        assert_eq!(study_level(4096, &f), 3);
        assert_eq!(layout.tile(0, &f), Some(level3 + 40 * 64 + 2));
        // Every pixel on the quad (centres within 2/3 of the view from its
        // centre): 1.5 texels a pixel reach every tile of level 3, no other.
        let inside = |c: u32| ((c as f32 + 0.5) / 256.0 - 1.0).abs() * 1.5 <= 1.0;
        let tiles: std::collections::BTreeSet<u32> = (0..512 * 512)
            .map(|i| UVec2::new(i % 512, i / 512))
            .filter(|p| inside(p.x) && inside(p.y))
            .filter_map(|pixel| layout.tile(0, &chart_footprint(&scene, &sample_pixel(&scene, &view, pixel, [1, 0]))))
            .collect();
        assert_eq!(tiles, (level3..level3 + 64 * 64).collect());
    }

    #[test]
    fn the_study_floors_the_largest_component_and_clamps() {
        let f = |dx: Vec2, dy: Vec2| ChartFootprint { uv: Vec2::splat(0.5), du_dx: dx, du_dy: dy };
        // 4096 * 1/512 = 8: level 3; just below 8 texels, level 2 (floor, not round).
        assert_eq!(study_level(4096, &f(Vec2::new(1.0 / 512.0, 0.0), Vec2::ZERO)), 3);
        assert_eq!(study_level(4096, &f(Vec2::new(0.99 / 512.0, 0.0), Vec2::ZERO)), 2);
        // The largest absolute component, not the length: (-3, 3)/4096 has
        // length 4.24 texels (level 2) but largest component 3 (level 1).
        assert_eq!(study_level(4096, &f(Vec2::new(-3.0, 3.0) / 4096.0, Vec2::ZERO)), 1);
        assert_eq!(study_level(4096, &f(Vec2::ZERO, Vec2::new(0.0, -5.0 / 4096.0))), 2);
        // Magnification and degenerate footprints: level 0.
        assert_eq!(study_level(4096, &f(Vec2::splat(1e-5), Vec2::ZERO)), 0);
        assert_eq!(study_level(4096, &f(Vec2::ZERO, Vec2::ZERO)), 0);
    }

    #[test]
    fn levels_smaller_than_a_tile_mark_nothing() {
        // Tiles of 64 at 4096: levels 0-6 (4096 to 64 texels), 7 levels.
        let layout = StudyLayout::new(2, 4096, 64);
        assert!(layout.level_tiles(0, 6).is_some() && layout.level_tiles(0, 7).is_none());
        let per_object: u32 = (0..7).map(|l| (64u32 >> l).pow(2)).sum();
        assert_eq!(layout.tile_count, 2 * per_object);
        assert_eq!(layout.level_tiles(1, 0), Some((per_object, 64)));
        // 4096 * 1/32 = 128 texels a pixel: level 7, a 32-texel grid: nothing.
        let coarse = ChartFootprint { uv: Vec2::splat(0.5), du_dx: Vec2::new(1.0 / 32.0, 0.0), du_dy: Vec2::ZERO };
        assert_eq!(layout.tile(0, &coarse), None);
        // Level 6 still marks: the one 64-texel tile of object 1.
        let six = ChartFootprint { du_dx: Vec2::new(1.0 / 64.0, 0.0), ..coarse };
        assert_eq!(layout.tile(1, &six), Some(per_object + per_object - 1));
        // UVs outside the square clamp to its border tiles.
        let outside = ChartFootprint { uv: Vec2::new(1.5, -0.5), ..six };
        assert_eq!(layout.tile(0, &outside), Some(per_object - 1));
    }

    #[test]
    fn our_marking_matches_the_twins_footprint() {
        let layout = AtlasLayout::new(&[Some(256)], 8, 16, 4096, 32).unwrap();
        let entries = layout.gpu_entries();
        // One texel a pixel at level 2 (64 texels): uv * 64 - 0.5 = (7.0, 3.3):
        // taps 7-8 cross the tile edge in x only.
        let f = ChartFootprint {
            uv: Vec2::new(7.5, 3.8) / 64.0,
            du_dx: Vec2::new(4.0 / 256.0, 0.0),
            du_dy: Vec2::new(0.0, 4.0 / 256.0),
        };
        let mut tiles = Vec::new();
        bilinear_tiles(&entries[0], 8, &f, |t| tiles.push(t));
        let l = entries[0].levels[2];
        let b = cpu::bilinear(l.size, f.uv);
        assert_eq!(tiles, cpu::footprint_tiles(&l, 8, b.texel, b.texel_hi));
        assert_eq!(tiles, vec![l.tile_base, l.tile_base + 1]);
    }

    #[test]
    fn variants_of_the_markings() {
        let names = |m: &[Marking]| Variant::for_markings(m).iter().map(|v| v.to_string()).collect::<Vec<_>>();
        assert_eq!(names(&[Marking::Study]), ["study marking, 4096 textures"]);
        assert_eq!(
            names(&Marking::ALL),
            ["study marking, 4096 textures", "bilinear marking, 4096 textures", "bilinear marking, density textures"]
        );
    }
}
