//! A mesh builder for the procedural scenes that also lays out each object's
//! unique chart atlas (`uv1`).
//!
//! Shapes add vertices to a *chart*: a flat piece of surface with its own 2D
//! coordinates in metres (a box face, an unrolled lathe strip, an arch's
//! intrados, a banner sheet). [`MeshBuilder::finish`] takes each chart's
//! bounding rectangle, packs the rectangles into the unit square with a shelf
//! packer and one uniform scale (so that texel density is the same on every
//! chart of an object), and writes `uv1`.
//!
//! Gutter rule: every chart sits in a cell inset by `GUTTER / 2` on each side,
//! so two charts are at least [`GUTTER`] apart and every chart is at least
//! `GUTTER / 2` from the border of the unit square (the same `GUTTER` again
//! when the atlas wraps or is tiled next to another object's atlas).
//! `GUTTER = 1/128` is 4 texels at 512 x 512, so bilinear filtering (plus a
//! 1-texel dilation) still stays inside a chart's own gutter down to the
//! 512 mip of a larger atlas.

use glam::{Vec2, Vec3};

use crate::scene::Mesh;

/// Minimum distance in uv1 between two charts (fraction of the unit square).
pub const GUTTER: f32 = 1.0 / 128.0;

/// Handle of a chart inside one [`MeshBuilder`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChartId(u32);

/// An axis-aligned rectangle in uv1 space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvRect {
    /// Lower-left corner.
    pub min: Vec2,
    /// Upper-right corner.
    pub max: Vec2,
}

impl UvRect {
    /// Whether `p` lies in the rectangle, allowing `eps` of rounding.
    pub fn contains(&self, p: Vec2, eps: f32) -> bool {
        p.cmpge(self.min - eps).all() && p.cmple(self.max + eps).all()
    }

    /// The larger of the horizontal and vertical gaps between two rectangles
    /// (negative when they overlap): the Chebyshev separation.
    pub fn separation(&self, o: &UvRect) -> f32 {
        let gx = (o.min.x - self.max.x).max(self.min.x - o.max.x);
        let gy = (o.min.y - self.max.y).max(self.min.y - o.max.y);
        gx.max(gy)
    }

    /// Area as a fraction of the unit square.
    pub fn area(&self) -> f32 {
        let e = self.max - self.min;
        e.x * e.y
    }
}

/// Where [`MeshBuilder::finish`] put each chart; kept for tests and reports.
#[derive(Clone, Debug)]
pub struct ChartLayout {
    /// The uv1 rectangle of each chart's content (without its gutter).
    pub rects: Vec<UvRect>,
    /// The chart of each triangle.
    pub triangle_chart: Vec<u32>,
    /// uv1 units per metre, the same for every chart of the object.
    pub scale: f32,
    /// The gutter the layout honours (see the module docs).
    pub gutter: f32,
}

impl ChartLayout {
    /// Fraction of the unit square covered by chart rectangles.
    pub fn utilisation(&self) -> f32 {
        self.rects.iter().map(UvRect::area).sum()
    }
}

/// Collects triangles grouped into charts; see the module docs.
#[derive(Default)]
pub struct MeshBuilder {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    uv0: Vec<Vec2>,
    /// Chart-local coordinates in metres.
    local: Vec<Vec2>,
    chart_of: Vec<u32>,
    indices: Vec<u32>,
    charts: u32,
}

impl MeshBuilder {
    /// An empty builder.
    pub fn new() -> Self {
        Self::default()
    }

    /// Whether nothing has been added yet.
    pub fn is_empty(&self) -> bool {
        self.indices.is_empty()
    }

    /// Triangles added so far.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// Starts a new chart; vertices added to it share one flat 2D layout.
    pub fn chart(&mut self) -> ChartId {
        self.charts += 1;
        ChartId(self.charts - 1)
    }

    /// Adds a vertex: world position, unit normal, texture uv0, and its
    /// position in the chart's 2D layout in metres (any origin).
    pub fn vertex(&mut self, chart: ChartId, p: Vec3, n: Vec3, uv0: Vec2, local: Vec2) -> u32 {
        debug_assert!(chart.0 < self.charts);
        self.positions.push(p);
        self.normals.push(n.normalize());
        self.uv0.push(uv0);
        self.local.push(local);
        self.chart_of.push(chart.0);
        (self.positions.len() - 1) as u32
    }

    /// Adds a triangle, wound counter-clockwise as seen from the side its
    /// vertex normals point to (so callers need not care about winding).
    pub fn triangle(&mut self, a: u32, b: u32, c: u32) {
        debug_assert!(self.chart_of[a as usize] == self.chart_of[b as usize]);
        debug_assert!(self.chart_of[a as usize] == self.chart_of[c as usize]);
        let [pa, pb, pc] = [a, b, c].map(|i| self.positions[i as usize]);
        let n = [a, b, c].iter().map(|&i| self.normals[i as usize]).sum::<Vec3>();
        if (pb - pa).cross(pc - pa).dot(n) < 0.0 {
            self.indices.extend_from_slice(&[a, c, b]);
        } else {
            self.indices.extend_from_slice(&[a, b, c]);
        }
    }

    /// Adds the quad `a b c d` (corners in order around it) as two triangles.
    pub fn quad(&mut self, a: u32, b: u32, c: u32, d: u32) {
        self.triangle(a, b, c);
        self.triangle(a, c, d);
    }

    /// A flat rectangle `corner + s*ea + t*eb` (s, t in `[0, 1]`) facing
    /// `ea x eb`, cut into quads of at most `cell` metres, as its own chart.
    /// uv0 is the world position projected on the face axes, times `tiling`
    /// (repeats per metre).
    pub fn rect(&mut self, corner: Vec3, ea: Vec3, eb: Vec3, cell: f32, tiling: f32) {
        let (la, lb) = (ea.length(), eb.length());
        let (ua, ub) = (ea / la, eb / lb);
        let n = ea.cross(eb).normalize();
        let na = (la / cell).ceil().max(1.0) as u32;
        let nb = (lb / cell).ceil().max(1.0) as u32;
        let chart = self.chart();
        let first = self.positions.len() as u32;
        for j in 0..=nb {
            for i in 0..=na {
                let (s, t) = (i as f32 / na as f32, j as f32 / nb as f32);
                let p = corner + s * ea + t * eb;
                let uv0 = Vec2::new(p.dot(ua), p.dot(ub)) * tiling;
                self.vertex(chart, p, n, uv0, Vec2::new(s * la, t * lb));
            }
        }
        let row = na + 1;
        for j in 0..nb {
            for i in 0..na {
                let v = first + j * row + i;
                self.quad(v, v + 1, v + 1 + row, v + row);
            }
        }
    }

    /// [`MeshBuilder::rect`] facing `normal` (the edges are swapped when
    /// `ea x eb` points the other way).
    pub fn rect_facing(&mut self, corner: Vec3, ea: Vec3, eb: Vec3, normal: Vec3, cell: f32, tiling: f32) {
        if ea.cross(eb).dot(normal) < 0.0 {
            self.rect(corner, eb, ea, cell, tiling);
        } else {
            self.rect(corner, ea, eb, cell, tiling);
        }
    }

    /// The faces of the box `min..max` selected by `faces` (see [`Faces`]),
    /// each its own chart, cut into quads of at most `cell` metres.
    pub fn cuboid(&mut self, min: Vec3, max: Vec3, faces: Faces, cell: f32, tiling: f32) {
        let e = max - min;
        let (ex, ey, ez) = (Vec3::X * e.x, Vec3::Y * e.y, Vec3::Z * e.z);
        // Each face: corner and two edges whose cross product points outwards.
        let all = [
            (Faces::NEG_X, min, ez, ey),
            (Faces::POS_X, min + ex, ey, ez),
            (Faces::NEG_Y, min, ex, ez),
            (Faces::POS_Y, min + ey, ez, ex),
            (Faces::NEG_Z, min, ey, ex),
            (Faces::POS_Z, min + ez, ex, ey),
        ];
        for (bit, corner, a, b) in all {
            if faces.contains(bit) {
                self.rect(corner, a, b, cell, tiling);
            }
        }
    }

    /// A surface of revolution about the vertical axis through `base`: the
    /// profile is a list of (radius, height) points, bottom to top, with
    /// positive radii. Smooth around the axis; along the profile, corners
    /// sharper than 35 degrees get hard normals. One chart: the strip unrolled with every
    /// ring's chord length (so density stays uniform), centred.
    pub fn lathe(&mut self, base: Vec3, profile: &[Vec2], segments: u32, tiling: f32) {
        debug_assert!(profile.len() >= 2 && profile.iter().all(|p| p.x > 0.0));
        let chart = self.chart();
        let seg_normal = |k: usize| {
            let d = profile[k + 1] - profile[k];
            Vec2::new(d.y, -d.x).normalize() // outward for a bottom-to-top profile
        };
        let chord = 2.0 * (std::f32::consts::PI / segments as f32).sin();
        let circumference = |r: f32| r * chord * segments as f32;
        let widest = profile.iter().map(|p| circumference(p.x)).fold(0.0, f32::max);
        let repeats = (widest * tiling).round().max(1.0);
        let mut length = 0.0;
        for k in 0..profile.len() - 1 {
            let n = seg_normal(k);
            // End normals: averaged with the neighbouring segment when the corner is soft.
            let soft = |m: Vec2| if m.dot(n) > 35f32.to_radians().cos() { (m + n).normalize() } else { n };
            let n0 = if k > 0 { soft(seg_normal(k - 1)) } else { n };
            let n1 = if k + 2 < profile.len() { soft(seg_normal(k + 1)) } else { n };
            let seg_len = (profile[k + 1] - profile[k]).length();
            let first = self.positions.len() as u32;
            for (p, pn, v) in [(profile[k], n0, length), (profile[k + 1], n1, length + seg_len)] {
                let c = circumference(p.x);
                for j in 0..=segments {
                    let f = j as f32 / segments as f32;
                    let a = f * std::f32::consts::TAU;
                    let radial = Vec3::new(a.cos(), 0.0, -a.sin());
                    let pos = base + radial * p.x + Vec3::Y * p.y;
                    let normal = radial * pn.x + Vec3::Y * pn.y;
                    let uv0 = Vec2::new(f * repeats, v * tiling);
                    self.vertex(chart, pos, normal, uv0, Vec2::new(0.5 * (widest - c) + f * c, v));
                }
            }
            let row = segments + 1;
            for j in 0..segments {
                let v = first + j;
                self.quad(v, v + 1, v + 1 + row, v + row);
            }
            length += seg_len;
        }
    }

    /// Packs the charts and returns the mesh (with tangents) and its layout.
    ///
    /// Panics if the charts cannot fit even at zero size (more than
    /// `1 / GUTTER^2` charts): a generator bug, not an input error.
    pub fn finish(self, name: &str) -> (Mesh, ChartLayout) {
        let n = self.charts as usize;
        let mut lo = vec![Vec2::splat(f32::INFINITY); n];
        let mut hi = vec![Vec2::splat(f32::NEG_INFINITY); n];
        for (l, &c) in self.local.iter().zip(&self.chart_of) {
            lo[c as usize] = lo[c as usize].min(*l);
            hi[c as usize] = hi[c as usize].max(*l);
        }
        // Landscape orientation for every chart helps the shelf packer.
        let size: Vec<Vec2> = (0..n).map(|c| (hi[c] - lo[c]).max(Vec2::splat(1e-4))).collect();
        let rotated: Vec<bool> = size.iter().map(|s| s.y > s.x).collect();
        let packed: Vec<Vec2> =
            size.iter().zip(&rotated).map(|(s, &r)| if r { Vec2::new(s.y, s.x) } else { *s }).collect();
        let (scale, origins) = pack(&packed, GUTTER);
        let rects: Vec<UvRect> = (0..n)
            .map(|c| {
                let min = origins[c] + Vec2::splat(0.5 * GUTTER);
                UvRect { min, max: min + packed[c] * scale }
            })
            .collect();
        let uv1 = self
            .local
            .iter()
            .zip(&self.chart_of)
            .map(|(l, &c)| {
                let c = c as usize;
                let q = *l - lo[c];
                // A quarter turn (not a mirror image) for rotated charts.
                let q = if rotated[c] { Vec2::new(q.y, size[c].x - q.x) } else { q };
                (rects[c].min + q * scale).clamp(rects[c].min, rects[c].max)
            })
            .collect();
        let triangle_chart = self.indices.chunks_exact(3).map(|t| self.chart_of[t[0] as usize]).collect();
        let mut mesh = Mesh {
            name: name.to_string(),
            positions: self.positions,
            normals: self.normals,
            tangents: Vec::new(),
            uv0: self.uv0,
            uv1: Some(uv1),
            indices: self.indices,
        };
        mesh.generate_missing_attributes();
        (mesh, ChartLayout { rects, triangle_chart, scale, gutter: GUTTER })
    }
}

/// Finds the largest uniform scale (uv1 per metre) at which the shelf packer
/// fits every chart, each grown by `gutter`, into the unit square, and
/// returns it with each chart's cell origin.
fn pack(sizes: &[Vec2], gutter: f32) -> (f32, Vec<Vec2>) {
    if sizes.is_empty() {
        return (1.0, Vec::new());
    }
    // Tallest first, then widest: the classic shelf order.
    let mut order: Vec<usize> = (0..sizes.len()).collect();
    order.sort_by(|&a, &b| sizes[b].y.total_cmp(&sizes[a].y).then(sizes[b].x.total_cmp(&sizes[a].x)).then(a.cmp(&b)));
    let area: f32 = sizes.iter().map(|s| s.x * s.y).sum();
    let widest = sizes.iter().map(|s| s.x.max(s.y)).fold(0.0, f32::max);
    let mut hi = (1.0 / area.sqrt()).min((1.0 - gutter) / widest);
    let mut lo = 0.0;
    assert!(shelf(sizes, &order, lo, gutter, None), "too many charts ({}) for the gutter", sizes.len());
    if shelf(sizes, &order, hi, gutter, None) {
        lo = hi;
    } else {
        for _ in 0..32 {
            let mid = 0.5 * (lo + hi);
            if shelf(sizes, &order, mid, gutter, None) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
    }
    let mut origins = vec![Vec2::ZERO; sizes.len()];
    let fits = shelf(sizes, &order, lo, gutter, Some(&mut origins));
    debug_assert!(fits);
    (lo, origins)
}

/// Shelf packing at one scale: left to right in rows, a new row when the
/// next cell does not fit. Returns whether everything fits in the unit square.
fn shelf(sizes: &[Vec2], order: &[usize], scale: f32, gutter: f32, mut out: Option<&mut Vec<Vec2>>) -> bool {
    let (mut x, mut y, mut row) = (0.0f32, 0.0f32, 0.0f32);
    for &i in order {
        let cell = sizes[i] * scale + Vec2::splat(gutter);
        if cell.x > 1.0 {
            return false;
        }
        if x + cell.x > 1.0 {
            y += row;
            x = 0.0;
            row = 0.0;
        }
        if y + cell.y > 1.0 {
            return false;
        }
        if let Some(out) = out.as_deref_mut() {
            out[i] = Vec2::new(x, y);
        }
        x += cell.x;
        row = row.max(cell.y);
    }
    true
}

/// A set of box faces for [`MeshBuilder::cuboid`], named by outward normal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Faces(u8);

impl Faces {
    pub const NEG_X: Faces = Faces(1);
    pub const POS_X: Faces = Faces(2);
    pub const NEG_Y: Faces = Faces(4);
    pub const POS_Y: Faces = Faces(8);
    pub const NEG_Z: Faces = Faces(16);
    pub const POS_Z: Faces = Faces(32);
    pub const ALL: Faces = Faces(63);

    /// Whether every face of `o` is in the set.
    pub fn contains(self, o: Faces) -> bool {
        self.0 & o.0 == o.0
    }

    /// These faces without those of `o`.
    pub fn without(self, o: Faces) -> Faces {
        Faces(self.0 & !o.0)
    }
}

impl std::ops::BitOr for Faces {
    type Output = Faces;
    fn bitor(self, o: Faces) -> Faces {
        Faces(self.0 | o.0)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Checks a finished mesh against its layout: charts pairwise at least
    /// the gutter apart and inside the unit square, every triangle inside its
    /// own chart, no chart over-covered (triangles overlapping inside it),
    /// windings agree with normals, normals are unit length. Returns the
    /// spread (max / min) of world area per uv1 area over the triangles.
    pub fn check_mesh(mesh: &Mesh, layout: &ChartLayout) -> f32 {
        let uv1 = mesh.uv1.as_ref().expect("uv1");
        let eps = 1e-5;
        // Pairwise separation with a sweep over x so that big layouts stay cheap.
        let mut order: Vec<usize> = (0..layout.rects.len()).collect();
        order.sort_by(|&a, &b| layout.rects[a].min.x.total_cmp(&layout.rects[b].min.x));
        for (k, &a) in order.iter().enumerate() {
            let ra = layout.rects[a];
            assert!(
                ra.min.cmpge(Vec2::splat(0.5 * layout.gutter - eps)).all(),
                "{}: chart {a} too near the border",
                mesh.name
            );
            assert!(
                ra.max.cmple(Vec2::splat(1.0 - 0.5 * layout.gutter + eps)).all(),
                "{}: chart {a} off the square",
                mesh.name
            );
            for &b in &order[k + 1..] {
                let rb = layout.rects[b];
                if rb.min.x > ra.max.x + layout.gutter {
                    break;
                }
                let sep = ra.separation(&rb);
                assert!(sep >= layout.gutter - eps, "{}: charts {a} and {b} are {sep} apart", mesh.name);
            }
        }
        let mut covered = vec![0.0f64; layout.rects.len()];
        let (mut lo, mut hi) = (f32::INFINITY, 0.0f32);
        for (t, tri) in mesh.indices.chunks_exact(3).enumerate() {
            let c = layout.triangle_chart[t] as usize;
            let [a, b, d] = [0, 1, 2].map(|k| uv1[tri[k] as usize]);
            for p in [a, b, d] {
                assert!(layout.rects[c].contains(p, eps), "{}: triangle {t} leaves chart {c}", mesh.name);
                assert!(p.cmpge(Vec2::ZERO).all() && p.cmple(Vec2::ONE).all());
            }
            let uv_area = 0.5 * (b - a).perp_dot(d - a).abs();
            covered[c] += uv_area as f64;
            let [pa, pb, pc] = [0, 1, 2].map(|k| mesh.positions[tri[k] as usize]);
            let cross = (pb - pa).cross(pc - pa);
            let n: Vec3 = [0, 1, 2].iter().map(|&k| mesh.normals[tri[k] as usize]).sum();
            assert!(cross.dot(n) > 0.0, "{}: triangle {t} is wound against its normals", mesh.name);
            let ratio = 0.5 * cross.length() / uv_area;
            lo = lo.min(ratio);
            hi = hi.max(ratio);
        }
        for (c, area) in covered.iter().enumerate() {
            let rect = layout.rects[c].area() as f64;
            assert!(*area <= rect * 1.001 + 1e-9, "{}: chart {c} covered {area} > {rect}: overlap", mesh.name);
        }
        for n in &mesh.normals {
            assert!((n.length() - 1.0).abs() < 1e-3, "{}: normal {n} not unit", mesh.name);
        }
        hi / lo
    }

    #[test]
    fn packer_keeps_gutters_and_uniform_density() {
        let mut b = MeshBuilder::new();
        b.cuboid(Vec3::ZERO, Vec3::new(3.0, 1.0, 0.5), Faces::ALL, 0.5, 1.0);
        b.rect(Vec3::new(0.0, 2.0, 0.0), Vec3::X * 0.2, Vec3::Z * 7.0, 1.0, 1.0);
        b.lathe(Vec3::new(5.0, 0.0, 0.0), &[Vec2::new(0.5, 0.0), Vec2::new(0.4, 1.0), Vec2::new(0.6, 1.2)], 24, 1.0);
        let (mesh, layout) = b.finish("test");
        assert_eq!(layout.rects.len(), 8);
        assert!(mesh.validate().is_ok());
        let spread = check_mesh(&mesh, &layout);
        assert!(spread < 1.05, "density spread {spread}");
        assert!(layout.utilisation() > 0.3, "utilisation {}", layout.utilisation());
    }

    /// Runs `check_mesh` and returns its panic message (empty if it passed).
    fn failure(mesh: &Mesh, layout: &ChartLayout) -> String {
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| check_mesh(mesh, layout)));
        r.err().map(|e| e.downcast_ref::<String>().cloned().unwrap_or_default()).unwrap_or_default()
    }

    #[test]
    fn checker_catches_charts_inside_the_gutter() {
        let mut b = MeshBuilder::new();
        b.cuboid(Vec3::ZERO, Vec3::ONE, Faces::ALL, 1.0, 1.0);
        let (mut mesh, mut layout) = b.finish("test");
        assert_eq!(failure(&mesh, &layout), "");
        // Move chart 1 (rectangle and triangles) to half a gutter right of chart 0.
        let target = Vec2::new(layout.rects[0].max.x + 0.5 * GUTTER, layout.rects[0].min.y);
        let shift = target - layout.rects[1].min;
        let moved: Vec<u32> =
            layout.triangle_chart.iter().enumerate().filter(|(_, c)| **c == 1).map(|(t, _)| t as u32).collect();
        let mut verts: Vec<u32> =
            moved.iter().flat_map(|&t| mesh.indices[3 * t as usize..3 * t as usize + 3].to_vec()).collect();
        verts.sort();
        verts.dedup();
        for v in verts {
            mesh.uv1.as_mut().unwrap()[v as usize] += shift;
        }
        layout.rects[1].min += shift;
        layout.rects[1].max += shift;
        assert!(failure(&mesh, &layout).contains("apart"));
    }

    #[test]
    fn checker_catches_overlaps_inside_a_chart() {
        let mut b = MeshBuilder::new();
        let c = b.chart();
        // Two quads of one chart laid on the same 2D spot.
        for y in [0.0, 1.0] {
            let v: Vec<u32> = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
                .iter()
                .map(|&(x, z)| b.vertex(c, Vec3::new(x, y, z), Vec3::Y, Vec2::ZERO, Vec2::new(x, z)))
                .collect();
            b.quad(v[0], v[1], v[2], v[3]);
        }
        let (mesh, layout) = b.finish("test");
        assert!(failure(&mesh, &layout).contains("overlap"));
    }
}
