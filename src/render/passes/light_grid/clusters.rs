//! View-space clusters: the screen cut into tiles, each tile cut into
//! logarithmic depth slices from the camera's near plane to the far side of
//! the scene, for clustered forward shading. A cell is bounded by the
//! view-space box of its piece of the frustum; lights are moved to view space.

use glam::{UVec3, Vec2, Vec3};
use serde::Serialize;

use super::{GpuLightGridParams, LightGrid};
use crate::render::frame::Frame;
use crate::render::scene_gpu::SceneGpu;
use crate::scene::{Aabb, Camera};
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

pub const SHADER: ShaderSource = ShaderSource::new("light_grid/clusters.wgsl", include_str!("clusters.wgsl"));

/// How finely the view is cut.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct ClusterDims {
    pub tiles_x: u32,
    pub tiles_y: u32,
    /// Logarithmic depth slices.
    pub slices: u32,
}

impl Default for ClusterDims {
    /// 16 x 9 tiles (square on a 16:9 screen) x 24 slices: 3456 cells.
    fn default() -> Self {
        Self { tiles_x: 16, tiles_y: 9, slices: 24 }
    }
}

impl ClusterDims {
    pub fn cell_count(&self) -> u32 {
        self.tiles_x * self.tiles_y * self.slices
    }
}

/// The cluster grid: its GPU lists and what its geometry is built from.
pub struct Clusters {
    pub grid: LightGrid,
    dims: ClusterDims,
    /// World bounds of the scene (the last slice ends at their far side).
    scene_bounds: Aabb,
}

impl Clusters {
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        dims: ClusterDims,
    ) -> Result<Self, ShaderError> {
        assert!(dims.tiles_x > 0 && dims.tiles_y > 0 && dims.slices > 0, "empty cluster grid {dims:?}");
        let grid = LightGrid::new(device, shaders, scene, "clusters", SHADER, dims.cell_count())?;
        let scene_bounds = scene.object_bounds.iter().fold(Aabb::EMPTY, |u, b| u.union(b));
        Ok(Self { grid, dims, scene_bounds })
    }

    /// The geometry for `camera` on a screen of `aspect` (width / height):
    /// slices from the near plane to the farthest corner of the scene's
    /// bounds (1% beyond it), or the far plane if nearer.
    pub fn geometry(&self, camera: &Camera, aspect: f32) -> GpuLightGridParams {
        let forward = camera.forward.normalize();
        let deepest = if self.scene_bounds.is_empty() {
            camera.far
        } else {
            self.scene_bounds.corners().iter().map(|c| (*c - camera.position).dot(forward)).fold(f32::MIN, f32::max)
        };
        let near = camera.near;
        let far = (deepest * 1.01).min(camera.far).max(near * 2.0);
        let tan = (0.5 * camera.fov_y).tan();
        let dims = UVec3::new(self.dims.tiles_x, self.dims.tiles_y, self.dims.slices);
        GpuLightGridParams {
            to_grid: camera.view(),
            dims,
            cell_count: self.dims.cell_count(),
            tan_half: Vec2::new(aspect * tan, tan),
            near,
            far,
            slices_per_log: self.dims.slices as f32 / (far / near).ln(),
            ..Default::default()
        }
    }
}

/// Reads: the camera, the scene's lights. Writes: the clusters' cells and
/// lists (timed as `clusters: count`, `clusters: scan`, `clusters: fill`).
pub fn build_clusters(frame: &mut Frame, clusters: &mut Clusters) {
    let aspect = frame.targets.width as f32 / frame.targets.height as f32;
    let params = clusters.geometry(frame.camera, aspect);
    // Clusters are view space and few per light: one work item each.
    clusters.grid.build(frame, params, |_| 1);
}

/// View depth of slice boundary `k` (0: near; `slices`: far). Mirrors
/// `slice_depth` in `clusters.wgsl`.
fn slice_depth(p: &GpuLightGridParams, k: u32) -> f32 {
    match k {
        0 => p.near,
        k if k >= p.dims.z => p.far,
        k => p.near * (k as f32 / p.slices_per_log).exp(),
    }
}

/// The view-space box of cluster `cell` (the CPU twin of `cluster_box` in
/// `clusters.wgsl`): the box of the 8 corners of its frustum piece.
pub fn cell_bounds(p: &GpuLightGridParams, cell: u32) -> Aabb {
    let (tx, ty, k) = (cell % p.dims.x, (cell / p.dims.x) % p.dims.y, cell / (p.dims.x * p.dims.y));
    let tiles = Vec2::new(p.dims.x as f32, p.dims.y as f32);
    let x0 = -1.0 + 2.0 * tx as f32 / tiles.x;
    let x1 = -1.0 + 2.0 * (tx + 1) as f32 / tiles.x;
    let y1 = 1.0 - 2.0 * ty as f32 / tiles.y;
    let y0 = 1.0 - 2.0 * (ty + 1) as f32 / tiles.y;
    let (d0, d1) = (slice_depth(p, k), slice_depth(p, k + 1));
    let th = p.tan_half;
    Aabb {
        min: Vec3::new((x0 * d0).min(x0 * d1) * th.x, (y0 * d0).min(y0 * d1) * th.y, -d1),
        max: Vec3::new((x1 * d0).max(x1 * d1) * th.x, (y1 * d0).max(y1 * d1) * th.y, -d0),
    }
}
