// Bounding spheres of what point and spot lights reach, and the sphere test
// against a convex region of planes (a view frustum, a tile's frustum): what
// GPU light culling shares.
#define_import_path shadespace::light_bounds
#import shadespace::contract::LIGHT_SPOT
#import shadespace::lighting::Light

// A sphere (centre, radius) holding every point a point or spot light can
// light: the sphere of its range, or for a spot light narrower than a
// half-space, the smallest sphere around its cone cut at the range (the
// spherical sector): through apex and rim below 45 degrees, centred on the
// rim's circle above.
fn light_bounds(l: Light) -> vec4f {
    let c = l.cos_outer;
    if l.kind != LIGHT_SPOT || c <= 0.0 {
        return vec4f(l.position, l.radius);
    }
    if c > 0.70710678 {
        let r = l.radius / (2.0 * c);
        return vec4f(l.position + l.direction * r, r);
    }
    return vec4f(l.position + l.direction * (l.radius * c), l.radius * sqrt(max(1.0 - c * c, 0.0)));
}

// Whether `sphere` reaches the inner side (`dot(n, p) + d >= 0`) of `plane`,
// whose normal is a unit vector.
fn reaches(plane: vec4f, sphere: vec4f) -> bool {
    return dot(plane.xyz, sphere.xyz) + plane.w >= -sphere.w;
}

// Whether `sphere` may touch the region inside all six planes (false only
// when it lies wholly outside one: conservative near the region's edges).
fn sphere_touches(planes: array<vec4f, 6>, sphere: vec4f) -> bool {
    return reaches(planes[0], sphere) && reaches(planes[1], sphere) && reaches(planes[2], sphere)
        && reaches(planes[3], sphere) && reaches(planes[4], sphere) && reaches(planes[5], sphere);
}
