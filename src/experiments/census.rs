//! Which tiles a view needs, in every variant and tile size at once: the
//! scene prepared for the studies (objects left out, UV layouts per variant,
//! our texture sizes) and the CPU marking of a read-back visibility buffer.

use glam::UVec2;
use rayon::prelude::*;
use serde::Serialize;

use super::marking::{Texture, TileSpace, Variant};
use super::tile_set::{ConcurrentTileSet, TileSet};
use super::visibility::IdImage;
use crate::charts::{self, ChartCache, ChartError, ChartSource, TextureSizing};
use crate::materials::{self, MaterialsSpec};
use crate::render::objectspace::MAX_DENSITY_SIZE;
use crate::render::objectspace::atlas::AtlasError;
use crate::render::objectspace::cpu::{chart_footprint, sample_pixel};
use crate::scene::{self, Scene, SceneError};

/// Why a scene could not be prepared for the studies.
#[derive(Debug, thiserror::Error)]
pub enum StudySceneError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Charts(#[from] ChartError),
    #[error("--exclude: no object '{name}' (objects: {known})")]
    UnknownObject { name: String, known: String },
    #[error("--exclude leaves no object")]
    NothingLeft,
    #[error(transparent)]
    Materials(#[from] materials::file::MaterialsError),
}

/// How one object is counted.
#[derive(Clone, Debug, Serialize)]
pub struct ObjectSetup {
    pub name: String,
    /// UV layout of the 4096 variants: the file's own where it has one (the
    /// study shaded through those), else our generated chart.
    pub study_uvs: String,
    /// Our chart (density variant): `uv0`, `uv1`, or `generated`.
    pub our_chart: String,
    /// Overlap fraction of the file's layout, where our check rejected it.
    pub file_uv_overlap: Option<f32>,
    /// Our texture side at the texel density, after the atlas budget.
    pub density_size: Option<u32>,
}

/// A scene prepared for the tile studies.
pub struct StudyScene {
    pub name: String,
    /// The scene without the excluded objects, as the visibility pass draws it.
    pub render: Scene,
    /// Meshes carrying the 4096 variants' UV layouts (in `uv1`, or `uv0`
    /// with `uv1` unset); same triangles in the same order as `render`.
    study: Scene,
    /// Meshes carrying our charts, as `--pipeline objectspace` shades.
    charted: Scene,
    /// Our virtual texture sides (texel density).
    pub density_sizes: Vec<Option<u32>>,
    pub objects: Vec<ObjectSetup>,
    pub excluded: Vec<String>,
    pub texel_density: f32,
}

impl StudyScene {
    /// Loads scene `spec`, leaves out the objects named in `exclude`, and
    /// charts it at `texel_density` (generated charts come from `cache`).
    pub fn load(
        spec: &str,
        exclude: &[String],
        texel_density: f32,
        cache: &ChartCache,
    ) -> Result<Self, StudySceneError> {
        let mut render = scene::load(spec)?;
        for name in exclude {
            if !render.objects.iter().any(|o| &o.name == name) {
                let known: Vec<&str> = render.objects.iter().map(|o| o.name.as_str()).collect();
                return Err(StudySceneError::UnknownObject { name: name.clone(), known: known.join(", ") });
            }
        }
        render.objects.retain(|o| !exclude.contains(&o.name));
        if render.objects.is_empty() {
            return Err(StudySceneError::NothingLeft);
        }
        let sizing = TextureSizing::Density { texels_per_metre: texel_density, min: 64, max: MAX_DENSITY_SIZE };
        let charts = charts::chart_scene(&render, &sizing, cache)?;
        let density_sizes = charts.texture_sizes();
        let charted = charts.apply(&render);
        let mut study = charted.clone();
        let mut objects = Vec::new();
        for (i, o) in render.objects.iter().enumerate() {
            let chart = charts.meshes[o.mesh].as_ref();
            // The file's layout our check rejected (overlaps), if any: the study used it.
            let rejected = chart.and_then(|c| c.rejected.first());
            if let Some(r) = rejected {
                let mut mesh = render.meshes[o.mesh].clone();
                if r.source == ChartSource::Uv0 {
                    mesh.uv1 = None;
                }
                study.meshes[o.mesh] = mesh;
            }
            let our_chart = chart.map_or("none".to_string(), |c| match c.source {
                ChartSource::Cached => ChartSource::Generated.to_string(),
                s => s.to_string(),
            });
            objects.push(ObjectSetup {
                name: o.name.clone(),
                study_uvs: rejected.map_or(our_chart.clone(), |r| format!("file {}", r.source)),
                our_chart,
                file_uv_overlap: rejected.map(|r| r.overlap.fraction),
                density_size: density_sizes[i],
            });
        }
        Ok(Self {
            name: render.name.clone(),
            render,
            study,
            charted,
            density_sizes,
            objects,
            excluded: exclude.to_vec(),
            texel_density,
        })
    }
}

impl StudyScene {
    /// The scene with our charts in `uv1`, as `--pipeline objectspace` shades it.
    pub fn charted(&self) -> &Scene {
        &self.charted
    }

    /// Gives every variant of the scene (drawn, the study's and ours
    /// charted) the materials `spec` makes (`experiment --materials`, as
    /// `render --materials`): layers change materials, not geometry, so the
    /// charts and tile spaces hold.
    pub fn apply_materials(&mut self, spec: &MaterialsSpec) -> Result<(), StudySceneError> {
        for scene in [&mut self.render, &mut self.study, &mut self.charted] {
            materials::apply(scene, spec)?;
        }
        Ok(())
    }
}

/// One tile index space: a variant at a tile size.
#[derive(Clone, Debug)]
pub struct Space {
    pub variant: Variant,
    pub tile_size: u32,
    pub tiles: TileSpace,
}

/// Marks a view's tiles in every space.
pub struct Census<'a> {
    scene: &'a StudyScene,
    pub spaces: Vec<Space>,
}

impl<'a> Census<'a> {
    /// Spaces for every variant at every tile size, in that order.
    pub fn new(scene: &'a StudyScene, variants: &[Variant], tile_sizes: &[u32]) -> Result<Self, AtlasError> {
        let mut spaces = Vec::new();
        for &variant in variants {
            for &tile_size in tile_sizes {
                let tiles = TileSpace::new(variant, tile_size, &scene.density_sizes)?;
                spaces.push(Space { variant, tile_size, tiles });
            }
        }
        Ok(Self { scene, spaces })
    }

    /// The tiles each space's marking needs for a visibility buffer, in the
    /// order of [`Census::spaces`]. Rows run in parallel.
    pub fn tiles(&self, image: &IdImage) -> Vec<TileSet> {
        let sets: Vec<ConcurrentTileSet> =
            self.spaces.iter().map(|s| ConcurrentTileSet::new(s.tiles.tile_count())).collect();
        let (study, charted) = (&self.scene.study, &self.scene.charted);
        let density = self.spaces.iter().any(|s| s.variant.texture == Texture::Density);
        (0..image.height).into_par_iter().for_each(|y| {
            for x in 0..image.width {
                let ids = image.ids[(y * image.width + x) as usize];
                if ids[0] == 0 {
                    continue;
                }
                // Positions and triangles are the same in both scenes.
                let p = sample_pixel(study, &image.view, UVec2::new(x, y), ids);
                let at_4096 = chart_footprint(study, &p);
                let ours = if density { chart_footprint(charted, &p) } else { at_4096 };
                for (space, set) in self.spaces.iter().zip(&sets) {
                    let f = if space.variant.texture == Texture::Density { &ours } else { &at_4096 };
                    space.tiles.mark(p.object, f, |t| set.insert(t));
                }
            }
        });
        sets.into_iter().map(ConcurrentTileSet::finish).collect()
    }
}
