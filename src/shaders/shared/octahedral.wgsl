// Octahedral encoding of unit vectors into two numbers in [-1, 1] (Meyer et
// al. 2010; Cigolle et al., "A Survey of Efficient Representations for
// Independent Unit Vectors", JCGT 2014): project onto the octahedron
// |x| + |y| + |z| = 1, then fold the lower half over the diagonals. Used for
// G-buffer normals. The Rust twin is `render::passes::gbuffer::octahedral`,
// whose tests bound the round-trip error through the stored format.
#define_import_path shadespace::octahedral

// +1 or -1 per component (+1 for zero, so that the fold is continuous).
fn sign_not_zero(v: vec2f) -> vec2f {
    return select(vec2f(-1.0), vec2f(1.0), v >= vec2f(0.0));
}

// Unit vector -> [-1, 1]^2.
fn oct_encode(n: vec3f) -> vec2f {
    let p = n.xy / (abs(n.x) + abs(n.y) + abs(n.z));
    return select(p, (1.0 - abs(p.yx)) * sign_not_zero(p), n.z < 0.0);
}

// [-1, 1]^2 -> unit vector (the inverse of `oct_encode`).
fn oct_decode(e: vec2f) -> vec3f {
    let z = 1.0 - abs(e.x) - abs(e.y);
    // Unfold the lower half: move x and y towards zero by the overshoot.
    let t = max(-z, 0.0);
    let xy = e - t * sign_not_zero(e);
    return normalize(vec3f(xy, z));
}
