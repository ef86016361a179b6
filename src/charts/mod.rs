//! Unique UV layouts ("charts") for object-space shading: every object is
//! shaded into its own texture through a parameterization in which no two
//! surface points share a texel.
//!
//! For each mesh, [`chart_mesh`] takes the first usable of: `uv1` when it is
//! unique, `uv0` when it is unique, or a layout generated with `uvunwrap`
//! (cached on disk, see [`ChartCache`]). Whichever it picks ends up in `uv1` of
//! the returned mesh: the pipeline always shades through `uv1`.
//! [`chart_scene`] does that for a whole scene, once per mesh, and sizes each
//! object's shading texture ([`TextureSizing`]).
//!
//! "Unique" is decided by [`check_overlap`] (see [`overlap`] for the rule):
//! the overlap fraction at [`ChartSettings::check_resolution`] is at most
//! [`ChartSettings::tolerance`], no UV lies outside `[0, 1]`, and at most that
//! same share of the surface area sits on triangles collapsed to zero UV area.

pub mod cache;
pub mod density;
pub mod generate;
pub mod islands;
pub mod overlap;
pub mod screen;

use std::fmt;
use std::time::Instant;

pub use cache::ChartCache;
pub use density::{TextureSize, TextureSizing, mip_count, uv_area, world_area};
pub use generate::{GeneratedChart, GeneratorSettings};
pub use overlap::{OverlapReport, check_overlap, collapsed_area_fraction};
pub use screen::{PACKING_SIZING, path_cameras, projected_densities, screen_sizings};

use crate::hash::Fnv1a;
use crate::memo::Memo;
use crate::scene::{Mesh, Scene};

/// Where the chart set in `uv1` of a [`ChartedMesh`] came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ChartSource {
    /// The mesh's own second UV set.
    Uv1,
    /// The mesh's texture coordinates, copied into `uv1`.
    Uv0,
    /// Generated now by `uvunwrap` (and written to the cache).
    Generated,
    /// Generated earlier, read from the cache.
    Cached,
}

impl fmt::Display for ChartSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(match self {
            ChartSource::Uv1 => "uv1",
            ChartSource::Uv0 => "uv0",
            ChartSource::Generated => "generated",
            ChartSource::Cached => "cached",
        })
    }
}

/// How meshes are checked and charts generated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChartSettings {
    /// Side of the texel grid of the overlap check. Overlaps count only where
    /// they are about a texel thick at this resolution, so a finer check is
    /// stricter (Sponza's pillarsSmall: 0.06% at 1024, 0.23% at 4096).
    pub check_resolution: u32,
    /// Largest overlap fraction (and collapsed-area share) of a unique layout.
    pub tolerance: f32,
    /// Settings of the chart generator.
    pub generator: GeneratorSettings,
}

impl Default for ChartSettings {
    fn default() -> Self {
        Self { check_resolution: 1024, tolerance: 0.001, generator: GeneratorSettings::default() }
    }
}

/// An existing UV set that was checked and not used.
#[derive(Clone, Debug, PartialEq)]
pub struct RejectedUvs {
    /// [`ChartSource::Uv1`] or [`ChartSource::Uv0`].
    pub source: ChartSource,
    /// What the overlap check found.
    pub overlap: OverlapReport,
    /// Why it was not used, in words.
    pub reason: String,
}

/// A mesh with a unique chart set in `uv1`.
#[derive(Clone, Debug)]
pub struct ChartedMesh {
    /// The mesh to render: the source mesh itself (with `uv1` set) for
    /// existing UVs, or a copy with vertices split along chart seams.
    pub mesh: Mesh,
    /// Where `mesh.uv1` came from.
    pub source: ChartSource,
    /// The overlap check of `mesh.uv1`.
    pub overlap: OverlapReport,
    /// For generated charts, the source vertex of each vertex of `mesh`;
    /// `None` when the vertices are the source's own.
    pub vertex_remap: Option<Vec<u32>>,
    /// Page size generated charts were packed for (their gutters are
    /// `padding` texels at this size); `None` for existing UVs.
    pub generated_resolution: Option<u32>,
    /// Existing UV sets that were checked and found not unique.
    pub rejected: Vec<RejectedUvs>,
}

impl ChartedMesh {
    /// The chart set (`mesh.uv1`).
    pub fn uvs(&self) -> &[glam::Vec2] {
        self.mesh.uv1.as_deref().unwrap_or(&[])
    }

    /// Share of the UV square the charts cover (see [`uv_area`]).
    pub fn uv_coverage(&self) -> f32 {
        uv_area(self.uvs(), &self.mesh.indices)
    }
}

/// Why charting failed.
#[derive(Debug, thiserror::Error)]
pub enum ChartError {
    /// The mesh breaks an invariant of [`Mesh::validate`].
    #[error("{0}")]
    InvalidMesh(String),
    /// An object refers to a mesh the scene does not have.
    #[error("object '{object}' refers to missing mesh {mesh}")]
    MissingMesh { object: String, mesh: usize },
    /// `uvunwrap` could not unwrap the mesh.
    #[error("mesh '{mesh}': chart generation failed: {source}")]
    Generation {
        mesh: String,
        #[source]
        source: uvunwrap::Error,
    },
}

/// Verdicts of [`judge`] remembered, at most this many: a few hundred
/// bytes each.
const VERDICTS: usize = 1 << 14;

static JUDGED: Memo<(OverlapReport, Option<String>)> = Memo::new(VERDICTS, |_| 1);

/// Checks one UV set: the overlap report, and why it isn't unique if it
/// isn't. Remembered by content ([`crate::memo`]): every renderer built over
/// a scene charts its meshes again, and checking a mesh's own UVs (drawing
/// them at [`ChartSettings::check_resolution`]) was most of that.
fn judge(mesh: &Mesh, uvs: &[glam::Vec2], settings: &ChartSettings) -> (OverlapReport, Option<String>) {
    let mut h = Fnv1a::default();
    h.write_pod(&[settings.check_resolution]);
    h.write_pod(&[settings.tolerance]);
    h.write_pod(uvs);
    h.write_pod(&mesh.indices);
    h.write_pod(&mesh.positions);
    JUDGED.get(h.finish(), || judge_afresh(mesh, uvs, settings)).as_ref().clone()
}

/// [`judge`] as it is derived.
fn judge_afresh(mesh: &Mesh, uvs: &[glam::Vec2], settings: &ChartSettings) -> (OverlapReport, Option<String>) {
    let report = check_overlap(uvs, &mesh.indices, settings.check_resolution);
    let reason = if report.out_of_range_vertices > 0 {
        Some(format!("{} vertices outside [0, 1]", report.out_of_range_vertices))
    } else if report.covered_texels == 0 {
        Some("covers no texel".to_string())
    } else if report.fraction > settings.tolerance {
        Some(format!("{:.3}% of covered texels overlap", 100.0 * report.fraction))
    } else {
        let collapsed = if report.degenerate_triangles > 0 {
            collapsed_area_fraction(&mesh.positions, uvs, &mesh.indices)
        } else {
            0.0
        };
        (collapsed > settings.tolerance).then(|| format!("{:.3}% of the surface has zero UV area", 100.0 * collapsed))
    };
    (report, reason)
}

/// Gives `mesh` a unique chart set in `uv1`: its own `uv1` or `uv0` when
/// unique, else a generated one packed for a page of `texture_side` texels
/// (clamped by [`GeneratorSettings::resolution_for`]), read from `cache` when
/// it was generated before.
pub fn chart_mesh(
    mesh: &Mesh,
    texture_side: u32,
    settings: &ChartSettings,
    cache: &ChartCache,
) -> Result<ChartedMesh, ChartError> {
    mesh.validate().map_err(ChartError::InvalidMesh)?;
    let mut rejected = Vec::new();
    let existing = [(ChartSource::Uv1, mesh.uv1.as_deref()), (ChartSource::Uv0, Some(mesh.uv0.as_slice()))];
    for (source, uvs) in existing {
        let Some(uvs) = uvs else { continue };
        let (overlap, reason) = judge(mesh, uvs, settings);
        match reason {
            None => {
                let mut charted = mesh.clone();
                charted.uv1 = Some(uvs.to_vec());
                return Ok(ChartedMesh {
                    mesh: charted,
                    source,
                    overlap,
                    vertex_remap: None,
                    generated_resolution: None,
                    rejected,
                });
            }
            Some(reason) => rejected.push(RejectedUvs { source, overlap, reason }),
        }
    }

    let resolution = settings.generator.resolution_for(texture_side);
    let key = cache::chart_key(mesh, resolution, &settings.generator);
    let (chart, source) = match cache.load(key, mesh) {
        Some(chart) => (chart, ChartSource::Cached),
        None => {
            let start = Instant::now();
            let chart = generate::generate(mesh, resolution, &settings.generator)
                .map_err(|source| ChartError::Generation { mesh: mesh.name.clone(), source })?;
            tracing::info!(
                "mesh '{}': generated charts for {} triangles at {} in {:.2} s",
                mesh.name,
                mesh.triangle_count(),
                chart.resolution,
                start.elapsed().as_secs_f32()
            );
            cache.store(key, &chart);
            (chart, ChartSource::Generated)
        }
    };
    let charted = generate::apply(mesh, &chart);
    let (overlap, reason) = judge(&charted, chart.uvs.as_slice(), settings);
    if let Some(reason) = reason {
        // uvunwrap promises valid charts; say so loudly if one is not.
        tracing::warn!("mesh '{}': generated charts are not unique: {reason}", mesh.name);
    }
    Ok(ChartedMesh {
        mesh: charted,
        source,
        overlap,
        vertex_remap: Some(chart.remap),
        generated_resolution: Some(chart.resolution),
        rejected,
    })
}

/// One row of [`SceneCharts`]: an object, its chart and its texture.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectChart {
    /// The object's name.
    pub name: String,
    /// Index into [`Scene::objects`].
    pub object: usize,
    /// Index into [`Scene::meshes`] and [`SceneCharts::meshes`].
    pub mesh: usize,
    /// Triangles of the object's mesh.
    pub triangles: usize,
    /// World surface area in m² (the mesh under the object's transform).
    pub world_area: f32,
    /// `None` for `forward_only` objects, which have no shading texture.
    pub shading: Option<ObjectShading>,
}

/// Chart and texture of an object shaded in object space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectShading {
    /// Where the chart set came from.
    pub source: ChartSource,
    /// Overlap fraction of the chart set (see [`OverlapReport::fraction`]).
    pub overlap_fraction: f32,
    /// Share of the UV square the charts cover.
    pub uv_coverage: f32,
    /// The shading texture: side, mip count and achieved texel density.
    pub texture: TextureSize,
}

/// Charts and shading-texture sizes of every object of a scene.
#[derive(Clone, Debug)]
pub struct SceneCharts {
    /// One per scene object, in scene order.
    pub objects: Vec<ObjectChart>,
    /// One per scene mesh: the charted mesh, or `None` for meshes that only
    /// `forward_only` objects (or none) use.
    pub meshes: Vec<Option<ChartedMesh>>,
}

impl SceneCharts {
    /// The charted mesh object `object` is drawn with, if it is shaded in object space.
    pub fn charted_mesh(&self, object: usize) -> Option<&ChartedMesh> {
        let row = self.objects.get(object)?;
        row.shading.and(self.meshes.get(row.mesh)?.as_ref())
    }

    /// Shading-texture side per object; `None` for objects shaded forward.
    pub fn texture_sizes(&self) -> Vec<Option<u32>> {
        self.objects.iter().map(|o| o.shading.map(|s| s.texture.side)).collect()
    }

    /// A copy of `scene` whose meshes carry their charts in `uv1`: where a
    /// chart was generated the mesh is replaced (vertices split along seams,
    /// same triangles in the same order).
    pub fn apply(&self, scene: &Scene) -> Scene {
        let mut charted = scene.clone();
        for (mesh, chart) in charted.meshes.iter_mut().zip(&self.meshes) {
            if let Some(chart) = chart {
                *mesh = chart.mesh.clone();
            }
        }
        charted
    }

    /// The per-object table as aligned text (the same as `Display`).
    pub fn table(&self) -> String {
        self.to_string()
    }
}

impl fmt::Display for SceneCharts {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let header =
            ["object", "triangles", "chart", "overlap", "area m²", "uv cover", "texture", "mips", "texels/m", "notes"];
        let rows: Vec<[String; 10]> = self
            .objects
            .iter()
            .map(|o| {
                let notes = self.meshes[o.mesh]
                    .as_ref()
                    .filter(|_| o.shading.is_some())
                    .map(|c| {
                        c.rejected.iter().map(|r| format!("{}: {}", r.source, r.reason)).collect::<Vec<_>>().join("; ")
                    })
                    .unwrap_or_default();
                let common = [o.name.clone(), o.triangles.to_string()];
                let area = format!("{:.2}", o.world_area);
                match &o.shading {
                    Some(s) => [
                        common[0].clone(),
                        common[1].clone(),
                        s.source.to_string(),
                        format!("{:.3}%", 100.0 * s.overlap_fraction),
                        area,
                        format!("{:.1}%", 100.0 * s.uv_coverage),
                        format!("{0}x{0}", s.texture.side),
                        s.texture.mip_count.to_string(),
                        format!("{:.0}", s.texture.texels_per_metre),
                        notes,
                    ],
                    None => {
                        let dash = || "-".to_string();
                        [
                            common[0].clone(),
                            common[1].clone(),
                            "forward".into(),
                            dash(),
                            area,
                            dash(),
                            dash(),
                            dash(),
                            dash(),
                            "forward_only: not charted".into(),
                        ]
                    }
                }
            })
            .collect();
        let width = |k: usize| rows.iter().map(|r| r[k].chars().count()).chain([header[k].chars().count()]).max();
        let widths: Vec<usize> = (0..header.len()).map(|k| width(k).unwrap_or(0)).collect();
        let line = |f: &mut fmt::Formatter<'_>, cells: &[&str]| -> fmt::Result {
            let mut text = String::new();
            for (k, cell) in cells.iter().enumerate() {
                let pad = widths[k].saturating_sub(cell.chars().count());
                // Names, sources and notes left-aligned; numbers right-aligned.
                if matches!(k, 0 | 2 | 9) {
                    text.push_str(cell);
                    text.push_str(&" ".repeat(pad));
                } else {
                    text.push_str(&" ".repeat(pad));
                    text.push_str(cell);
                }
                text.push_str("  ");
            }
            writeln!(f, "{}", text.trim_end())
        };
        line(f, &header)?;
        for r in &rows {
            line(f, &r.iter().map(String::as_str).collect::<Vec<_>>())?;
        }
        let shaded: Vec<_> = self.objects.iter().filter_map(|o| o.shading).collect();
        let texels: u64 = shaded.iter().map(|s| (s.texture.side as u64).pow(2)).sum();
        writeln!(
            f,
            "{} objects, {} shaded in object space, {:.1} Mtexels at mip 0",
            self.objects.len(),
            shaded.len(),
            texels as f64 / 1e6
        )
    }
}

/// [`chart_scene_with`] with the default [`ChartSettings`].
pub fn chart_scene(scene: &Scene, sizing: &TextureSizing, cache: &ChartCache) -> Result<SceneCharts, ChartError> {
    chart_scene_with(scene, sizing, &ChartSettings::default(), cache)
}

/// Charts every mesh that an object shaded in object space uses (once per
/// mesh, however many objects share it) and sizes every such object's
/// shading texture. `forward_only` objects are listed but not charted.
///
/// Generated charts are packed for the smallest texture any of the mesh's
/// objects could get (the side for charts covering the whole UV square), so
/// that gutters are at least the generator's padding in every final texture.
pub fn chart_scene_with(
    scene: &Scene,
    sizing: &TextureSizing,
    settings: &ChartSettings,
    cache: &ChartCache,
) -> Result<SceneCharts, ChartError> {
    chart_scene_sized(scene, &vec![*sizing; scene.objects.len()], sizing, settings, cache)
}

/// [`chart_scene_with`] with a texture sizing per object (`sizings[i]` for
/// `scene.objects[i]`; [`screen::screen_sizings`] gives one that follows the
/// screen; an object without one is sized like the last that has one),
/// generated charts packed as for `packing` (so that the charts, and their
/// cache entries, do not change with the image size or the camera: a
/// texture smaller than the packing page is like a coarser mip level of it).
pub fn chart_scene_sized(
    scene: &Scene,
    sizings: &[TextureSizing],
    packing: &TextureSizing,
    settings: &ChartSettings,
    cache: &ChartCache,
) -> Result<SceneCharts, ChartError> {
    let fallback = TextureSizing::Density { texels_per_metre: 0.0, min: 64, max: 64 };
    let sizing = |i: usize| *sizings.get(i).or(sizings.last()).unwrap_or(&fallback);
    for o in &scene.objects {
        if o.mesh >= scene.meshes.len() {
            return Err(ChartError::MissingMesh { object: o.name.clone(), mesh: o.mesh });
        }
    }
    // Instances of a mesh turned alike have the same area (translation does
    // not change it): one sum per mesh and turn, not per instance.
    let mut area_of: std::collections::HashMap<(usize, [u32; 9]), f32> = Default::default();
    let areas: Vec<f32> = scene
        .objects
        .iter()
        .map(|o| {
            let linear = glam::Mat3::from_mat4(o.transform).to_cols_array().map(f32::to_bits);
            *area_of.entry((o.mesh, linear)).or_insert_with(|| world_area(&scene.meshes[o.mesh], &o.transform))
        })
        .collect();

    let mut meshes: Vec<Option<ChartedMesh>> = vec![None; scene.meshes.len()];
    for (m, slot) in meshes.iter_mut().enumerate() {
        let side = scene
            .objects
            .iter()
            .zip(&areas)
            .filter(|(o, _)| o.mesh == m && !o.forward_only)
            .map(|(_, &area)| packing.min_side(area))
            .min();
        if let Some(side) = side {
            *slot = Some(chart_mesh(&scene.meshes[m], side, settings, cache)?);
        }
    }

    let objects = scene
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| {
            let shading = meshes[o.mesh].as_ref().filter(|_| !o.forward_only).map(|c| {
                let uv_coverage = c.uv_coverage();
                ObjectShading {
                    source: c.source,
                    overlap_fraction: c.overlap.fraction,
                    uv_coverage,
                    texture: sizing(i).size(areas[i], uv_coverage),
                }
            });
            ObjectChart {
                name: o.name.clone(),
                object: i,
                mesh: o.mesh,
                triangles: scene.meshes[o.mesh].triangle_count(),
                world_area: areas[i],
                shading,
            }
        })
        .collect();
    Ok(SceneCharts { objects, meshes })
}

#[cfg(test)]
mod tests;
