// Triangle-index maps: rasterize an object's charts in UV space into its
// square of the atlas (the viewport), writing triangle + 1 per texel, every
// texel a triangle touches. `vs_main`/`fs_main` rely on the hardware's
// conservative rasterization; where the adapter has none, `vs_conservative`/
// `fs_conservative` emulate it (Hasselgren, Akenine-Moller and Ohlsson,
// "Conservative Rasterization", GPU Gems 2, ch. 42): each edge moves outward
// by half a texel's extent along its normal, so that every texel the
// triangle touches has its centre inside the enlarged triangle, and
// fragments beyond the triangle's bounding box grown by half a texel are
// discarded (the enlarged corners overreach there).
enable primitive_index;
#import shadespace::scene_bindings::{vertices, objects, triangle_vertices}

@vertex
fn vs_main(@builtin(vertex_index) vi: u32) -> @builtin(position) vec4f {
    let uv = vertices[vi].chart_uv;
    return vec4f(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.5, 1.0);
}

@fragment
fn fs_main(@builtin(primitive_index) triangle: u32) -> @location(0) u32 {
    return triangle + 1u;
}

// Mirrors `trimap::GpuTrimapDraw`: one object's level, drawn as instance k.
struct TrimapDraw {
    object: u32,
    // The level's side in texels, and its square's corner in the page.
    size: u32,
    origin: vec2u,
}

@group(1) @binding(0) var<storage, read> draws: array<TrimapDraw>;

struct Enlarged {
    @builtin(position) position: vec4f,
    @location(0) @interpolate(flat) triangle: u32,
    // The triangle's bounding box in page texels, grown by half a texel.
    @location(1) @interpolate(flat) bounds: vec4f,
}

fn cross2(a: vec2f, b: vec2f) -> f32 {
    return a.x * b.y - a.y * b.x;
}

// Non-indexed: vertex `vi` is corner vi % 3 of the object's triangle vi / 3.
@vertex
fn vs_conservative(@builtin(vertex_index) vi: u32, @builtin(instance_index) k: u32) -> Enlarged {
    let d = draws[k];
    let triangle = vi / 3u;
    let corner = vi % 3u;
    let tri = triangle_vertices(objects[d.object], triangle);
    let size = f32(d.size);
    // Texel units of this level (y down, as the viewport maps it).
    let p = array<vec2f, 3>(
        vertices[tri.x].chart_uv * size,
        vertices[tri.y].chart_uv * size,
        vertices[tri.z].chart_uv * size,
    );
    var out: Enlarged;
    out.triangle = triangle;
    let lo = min(min(p[0], p[1]), p[2]);
    let hi = max(max(p[0], p[1]), p[2]);
    out.bounds = vec4f(lo - 0.5, hi + 0.5) + vec4f(vec2f(d.origin), vec2f(d.origin));
    let area = cross2(p[1] - p[0], p[2] - p[0]);
    var q = p[corner];
    if area != 0.0 {
        // The two edges meeting at this corner, each moved out by the half
        // extent of a texel along its unit outward normal; the corner moves
        // to where the moved lines cross.
        let a = p[(corner + 2u) % 3u];
        let b = p[(corner + 1u) % 3u];
        let n1 = normalize(vec2f(q.y - a.y, a.x - q.x)) * sign(area);
        let n2 = normalize(vec2f(b.y - q.y, q.x - b.x)) * sign(area);
        let c1 = dot(n1, q) + 0.5 * (abs(n1.x) + abs(n1.y));
        let c2 = dot(n2, q) + 0.5 * (abs(n2.x) + abs(n2.y));
        let det = n1.x * n2.y - n1.y * n2.x;
        if det != 0.0 {
            let moved = vec2f(c1 * n2.y - c2 * n1.y, n1.x * c2 - n2.x * c1) / det;
            // A very sharp corner moves far out; the bounding box discards
            // what lies beyond, so cap the move (keeps the numbers finite).
            let offset = moved - q;
            let reach = length(offset);
            q += offset * min(1.0, 4.0 * size / max(reach, 1e-20));
        }
    }
    let uv = q / size;
    out.position = vec4f(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.5, 1.0);
    return out;
}

@fragment
fn fs_conservative(in: Enlarged) -> @location(0) u32 {
    let c = in.position.xy;
    if any(c < in.bounds.xy) || any(c > in.bounds.zw) {
        discard;
    }
    return in.triangle + 1u;
}
