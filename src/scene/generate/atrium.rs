//! The `atrium`: a Sponza-like courtyard, 30 x 13 x 15 m (x, y, z), centred
//! on the origin in x and z.
//!
//! A 20 x 6 m court (pillar lines at |x| = 10, |z| = 3) is ringed by two
//! storeys of round pillars carrying semicircular arcades: 8 bays of 2.5 m on
//! the long sides, 3 bays of 2 m on the short ones. Aisles 4 m wide run between
//! the arcades and the outer walls, under the gallery floor (5.6-6.0 m) and
//! the roof rim (11.0-11.4 m); the walls rise to 13 m. Six cloth banners hang
//! into the court. No randomness: every wave is a fixed sine.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

use super::builder::{Faces, MeshBuilder};
use super::{Assembler, Generated};

/// Half extents of the outside of the walls and the wall thickness.
const HALF_X: f32 = 15.0;
const HALF_Z: f32 = 7.5;
const WALL: f32 = 0.5;
const WALL_HEIGHT: f32 = 13.0;
/// The inside of the walls.
const IN_X: f32 = HALF_X - WALL;
const IN_Z: f32 = HALF_Z - WALL;
/// Pillar lines of the court.
const COURT_X: f32 = 10.0;
const COURT_Z: f32 = 3.0;
const LONG_BAYS: usize = 8;
const SHORT_BAYS: usize = 3;
/// Checker repeats per metre (uv0).
const TILING: f32 = 1.0;
/// Largest quad edge on flat surfaces: keeps big faces tessellated enough for
/// per-vertex work (culling tests, fog) without adding much.
const CELL: f32 = 1.0;
/// Segments around a pillar: smooth normals make 32 read as round (the
/// silhouette is off by 0.5% of the radius).
const PILLAR_SEGMENTS: u32 = 32;
/// Segments of a semicircular arch.
const ARCH_SEGMENTS: u32 = 24;

/// Linear tints of the banners, in the order they are listed.
const CLOTH: [Vec3; 6] = [
    Vec3::new(0.6, 0.06, 0.05),
    Vec3::new(0.06, 0.35, 0.1),
    Vec3::new(0.08, 0.14, 0.5),
    Vec3::new(0.6, 0.06, 0.05),
    Vec3::new(0.65, 0.45, 0.08),
    Vec3::new(0.65, 0.45, 0.08),
];

/// One storey of the arcade.
struct Storey {
    name: &'static str,
    /// Floor the pillars stand on.
    floor: f32,
    /// Where the arches spring (top of the abacus).
    spring: f32,
    /// Top of the arcade wall (underside of the slab above).
    top: f32,
    /// Shaft radius at the foot.
    radius: f32,
    /// Plinth height; the plinth is a square 2.8 radii wide.
    plinth: f32,
    /// Abacus height; the abacus is a square 2.9 radii wide.
    abacus: f32,
    /// Thickness of the arcade wall (also its width over a pillar).
    thickness: f32,
}

const STOREYS: [Storey; 2] = [
    Storey {
        name: "ground",
        floor: 0.0,
        spring: 4.0,
        top: 5.6,
        radius: 0.3,
        plinth: 0.2,
        abacus: 0.15,
        thickness: 0.6,
    },
    Storey {
        name: "upper",
        floor: 6.0,
        spring: 9.0,
        top: 11.0,
        radius: 0.24,
        plinth: 0.15,
        abacus: 0.12,
        thickness: 0.5,
    },
];

/// The slab over each storey: (bottom, top, half size of the court hole).
const SLABS: [(&str, f32, f32, Vec2); 2] =
    [("gallery_floor", 5.6, 6.0, Vec2::new(9.6, 2.6)), ("roof_rim", 11.0, 11.4, Vec2::new(9.4, 2.4))];

/// One side of the court: the pillar line and how to walk along it.
struct Side {
    name: &'static str,
    /// A point of the pillar line at s = 0 (y ignored).
    origin: Vec3,
    /// Unit direction along the side.
    along: Vec3,
    /// Pillar positions along the side, s.
    stations: Vec<f32>,
    /// Whether the ends stick out by half the wall thickness (the long sides
    /// close the corners; the short sides butt into them).
    closes_corners: bool,
}

fn sides() -> [Side; 4] {
    let long: Vec<f32> = (0..=LONG_BAYS).map(|i| -COURT_X + i as f32 * 2.0 * COURT_X / LONG_BAYS as f32).collect();
    let short: Vec<f32> = (0..=SHORT_BAYS).map(|i| -COURT_Z + i as f32 * 2.0 * COURT_Z / SHORT_BAYS as f32).collect();
    let side = |name, origin, along, stations: &Vec<f32>, closes_corners| Side {
        name,
        origin,
        along,
        stations: stations.clone(),
        closes_corners,
    };
    [
        side("south", Vec3::new(0.0, 0.0, -COURT_Z), Vec3::X, &long, true),
        side("north", Vec3::new(0.0, 0.0, COURT_Z), Vec3::X, &long, true),
        side("west", Vec3::new(-COURT_X, 0.0, 0.0), Vec3::Z, &short, false),
        side("east", Vec3::new(COURT_X, 0.0, 0.0), Vec3::Z, &short, false),
    ]
}

pub(super) fn build() -> Generated {
    let mut a = Assembler::new("atrium");
    // Linear tints of the kinds of surface (checker textures shared per kind).
    let stone = a.look("stone", Vec3::new(0.62, 0.5, 0.36), 4, 0.2, 8.0);
    let tiles = a.look("tiles", Vec3::new(0.5, 0.46, 0.42), 4, 0.3, 24.0);
    let marble = a.look("marble", Vec3::new(0.8, 0.78, 0.72), 4, 0.5, 64.0);
    let plaster = a.look("plaster", Vec3::new(0.72, 0.62, 0.48), 4, 0.25, 12.0);

    // The floor in 4 x 2 charts: one 2:1 chart would fill half the square.
    let mut floor = MeshBuilder::new();
    let piece = Vec2::new(2.0 * IN_X / 4.0, 2.0 * IN_Z / 2.0);
    for i in 0..4 {
        for j in 0..2 {
            let corner = Vec3::new(-IN_X + i as f32 * piece.x, 0.0, -IN_Z + j as f32 * piece.y);
            floor.rect_facing(corner, Vec3::X * piece.x, Vec3::Z * piece.y, Vec3::Y, CELL, TILING);
        }
    }
    a.add("floor", floor, tiles);
    a.add("walls", walls(), stone);
    for (name, bottom, top, hole) in SLABS {
        a.add(name, slab_ring(bottom, top, hole), plaster);
    }

    for storey in &STOREYS {
        for side in &sides() {
            // Corner pillars belong to the long sides.
            let inner =
                if side.closes_corners { &side.stations[..] } else { &side.stations[1..side.stations.len() - 1] };
            let mut pillars = MeshBuilder::new();
            for &s in inner {
                pillar(&mut pillars, side.origin + side.along * s, storey);
            }
            a.add(&format!("pillars_{}_{}", storey.name, side.name), pillars, marble);
            a.add(&format!("arcade_{}_{}", storey.name, side.name), arcade(side, storey), plaster);
        }
    }

    // (name, top centre, width direction, facing, width, length, pointed tip)
    let banners = [
        ("banner_south_west", Vec3::new(-5.0, 10.95, -2.5), Vec3::X, Vec3::Z, 1.4, 4.2, 0.3),
        ("banner_south_east", Vec3::new(5.0, 10.95, -2.5), Vec3::X, Vec3::Z, 1.4, 4.2, 0.3),
        ("banner_north_west", Vec3::new(-5.0, 10.95, 2.5), Vec3::X, Vec3::NEG_Z, 1.4, 4.2, 0.3),
        ("banner_north_east", Vec3::new(5.0, 10.95, 2.5), Vec3::X, Vec3::NEG_Z, 1.4, 4.2, 0.3),
        ("banner_west", Vec3::new(-9.65, 5.55, 0.0), Vec3::Z, Vec3::X, 1.0, 3.6, 0.25),
        ("banner_east", Vec3::new(9.65, 5.55, 0.0), Vec3::Z, Vec3::NEG_X, 1.0, 3.6, 0.25),
    ];
    for (k, (name, top, across, out, width, length, tip)) in banners.into_iter().enumerate() {
        let cloth = a.look(name, CLOTH[k % CLOTH.len()], 4, 0.2, 8.0);
        let mut b = MeshBuilder::new();
        banner(&mut b, top, across, out, Vec3::new(width, length, tip), k as f32 * 1.7);
        a.add(name, b, cloth);
    }
    a.finish()
}

/// The four outer walls with their tops, outsides and exposed ends.
fn walls() -> MeshBuilder {
    let mut b = MeshBuilder::new();
    let h = WALL_HEIGHT;
    for sz in [-1.0f32, 1.0] {
        // Long walls run the full length; the inner face stops at the end walls.
        let (z0, z1) = if sz < 0.0 { (-HALF_Z, -IN_Z) } else { (IN_Z, HALF_Z) };
        let outer = if sz < 0.0 { Faces::NEG_Z } else { Faces::POS_Z };
        b.cuboid(
            Vec3::new(-HALF_X, 0.0, z0),
            Vec3::new(HALF_X, h, z1),
            outer | Faces::POS_Y | Faces::NEG_X | Faces::POS_X,
            CELL,
            TILING,
        );
        let z = sz * IN_Z;
        b.rect_facing(Vec3::new(-IN_X, 0.0, z), Vec3::X * 2.0 * IN_X, Vec3::Y * h, Vec3::Z * -sz, CELL, TILING);
    }
    for sx in [-1.0f32, 1.0] {
        let (x0, x1) = if sx < 0.0 { (-HALF_X, -IN_X) } else { (IN_X, HALF_X) };
        let faces = Faces::NEG_X | Faces::POS_X | Faces::POS_Y;
        b.cuboid(Vec3::new(x0, 0.0, -IN_Z), Vec3::new(x1, h, IN_Z), faces, CELL, TILING);
    }
    b
}

/// A slab between the walls with a rectangular hole over the court: four
/// strips (top, underside, and the face towards the court).
fn slab_ring(bottom: f32, top: f32, hole: Vec2) -> MeshBuilder {
    let mut b = MeshBuilder::new();
    let (tb, h) = (Faces::NEG_Y | Faces::POS_Y, top - bottom);
    for s in [-1.0f32, 1.0] {
        let (z0, z1) = if s < 0.0 { (-IN_Z, -hole.y) } else { (hole.y, IN_Z) };
        b.cuboid(Vec3::new(-IN_X, bottom, z0), Vec3::new(IN_X, top, z1), tb, CELL, TILING);
        let court = Vec3::new(-hole.x, bottom, s * hole.y);
        b.rect_facing(court, Vec3::X * 2.0 * hole.x, Vec3::Y * h, Vec3::Z * -s, CELL, TILING);
        let (x0, x1) = if s < 0.0 { (-IN_X, -hole.x) } else { (hole.x, IN_X) };
        b.cuboid(Vec3::new(x0, bottom, -hole.y), Vec3::new(x1, top, hole.y), tb, CELL, TILING);
        let court = Vec3::new(s * hole.x, bottom, -hole.y);
        b.rect_facing(court, Vec3::Z * 2.0 * hole.y, Vec3::Y * h, Vec3::X * -s, CELL, TILING);
    }
    b
}

/// A pillar standing at `at` (x, z): square plinth, turned shaft with a torus
/// at the foot, a slight entasis and a flared capital, square abacus on top.
fn pillar(b: &mut MeshBuilder, at: Vec3, st: &Storey) {
    let r = st.radius;
    let foot = Vec3::new(at.x, st.floor, at.z);
    let half = Vec3::new(1.4 * r, 0.0, 1.4 * r);
    b.cuboid(foot - half, foot + half + Vec3::Y * st.plinth, Faces::ALL.without(Faces::NEG_Y), CELL, TILING);
    let cap = Vec3::new(1.45 * r, 0.0, 1.45 * r);
    let spring = Vec3::new(at.x, st.spring, at.z);
    b.cuboid(spring - cap - Vec3::Y * st.abacus, spring + cap, Faces::ALL.without(Faces::NEG_Y), CELL, TILING);

    let height = st.spring - st.abacus - st.floor - st.plinth;
    let mut profile = Vec::new();
    // Torus at the foot: a half circle of radius 0.25 r, bottom to top.
    let (tr, tc) = (0.25 * r, 1.1 * r);
    for k in 0..=6 {
        let a = -0.5 * PI + PI * k as f32 / 6.0;
        profile.push(Vec2::new(tc + tr * a.cos(), tr + tr * a.sin()));
    }
    // Shaft with entasis: a slight swell, then a taper to 0.88 r.
    let (shaft0, shaft1) = (2.0 * tr, height - 0.3 * r * 2.0);
    let shaft_r = |t: f32| r * (1.0 + 0.03 * (PI * t).sin() - 0.12 * t);
    for k in 0..=10 {
        let t = k as f32 / 10.0;
        profile.push(Vec2::new(shaft_r(t), shaft0 + t * (shaft1 - shaft0)));
    }
    // Echinus: flares from the shaft to 1.35 r.
    let r_top = shaft_r(1.0);
    for k in 1..=5 {
        let s = k as f32 / 5.0;
        profile.push(Vec2::new(r_top + (1.35 * r - r_top) * s * s, shaft1 + s * (height - shaft1)));
    }
    b.lathe(foot + Vec3::Y * st.plinth, &profile, PILLAR_SEGMENTS, TILING);
}

/// The arcade wall of one side and storey: one panel per bay, each a
/// rectangle with a semicircular opening, extruded by the storey's thickness.
fn arcade(side: &Side, st: &Storey) -> MeshBuilder {
    let mut b = MeshBuilder::new();
    let across = Vec3::Y.cross(side.along); // horizontal, perpendicular to the side
    let origin = Vec3::new(side.origin.x, st.spring, side.origin.z);
    let bays = side.stations.len() - 1;
    let half_t = 0.5 * st.thickness;
    for i in 0..bays {
        let (a, c) = (side.stations[i], side.stations[i + 1]);
        let first = i == 0 && side.closes_corners;
        let last = i == bays - 1 && side.closes_corners;
        let panel = Panel {
            origin,
            along: side.along,
            across,
            s0: if first { a - half_t } else { a },
            s1: if last { c + half_t } else { c },
            centre: 0.5 * (a + c),
            // The wall over a pillar is as wide as it is thick.
            radius: 0.5 * (c - a) - half_t,
            height: st.top - st.spring,
            thickness: st.thickness,
            caps: (first, last),
        };
        arch_panel(&mut b, &panel);
    }
    b
}

/// A wall panel with a semicircular opening; see [`arch_panel`].
struct Panel {
    /// The point at s = 0 on the spring line, mid-thickness.
    origin: Vec3,
    along: Vec3,
    across: Vec3,
    /// The panel spans s0..s1 along and 0..height above the spring line.
    s0: f32,
    s1: f32,
    /// Arch centre (on the spring line) and radius.
    centre: f32,
    radius: f32,
    height: f32,
    thickness: f32,
    /// End faces at s0 and s1.
    caps: (bool, bool),
}

/// Front and back faces (rays from the arch centre to the outline, one chart
/// each), the intrados (unrolled by arc length, one chart) and optional end
/// caps. The top and the feet rest on the slab and the abaci: not emitted.
fn arch_panel(b: &mut MeshBuilder, p: &Panel) {
    let (c, r, h) = (p.centre, p.radius, p.height);
    debug_assert!(r < p.s1 - c && r < c - p.s0 && r < h);
    let at = |s: f32, y: f32, d: f32| p.origin + p.along * s + Vec3::Y * y + p.across * d;
    // The fan's angles: uniform, plus the two top corners so that the outline is exact.
    let mut angles: Vec<f32> = (0..=ARCH_SEGMENTS).map(|i| PI * i as f32 / ARCH_SEGMENTS as f32).collect();
    angles.push(h.atan2(p.s1 - c));
    angles.push(h.atan2(p.s0 - c));
    angles.sort_by(f32::total_cmp);
    angles.dedup_by(|x, y| (*x - *y).abs() < 1e-4);
    let outline = |a: f32| {
        let d = Vec2::new(a.cos(), a.sin());
        let tx = if d.x > 1e-6 {
            (p.s1 - c) / d.x
        } else if d.x < -1e-6 {
            (p.s0 - c) / d.x
        } else {
            f32::INFINITY
        };
        let ty = if d.y > 1e-6 { h / d.y } else { f32::INFINITY };
        Vec2::new(c, 0.0) + d * tx.min(ty)
    };
    let half_t = 0.5 * p.thickness;
    for sign in [-1.0f32, 1.0] {
        let chart = b.chart();
        let n = p.across * sign;
        let d = sign * half_t;
        let mut prev: Option<(u32, u32)> = None;
        for &a in &angles {
            let inner = Vec2::new(c + r * a.cos(), r * a.sin());
            let outer = outline(a);
            let vertex = |b: &mut MeshBuilder, q: Vec2| {
                let pos = at(q.x, q.y, d);
                let uv0 = Vec2::new(q.x, pos.y) * TILING;
                b.vertex(chart, pos, n, uv0, Vec2::new(sign * (q.x - p.s0), q.y))
            };
            let (vi, vo) = (vertex(b, inner), vertex(b, outer));
            if let Some((pi, po)) = prev {
                b.quad(pi, po, vo, vi);
            }
            prev = Some((vi, vo));
        }
    }
    // Intrados: normals point at the arch centre.
    let chart = b.chart();
    let mut arc = 0.0;
    let mut prev: Option<(Vec2, u32, u32)> = None;
    for &a in &angles {
        let q = Vec2::new(c + r * a.cos(), r * a.sin());
        if let Some((pq, _, _)) = prev {
            arc += (q - pq).length();
        }
        let n = -(p.along * a.cos() + Vec3::Y * a.sin());
        let v0 = b.vertex(chart, at(q.x, q.y, -half_t), n, Vec2::new(-half_t, arc) * TILING, Vec2::new(0.0, arc));
        let v1 = b.vertex(chart, at(q.x, q.y, half_t), n, Vec2::new(half_t, arc) * TILING, Vec2::new(p.thickness, arc));
        if let Some((_, p0, p1)) = prev {
            b.quad(p0, p1, v1, v0);
        }
        prev = Some((q, v0, v1));
    }
    for (cap, s, facing) in [(p.caps.0, p.s0, -p.along), (p.caps.1, p.s1, p.along)] {
        if cap {
            b.rect_facing(at(s, 0.0, -half_t), p.across * p.thickness, Vec3::Y * h, facing, CELL, TILING);
        }
    }
}

/// A double-sided cloth banner hanging from `top` (its top edge's centre):
/// `dims` = (width, length at the sides, extra length of the pointed tip).
/// It bellies out towards `out` with a deterministic wave that grows towards
/// the bottom (never behind its top edge, so it clears the arcade). Each side
/// is one chart: width by arc length down the cloth, so density stays even.
fn banner(b: &mut MeshBuilder, top: Vec3, across: Vec3, out: Vec3, dims: Vec3, phase: f32) {
    let (width, length, tip) = (dims.x, dims.y, dims.z);
    let (nx, ny) = (24u32, 48u32);
    let surface = |s: f32, t: f32| {
        let hang = (t / length).clamp(0.0, 1.2).powf(1.5);
        let billow = 0.5 + 0.5 * (2.0 * PI * t / 1.6 + phase + 1.3 * s).sin();
        let ripple = 0.5 + 0.5 * (2.0 * PI * s / (0.6 * width) + 0.7 * phase).sin();
        top + across * s - Vec3::Y * t + out * (hang * (0.12 * billow + 0.03 * ripple))
    };
    let row = (ny + 1) as usize;
    let mut grid = Vec::with_capacity((nx as usize + 1) * row);
    for i in 0..=nx {
        let s = (i as f32 / nx as f32 - 0.5) * width;
        let col_len = length + tip * (1.0 - (2.0 * s / width).abs());
        let mut arc = 0.0;
        for j in 0..=ny {
            let t = col_len * j as f32 / ny as f32;
            let p = surface(s, t);
            if j > 0 {
                arc += (p - surface(s, col_len * (j - 1) as f32 / ny as f32)).length();
            }
            let e = 1e-3;
            let ds = surface(s + e, t) - surface(s - e, t);
            let dt = surface(s, t + e) - surface(s, t - e);
            let mut n = ds.cross(dt).normalize();
            if n.dot(out) < 0.0 {
                n = -n;
            }
            grid.push((p, n, Vec2::new(s, t), arc));
        }
    }
    // Front and back sheets 1 cm apart, so they never z-fight without culling.
    for sign in [1.0f32, -1.0] {
        let chart = b.chart();
        let base = grid
            .iter()
            .map(|&(p, n, st, arc)| {
                let pos = if sign > 0.0 { p } else { p - n * 0.01 };
                let local = Vec2::new(sign * st.x, arc);
                b.vertex(chart, pos, n * sign, st * TILING, local)
            })
            .collect::<Vec<u32>>();
        for i in 0..nx as usize {
            for j in 0..ny as usize {
                let v = |i: usize, j: usize| base[i * row + j];
                b.quad(v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1));
            }
        }
    }
}
