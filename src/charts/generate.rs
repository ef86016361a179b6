//! Chart generation with `uvunwrap` (xatlas-style segmentation, LSCM + ARAP
//! parameterization, shape packing), for meshes whose own UV sets are not
//! unique.

use glam::Vec2;

use crate::scene::Mesh;

/// Settings of the chart generator. All of them are part of the cache key.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GeneratorSettings {
    /// Empty texels around each chart at the generator's resolution (charts are
    /// `2 * padding` texels apart and `padding` from the page edges).
    pub padding: u32,
    /// Smallest page the generator packs into. Below it the gutters of a small
    /// texture shrink under `padding` texels (at 64 x 64 and the defaults, to 1).
    pub min_resolution: u32,
    /// Largest page the generator packs into: a larger texture just gets wider
    /// gutters, and packing time grows with the page area.
    pub max_resolution: u32,
    /// `uvunwrap`'s largest angle (degrees) between a face and its chart's
    /// average normal.
    pub max_chart_angle: f32,
    /// Pack by rows (`uvunwrap::Packing::Fast`) instead of by shape. On the
    /// Sponza objects at 2048 it was 5 to 20 times faster than shape packing
    /// for about the same coverage, so it is the default.
    pub fast_packing: bool,
}

impl Default for GeneratorSettings {
    fn default() -> Self {
        Self { padding: 4, min_resolution: 256, max_resolution: 4096, max_chart_angle: 70.0, fast_packing: true }
    }
}

impl GeneratorSettings {
    /// The page size the generator uses for a texture of `texture_side` texels.
    pub fn resolution_for(&self, texture_side: u32) -> u32 {
        let lo = self.min_resolution.max(4 * self.padding + 4);
        texture_side.clamp(lo, self.max_resolution.max(lo))
    }
}

/// A generated chart set: the new vertices (as indices of the source mesh's
/// vertices), their chart UVs and the remapped triangles.
#[derive(Clone, Debug, PartialEq)]
pub struct GeneratedChart {
    /// Page size the charts were packed for (with `padding` texel gutters).
    pub resolution: u32,
    /// For each new vertex, the source vertex it copies.
    pub remap: Vec<u32>,
    /// Chart UV of each new vertex, in `[0, 1]` of a square page.
    pub uvs: Vec<Vec2>,
    /// The source triangles, in the same order, indexing the new vertices.
    pub indices: Vec<u32>,
}

/// Pages larger than this are not tried when charts don't fit one page.
const LARGEST_PAGE: u32 = 16384;

/// Unwraps `mesh` onto one square page of `resolution` texels (doubled until
/// every chart fits one page). The source's vertex attributes are not read:
/// only positions (identical positions are welded; split vertices become
/// preferred seams) and triangles.
pub fn generate(mesh: &Mesh, resolution: u32, settings: &GeneratorSettings) -> Result<GeneratedChart, uvunwrap::Error> {
    let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|p| p.to_array()).collect();
    let input = uvunwrap::MeshInput::new(&positions, &mesh.indices);
    let mut page = resolution;
    loop {
        let options = uvunwrap::Options {
            max_chart_angle: settings.max_chart_angle,
            density: uvunwrap::Density::Auto { page_size: page },
            padding: settings.padding,
            packing: if settings.fast_packing { uvunwrap::Packing::Fast } else { uvunwrap::Packing::Shape },
            ..uvunwrap::Options::default()
        };
        let fits = match uvunwrap::generate(&[input], &options) {
            // Automatic density falls back to several pages when the charts'
            // padding alone can't share one: overlapping UVs for us, so retry larger.
            Ok(atlas) if atlas.page_count <= 1 => Some(atlas),
            Ok(_) | Err(uvunwrap::Error::ChartTooLarge { .. }) if page < LARGEST_PAGE => None,
            Ok(_) => {
                return Err(uvunwrap::Error::ChartTooLarge { width: page, height: page, page_size: page });
            }
            Err(e) => return Err(e),
        };
        let Some(atlas) = fits else {
            tracing::debug!("mesh '{}': charts don't fit one {page} page, trying {}", mesh.name, page * 2);
            page *= 2;
            continue;
        };
        let out = atlas.meshes.into_iter().next().unwrap_or_default();
        // The page is cropped to the rows used: v is relative to `height`.
        // Rescale it to the square page of `width` texels the texture has.
        let v_scale = atlas.height as f32 / atlas.width as f32;
        return Ok(GeneratedChart {
            resolution: page,
            remap: out.vertices.iter().map(|v| v.xref).collect(),
            uvs: out.vertices.iter().map(|v| Vec2::new(v.uv[0], v.uv[1] * v_scale)).collect(),
            indices: out.indices,
        });
    }
}

/// A copy of `mesh` with its vertices split along the chart seams: every
/// attribute is copied from the source vertex `chart.remap` names, `uv1` is the
/// chart and the triangles are `chart.indices`.
pub fn apply(mesh: &Mesh, chart: &GeneratedChart) -> Mesh {
    fn pick<T: Copy>(attr: &[T], remap: &[u32]) -> Vec<T> {
        remap.iter().map(|&i| attr[i as usize]).collect()
    }
    let n = mesh.positions.len();
    // Attributes of the wrong length (an unvalidated mesh) are left empty
    // rather than read out of range.
    let copy = |len: usize| len == n;
    Mesh {
        name: mesh.name.clone(),
        positions: pick(&mesh.positions, &chart.remap),
        normals: if copy(mesh.normals.len()) { pick(&mesh.normals, &chart.remap) } else { Vec::new() },
        tangents: if copy(mesh.tangents.len()) { pick(&mesh.tangents, &chart.remap) } else { Vec::new() },
        uv0: if copy(mesh.uv0.len()) { pick(&mesh.uv0, &chart.remap) } else { Vec::new() },
        uv1: Some(chart.uvs.clone()),
        indices: chart.indices.clone(),
    }
}
