// The depth pyramid of two-pass occlusion culling (`cull.wgsl`), one
// dispatch per level: level 0's texel is the farthest depth (reversed Z:
// the least) of a 2x2 block of pixels of the compute rasterizer's 64-bit
// buffer (under MSAA of every sample of them), level k + 1's of a 2x2
// block of level k's texels. Sides round up and blocks past the edge use
// the texels they have, so a texel of level k covers exactly the pixels [2^(k+1) t, 2^(k+1) (t + 1)) inside the screen.
// With DEPTH_TEXTURE level 0 reads the depth target of the hardware raster
// passes instead (`passes::cluster_draws`).

// Mirrors `visibility::compute::GpuHizLevel`.
struct HizLevel {
    // First entry of the source level in `hiz` (unused from pixels).
    src_offset: u32,
    src_width: u32,
    src_height: u32,
    dst_offset: u32,
    dst_width: u32,
    dst_height: u32,
    // 1: the source is the pixels (`depth_ids`).
    from_pixels: u32,
    // Entries of `depth_ids` per pixel: its samples.
    samples: u32,
}

@group(0) @binding(0) var<uniform> level: HizLevel;
#ifdef DEPTH_TEXTURE
@group(0) @binding(1) var depth: texture_depth_2d;

fn pixel_depth(p: vec2u, i: u32) -> f32 {
    return textureLoad(depth, p, 0);
}
#else
// Per pixel (sample): (payload, depth bits), the halves of `raster.wgsl`'s `depth_ids`.
@group(0) @binding(1) var<storage, read> depth_ids: array<vec2u>;

// The farthest of the pixel's samples.
fn pixel_depth(p: vec2u, i: u32) -> f32 {
    var farthest = bitcast<f32>(depth_ids[i * level.samples].y);
    for (var s = 1u; s < level.samples; s++) {
        farthest = min(farthest, bitcast<f32>(depth_ids[i * level.samples + s].y));
    }
    return farthest;
}
#endif
@group(0) @binding(2) var<storage, read_write> hiz: array<f32>;

@compute @workgroup_size(8, 8)
fn reduce(@builtin(global_invocation_id) id: vec3u) {
    if any(id.xy >= vec2u(level.dst_width, level.dst_height)) {
        return;
    }
    var farthest = 3.0e38;
    for (var k = 0u; k < 4u; k++) {
        let p = id.xy * 2u + vec2u(k & 1u, k >> 1u);
        if any(p >= vec2u(level.src_width, level.src_height)) {
            continue;
        }
        let i = p.y * level.src_width + p.x;
        if level.from_pixels != 0u {
            farthest = min(farthest, pixel_depth(p, i));
        } else {
            farthest = min(farthest, hiz[level.src_offset + i]);
        }
    }
    hiz[level.dst_offset + id.y * level.dst_width + id.x] = farthest;
}
