//! CPU light culling: view-frustum planes, light-volume versus box tests, and
//! per-object light lists in a flat (CSR) layout ready for a GPU storage buffer.
//!
//! Every test is conservative: it may keep a box or light that does not
//! matter, never drop one that does, so culling can only cost time, not pixels.

use glam::{Mat4, Vec3, Vec4};

use crate::scene::{Aabb, Light, LightKind};

/// Six planes `(n, d)` with unit `n`; a point `p` is inside when
/// `n·p + d >= 0` for all of them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frustum {
    /// Left, right, bottom, top, then the two depth planes (`z >= 0`, `z <= w`).
    pub planes: [Vec4; 6],
}

impl Frustum {
    /// Planes of a view-projection matrix in wgpu's clip space
    /// (`-w <= x, y <= w`, `0 <= z <= w`), extracted from its rows
    /// (Gribb-Hartmann). The depth planes are `z >= 0` and `z <= w`
    /// whichever end is near, so reversed-Z (near -> 1, far -> 0) works as is.
    /// A degenerate plane (an infinite far plane has `z = near`, constant) is
    /// replaced by one that keeps everything.
    pub fn from_view_projection(m: Mat4) -> Frustum {
        let (r0, r1, r2, r3) = (m.row(0), m.row(1), m.row(2), m.row(3));
        let raw = [r3 + r0, r3 - r0, r3 + r1, r3 - r1, r2, r3 - r2];
        Frustum {
            planes: raw.map(|p| {
                let len = p.truncate().length();
                if len > 1e-12 && len.is_finite() { p / len } else { Vec4::new(0.0, 0.0, 0.0, 1.0) }
            }),
        }
    }

    /// Whether `b` may be visible: false only when the whole box is outside
    /// one plane (tested with the box corner farthest along the plane normal).
    /// Boxes near the frustum's edges but outside it may still pass. An empty
    /// box is never visible.
    pub fn intersects_aabb(&self, b: &Aabb) -> bool {
        if b.is_empty() {
            return false;
        }
        self.planes.iter().all(|p| {
            let n = p.truncate();
            let corner = Vec3::select(n.cmpge(Vec3::ZERO), b.max, b.min);
            n.dot(corner) + p.w >= 0.0
        })
    }

    /// Whether a sphere may be visible (not wholly outside one plane).
    pub fn intersects_sphere(&self, center: Vec3, radius: f32) -> bool {
        self.planes.iter().all(|p| p.truncate().dot(center) + p.w >= -radius)
    }
}

/// Squared distance from `p` to the box (0 inside).
fn distance_squared_to_aabb(p: Vec3, b: &Aabb) -> f32 {
    let q = p.clamp(b.min, b.max);
    p.distance_squared(q)
}

/// Whether a sphere touches the box (exact; touching counts). Empty boxes never.
pub fn sphere_intersects_aabb(center: Vec3, radius: f32, b: &Aabb) -> bool {
    !b.is_empty() && distance_squared_to_aabb(center, b) <= radius * radius
}

/// Whether a spot light's volume (the cone of half-angle `acos(cos_outer)`
/// from `apex` along `direction`, cut at distance `radius`) may touch the box.
///
/// Conservative: the exact sphere-box test, then the box's bounding sphere
/// against the infinite cone: the sphere is rejected when its centre lies
/// wholly behind the apex, beyond the range, or farther than its radius from
/// the cone's surface line (Wronski's cone-sphere test; that distance is never
/// more than the true distance to the cone, so nothing touched is rejected).
/// Cones wider than a half-space (`cos_outer <= 0`) and a zero direction use the sphere test only.
pub fn cone_intersects_aabb(apex: Vec3, direction: Vec3, radius: f32, cos_outer: f32, b: &Aabb) -> bool {
    if !sphere_intersects_aabb(apex, radius, b) {
        return false;
    }
    let cos = cos_outer.min(1.0);
    let dir = if cos > 0.0 { direction.normalize_or_zero() } else { Vec3::ZERO };
    let cone = Cone { apex, dir, cos, sin: (1.0 - cos * cos).max(0.0).sqrt(), range: radius };
    !cone_rejects_sphere(&cone, b.center(), 0.5 * b.extent().length())
}

/// Whether the sphere (`center`, `r`) lies wholly outside the cone: behind
/// the apex, beyond the range, or farther than `r` from the cone's surface
/// line. Never rejects for a zero axis.
fn cone_rejects_sphere(cone: &Cone, center: Vec3, r: f32) -> bool {
    if cone.dir == Vec3::ZERO {
        return false;
    }
    let v = center - cone.apex;
    let along = v.dot(cone.dir);
    let across = (v.length_squared() - along * along).max(0.0).sqrt();
    let distance_to_surface = cone.cos * across - along * cone.sin;
    distance_to_surface > r || along > cone.range + r || along < -r
}

/// Whether `light` may light anything in the box. Ambient, directional and
/// environment lights light everything; point lights are spheres of their radius; spot
/// lights are their outer cone cut at the radius.
pub fn light_affects_aabb(light: &Light, b: &Aabb) -> bool {
    match light.kind {
        LightKind::Ambient | LightKind::Directional | LightKind::Environment => true,
        LightKind::Point => sphere_intersects_aabb(light.position, light.radius, b),
        LightKind::Spot => cone_intersects_aabb(light.position, light.direction, light.radius, light.cos_outer, b),
    }
}

/// Light lists of all objects in one flat layout: object `i`'s lights are
/// `indices[offsets[i] .. offsets[i] + counts[i]]`, indices into the light
/// array, ascending. `offsets` and `counts` have one entry per object; objects
/// are packed back to back, so `offsets[i+1] = offsets[i] + counts[i]`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LightLists {
    /// Start of each object's list in `indices`.
    pub offsets: Vec<u32>,
    /// Length of each object's list.
    pub counts: Vec<u32>,
    /// All lists back to back: indices into the light array.
    pub indices: Vec<u32>,
}

impl LightLists {
    /// No lights for any of `objects` objects (for pipelines that cull on the GPU).
    pub fn empty(objects: usize) -> Self {
        Self { offsets: vec![0; objects], counts: vec![0; objects], indices: Vec::new() }
    }

    /// The light indices of object `object`.
    pub fn lights_of(&self, object: usize) -> &[u32] {
        let start = self.offsets[object] as usize;
        &self.indices[start..start + self.counts[object] as usize]
    }
}

/// The lights that may reach any visible object, as flat arrays (one entry
/// per light, in light order) so that the sphere-box loop vectorises.
#[derive(Default)]
struct Candidates {
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
    /// Squared radius; infinite for ambient and directional lights, so that
    /// they pass every test and keep their place in light order.
    r2: Vec<f32>,
    /// Index into `cones` for spot lights (they need the cone test after the
    /// sphere test), `u32::MAX` for the others.
    cone: Vec<u32>,
    cones: Vec<Cone>,
    index: Vec<u32>,
}

/// A spot light's cone, prepared once per call for [`cone_rejects_sphere`].
struct Cone {
    apex: Vec3,
    /// Unit axis; zero when the light's direction is zero or the cone is
    /// wider than a half-space (then only the sphere test applies).
    dir: Vec3,
    cos: f32,
    sin: f32,
    range: f32,
}

impl Candidates {
    fn push(&mut self, index: usize, center: Vec3, r2: f32, cone: Option<Cone>) {
        self.x.push(center.x);
        self.y.push(center.y);
        self.z.push(center.z);
        self.r2.push(r2);
        self.cone.push(match cone {
            Some(c) => {
                self.cones.push(c);
                (self.cones.len() - 1) as u32
            }
            None => u32::MAX,
        });
        self.index.push(index as u32);
    }
}

/// The lights that may affect each object ([`light_affects_aabb`]), ambient
/// and directional lights included in every list, each list in light order.
/// With a frustum, objects outside it get empty lists (count 0).
///
/// Cost: a pre-pass drops the point and spot lights that reach no visible
/// object (sphere against the union of the visible boxes); then, per visible
/// object, one branch-free sphere-box test per remaining light over flat
/// arrays (vectorised by the compiler), and the cone test only for spots that
/// pass it. Measured with a release build on a shared, loaded 2-core AMD EPYC
/// (CPU time per call, 10,002 lights x 50 objects in a Sponza-sized box):
/// `small:10000` 0.5 ms, `mixed:1000:9` 0.75 ms, `big:10000` 2 ms (150,000
/// list entries: bound by the output).
pub fn lights_per_object(lights: &[Light], object_bounds: &[Aabb], frustum: Option<&Frustum>) -> LightLists {
    let visible: Vec<bool> =
        object_bounds.iter().map(|b| !b.is_empty() && frustum.is_none_or(|f| f.intersects_aabb(b))).collect();
    let union = object_bounds.iter().zip(&visible).filter(|(_, v)| **v).fold(Aabb::EMPTY, |u, (b, _)| u.union(b));

    let mut cand = Candidates::default();
    for (i, l) in lights.iter().enumerate() {
        match l.kind {
            LightKind::Ambient | LightKind::Directional | LightKind::Environment => {
                cand.push(i, Vec3::ZERO, f32::INFINITY, None)
            }
            LightKind::Point | LightKind::Spot => {
                if sphere_intersects_aabb(l.position, l.radius, &union) {
                    let cone = (l.kind == LightKind::Spot).then(|| {
                        let cos = l.cos_outer.min(1.0);
                        let dir = if cos > 0.0 { l.direction.normalize_or_zero() } else { Vec3::ZERO };
                        Cone { apex: l.position, dir, cos, sin: (1.0 - cos * cos).max(0.0).sqrt(), range: l.radius }
                    });
                    cand.push(i, l.position, l.radius * l.radius, cone);
                }
            }
        }
    }

    let mut lists = LightLists {
        offsets: Vec::with_capacity(object_bounds.len()),
        counts: Vec::with_capacity(object_bounds.len()),
        indices: Vec::new(),
    };
    // Padded to whole 8-byte words so that the scan below reads words only.
    let mut hit = vec![0u8; cand.index.len().div_ceil(8) * 8];
    for (b, &vis) in object_bounds.iter().zip(&visible) {
        let start = lists.indices.len();
        lists.offsets.push(start as u32);
        if vis {
            sphere_hits(&cand, b, &mut hit);
            let (center, r_box) = (b.center(), 0.5 * b.extent().length());
            // Scan 8 flags (0 or 1) at a time: most words are zero for small lights.
            for (w, word) in hit.chunks_exact(8).enumerate() {
                let mut bits = u64::from_le_bytes(word.try_into().expect("8 bytes"));
                while bits != 0 {
                    let c = w * 8 + (bits.trailing_zeros() / 8) as usize;
                    bits &= bits - 1;
                    let cone = cand.cone[c];
                    if cone == u32::MAX || !cone_rejects_sphere(&cand.cones[cone as usize], center, r_box) {
                        lists.indices.push(cand.index[c]);
                    }
                }
            }
        }
        lists.counts.push((lists.indices.len() - start) as u32);
    }
    lists
}

/// `hit[i] = 1` where candidate i's sphere touches the box `b`, else 0
/// (entries past the candidates stay 0).
fn sphere_hits(c: &Candidates, b: &Aabb, hit: &mut [u8]) {
    // `if a > b` rather than `f32::max`, whose NaN rule keeps LLVM from using
    // plain vector max instructions; no value here is NaN.
    fn max(a: f32, b: f32) -> f32 {
        if a > b { a } else { b }
    }
    let n = c.index.len();
    let (xs, ys, zs, r2s, hit) = (&c.x[..n], &c.y[..n], &c.z[..n], &c.r2[..n], &mut hit[..n]);
    for i in 0..n {
        // Distance along each axis from the centre to the box, 0 inside.
        let dx = max(max(b.min.x - xs[i], xs[i] - b.max.x), 0.0);
        let dy = max(max(b.min.y - ys[i], ys[i] - b.max.y), 0.0);
        let dz = max(max(b.min.z - zs[i], zs[i] - b.max.z), 0.0);
        hit[i] = (dx * dx + dy * dy + dz * dz <= r2s[i]) as u8;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Camera;

    fn camera() -> Camera {
        // At the origin looking down -z, 90 degrees vertical fov, near 0.5, far 100.
        Camera {
            position: Vec3::ZERO,
            forward: Vec3::NEG_Z,
            up: Vec3::Y,
            fov_y: 90f32.to_radians(),
            near: 0.5,
            far: 100.0,
        }
    }

    fn frustum() -> Frustum {
        Frustum::from_view_projection(camera().view_projection(1.0))
    }

    fn cube(center: Vec3, half: f32) -> Aabb {
        Aabb { min: center - Vec3::splat(half), max: center + Vec3::splat(half) }
    }

    fn point(position: Vec3, radius: f32) -> Light {
        Light::point(position, radius)
    }

    #[test]
    fn reversed_z_planes_are_what_we_expect() {
        let m = camera().view_projection(1.0);
        // Reversed-Z: near maps to 1, far to 0.
        let near = m.project_point3(Vec3::new(0.0, 0.0, -0.5));
        let far = m.project_point3(Vec3::new(0.0, 0.0, -100.0));
        assert!((near.z - 1.0).abs() < 1e-5 && far.z.abs() < 1e-5);
        let f = frustum();
        for p in f.planes {
            assert!((p.truncate().length() - 1.0).abs() < 1e-5);
        }
        // z >= 0 is the far plane here (z + 100 >= 0 in view space), z <= w the near plane (-z - 0.5 >= 0).
        let (far_plane, near_plane) = (f.planes[4], f.planes[5]);
        assert!((far_plane - Vec4::new(0.0, 0.0, 1.0, 100.0)).abs().max_element() < 1e-3, "{far_plane}");
        assert!((near_plane - Vec4::new(0.0, 0.0, -1.0, -0.5)).abs().max_element() < 1e-4, "{near_plane}");
        // Side planes of a 90-degree frustum pass through the eye at 45 degrees.
        let h = std::f32::consts::FRAC_1_SQRT_2;
        assert!((f.planes[0] - Vec4::new(h, 0.0, -h, 0.0)).abs().max_element() < 1e-5, "{}", f.planes[0]);
    }

    #[test]
    fn boxes_inside_outside_and_straddling_each_plane() {
        let f = frustum();
        // Inside, well within.
        assert!(f.intersects_aabb(&cube(Vec3::new(0.0, 0.0, -10.0), 1.0)));
        // Containing the whole frustum.
        assert!(f.intersects_aabb(&cube(Vec3::ZERO, 1000.0)));
        // At depth 10 the side planes are at |x| = 10, |y| = 10.
        let cases = [
            (Vec3::new(-13.0, 0.0, -10.0), Vec3::new(-10.5, 0.0, -10.0)), // left
            (Vec3::new(13.0, 0.0, -10.0), Vec3::new(10.5, 0.0, -10.0)),   // right
            (Vec3::new(0.0, -13.0, -10.0), Vec3::new(0.0, -10.5, -10.0)), // bottom
            (Vec3::new(0.0, 13.0, -10.0), Vec3::new(0.0, 10.5, -10.0)),   // top
            (Vec3::new(0.0, 0.0, -102.0), Vec3::new(0.0, 0.0, -100.5)),   // far
            (Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.0, 0.0, -0.2)),        // near (and behind)
        ];
        for (outside, straddling) in cases {
            assert!(!f.intersects_aabb(&cube(outside, 1.0)), "outside {outside}");
            assert!(f.intersects_aabb(&cube(straddling, 1.0)), "straddling {straddling}");
        }
        // Between near plane and eye, wholly: outside the near plane.
        assert!(!f.intersects_aabb(&Aabb { min: Vec3::new(-0.1, -0.1, -0.4), max: Vec3::new(0.1, 0.1, -0.1) }));
        assert!(!f.intersects_aabb(&Aabb::EMPTY));
        assert!(f.intersects_sphere(Vec3::new(0.0, 0.0, -101.0), 1.5));
        assert!(!f.intersects_sphere(Vec3::new(0.0, 0.0, -102.0), 1.5));
    }

    #[test]
    fn conservative_against_sampled_points() {
        // Any box holding a point that projects inside clip space must pass.
        let m = camera().view_projection(16.0 / 9.0);
        let f = Frustum::from_view_projection(m);
        let mut state = 12345u32;
        let mut rnd = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state as f32 / u32::MAX as f32
        };
        for _ in 0..2000 {
            let c = Vec3::new(rnd() * 60.0 - 30.0, rnd() * 60.0 - 30.0, rnd() * -120.0 + 5.0);
            let b = cube(c, 0.1 + 3.0 * rnd());
            let any_inside = (0..64).any(|k| {
                let t = Vec3::new((k & 3) as f32 / 3.0, ((k >> 2) & 3) as f32 / 3.0, (k >> 4) as f32 / 3.0);
                let clip = m * (b.min + t * b.extent()).extend(1.0);
                clip.w > 0.0 && clip.x.abs() <= clip.w && clip.y.abs() <= clip.w && (0.0..=clip.w).contains(&clip.z)
            });
            if any_inside {
                assert!(f.intersects_aabb(&b), "{b:?}");
            }
        }
    }

    #[test]
    fn infinite_reversed_z_far_plane_keeps_everything_far() {
        let m = Mat4::perspective_infinite_reverse_rh(1.0, 1.0, 0.1) * camera().view();
        let f = Frustum::from_view_projection(m);
        assert!(f.intersects_aabb(&cube(Vec3::new(0.0, 0.0, -1e6), 1.0)));
        assert!(!f.intersects_aabb(&cube(Vec3::new(0.0, 0.0, 5.0), 1.0)));
    }

    #[test]
    fn sphere_touching_a_box_corner() {
        let b = Aabb { min: Vec3::ZERO, max: Vec3::ONE };
        let dir = Vec3::ONE.normalize();
        let center = Vec3::ONE + 2.0 * dir; // distance 2 from the corner (1,1,1)
        assert!(sphere_intersects_aabb(center, 2.001, &b));
        assert!(!sphere_intersects_aabb(center, 1.999, &b));
        // Distance to the box is the corner's, not the centre's or a face's.
        assert!(!sphere_intersects_aabb(Vec3::new(2.0, 2.0, 2.0), 1.5, &b)); // corner at sqrt(3) = 1.73
        assert!(sphere_intersects_aabb(Vec3::splat(0.5), 0.01, &b), "centre inside");
        assert!(!sphere_intersects_aabb(Vec3::ZERO, 10.0, &Aabb::EMPTY));
        assert!(light_affects_aabb(&point(center, 2.001), &b));
        assert!(!light_affects_aabb(&point(center, 1.999), &b));
    }

    #[test]
    fn cone_pointing_away_from_a_box() {
        let b = cube(Vec3::new(0.0, -5.0, 0.0), 1.0); // below the apex
        let apex = Vec3::ZERO;
        let cos30 = 30f32.to_radians().cos();
        assert!(cone_intersects_aabb(apex, Vec3::NEG_Y, 10.0, cos30, &b), "pointing at it");
        assert!(!cone_intersects_aabb(apex, Vec3::Y, 10.0, cos30, &b), "pointing away");
        assert!(!cone_intersects_aabb(apex, Vec3::X, 10.0, cos30, &b), "pointing sideways");
        assert!(!cone_intersects_aabb(apex, Vec3::NEG_Y, 3.0, cos30, &b), "out of range");
        // A wide cone (60 degrees) pointing sideways grazes it; a half-space cone always does.
        assert!(cone_intersects_aabb(apex, Vec3::new(1.0, -1.0, 0.0), 10.0, 60f32.to_radians().cos(), &b));
        assert!(cone_intersects_aabb(apex, Vec3::Y, 10.0, -0.1, &b));
        // Apex inside the box: always.
        assert!(cone_intersects_aabb(Vec3::new(0.0, -5.0, 0.0), Vec3::Y, 1.0, 0.99, &b));
        let mut spot = point(apex, 10.0);
        spot.kind = LightKind::Spot;
        spot.direction = Vec3::Y;
        spot.cos_outer = cos30;
        assert!(!light_affects_aabb(&spot, &b));
        spot.direction = Vec3::NEG_Y;
        assert!(light_affects_aabb(&spot, &b));
    }

    #[test]
    fn cone_is_conservative_against_sampled_points() {
        let mut state = 99u32;
        let mut rnd = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state as f32 / u32::MAX as f32
        };
        for _ in 0..500 {
            let dir = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5).normalize();
            let cos_outer = (10.0 + 70.0 * rnd()).to_radians().cos();
            let b = cube(Vec3::new(rnd() * 10.0 - 5.0, rnd() * 10.0 - 5.0, rnd() * 10.0 - 5.0), 0.2 + rnd());
            let radius = 2.0 + 6.0 * rnd();
            let touched = (0..343).any(|k| {
                let t = Vec3::new((k % 7) as f32, ((k / 7) % 7) as f32, (k / 49) as f32) / 6.0;
                let p = b.min + t * b.extent();
                p.length() <= radius && p.normalize_or_zero().dot(dir) >= cos_outer
            });
            if touched {
                assert!(cone_intersects_aabb(Vec3::ZERO, dir, radius, cos_outer, &b), "{b:?} {dir} {cos_outer}");
            }
        }
    }

    #[test]
    fn light_lists_layout() {
        let ambient = Light { kind: LightKind::Ambient, ..point(Vec3::ZERO, 1.0) };
        let sun = Light { kind: LightKind::Directional, ..point(Vec3::ZERO, 1.0) };
        let lights = [
            point(Vec3::new(0.0, 0.0, -10.0), 1.5), // 0: touches object 0
            ambient,                                // 1: everyone
            point(Vec3::new(5.0, 0.0, -10.0), 1.5), // 2: touches object 1
            point(Vec3::new(2.5, 0.0, -10.0), 2.0), // 3: touches objects 0 and 1
            sun,                                    // 4: everyone
            point(Vec3::new(0.0, 50.0, 0.0), 1.0),  // 5: nothing
            point(Vec3::new(0.0, 0.0, 30.0), 5.0),  // 6: only the object behind the camera
        ];
        let objects = [
            cube(Vec3::new(0.0, 0.0, -10.0), 1.0),
            cube(Vec3::new(5.0, 0.0, -10.0), 1.0),
            cube(Vec3::new(0.0, 0.0, 30.0), 1.0), // behind the camera
            Aabb::EMPTY,
        ];
        let all = lights_per_object(&lights, &objects, None);
        assert_eq!(all.offsets, [0, 4, 8, 11]);
        assert_eq!(all.counts, [4, 4, 3, 0]);
        assert_eq!(all.indices, [0, 1, 3, 4, 1, 2, 3, 4, 1, 4, 6]);
        assert_eq!(all.lights_of(1), [1, 2, 3, 4]);

        let culled = lights_per_object(&lights, &objects, Some(&frustum()));
        assert_eq!(culled.offsets, [0, 4, 8, 8]);
        assert_eq!(culled.counts, [4, 4, 0, 0]);
        assert_eq!(culled.lights_of(2), [] as [u32; 0]);
        assert_eq!(culled.indices.len(), 8);

        let none = lights_per_object(&[], &objects, None);
        assert_eq!((none.offsets, none.counts, none.indices), (vec![0; 4], vec![0; 4], vec![]));
        assert_eq!(lights_per_object(&lights, &[], None), LightLists::default());
    }

    #[test]
    fn lists_match_brute_force() {
        let mut state = 7u32;
        let mut rnd = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state as f32 / u32::MAX as f32
        };
        let lights: Vec<Light> = (0..300)
            .map(|i| {
                let mut l = point(Vec3::new(rnd() * 40.0 - 20.0, rnd() * 10.0, rnd() * -40.0), 0.5 + 4.0 * rnd());
                if i % 4 == 1 {
                    l.kind = LightKind::Spot;
                    l.direction = Vec3::new(rnd() - 0.5, -1.0, rnd() - 0.5).normalize();
                    l.cos_outer = 0.8;
                }
                l
            })
            .collect();
        let objects: Vec<Aabb> =
            (0..40).map(|_| cube(Vec3::new(rnd() * 40.0 - 20.0, rnd() * 10.0, rnd() * -40.0), 0.5 + rnd())).collect();
        let f = frustum();
        let lists = lights_per_object(&lights, &objects, Some(&f));
        for (o, b) in objects.iter().enumerate() {
            let expect: Vec<u32> = if f.intersects_aabb(b) {
                (0..lights.len() as u32).filter(|&i| light_affects_aabb(&lights[i as usize], b)).collect()
            } else {
                vec![]
            };
            assert_eq!(lists.lights_of(o), expect, "object {o}");
        }
    }
}
