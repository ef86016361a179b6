// The compute rasterizer's resolve: the 64-bit depth-and-payload buffer of
// `raster.wgsl` turned into the visibility buffer every consumer reads:
// (object + 1, triangle), 0 = background. Here the buffer is read as plain (payload, depth bits) pairs:
// 64-bit atomics other than min/max are optional (`SHADER_INT64_ATOMIC_ALL_OPS`).
// Under MSAA (`MSAA` defined) a pixel has `params.samples` entries side by
// side, and the visibility buffer one layer per sample (multisampled
// textures cannot be written by compute passes).

// Mirrors `visibility::compute::GpuResolveParams`.
struct ResolveParams {
    width: u32,
    height: u32,
    // Entries of `ranges`.
    range_count: u32,
    // Samples per pixel (1 without MSAA).
    samples: u32,
}

@group(0) @binding(0) var<uniform> params: ResolveParams;
// Per visible object: (object, index of its first triangle in this frame's
// list, index of its first triangle in the scene's numbering, 0).
@group(0) @binding(1) var<storage, read> ranges: array<vec4u>;
// Per pixel (sample): (payload, depth bits), the halves of `raster.wgsl`'s `depth_ids`.
@group(0) @binding(2) var<storage, read> depth_ids: array<vec2u>;
#ifdef MSAA
@group(0) @binding(3) var visibility: texture_storage_2d_array<rg32uint, write>;
#else
@group(0) @binding(3) var visibility: texture_storage_2d<rg32uint, write>;
#endif

// The first CACHED_RANGES entries of `ranges` (object, first triangle in
// the scene's numbering), copied by the workgroup where they are all of
// them: each pixel's search then reads workgroup memory, not the buffer.
const CACHED_RANGES: u32 = 64u;
var<workgroup> cached: array<vec2u, CACHED_RANGES>;

@compute @workgroup_size(8, 8)
fn resolve(@builtin(global_invocation_id) id: vec3u, @builtin(local_invocation_index) local: u32) {
    let in_cache = params.range_count <= CACHED_RANGES;
    if in_cache && local < params.range_count {
        cached[local] = ranges[local].xz;
    }
    workgroupBarrier();
    if any(id.xy >= vec2u(params.width, params.height)) {
        return;
    }
    let first = (id.y * params.width + id.x) * params.samples;
    for (var s = 0u; s < params.samples; s++) {
        let ids = ids_of(depth_ids[first + s].x, in_cache);
#ifdef MSAA
        textureStore(visibility, id.xy, s, vec4u(ids, 0u, 0u));
#else
        textureStore(visibility, id.xy, vec4u(ids, 0u, 0u));
#endif
    }
}

// Entry `i` of `ranges` as (object, first triangle in the scene's
// numbering), from the workgroup's copy where `in_cache`.
fn range_at(i: u32, in_cache: bool) -> vec2u {
    if in_cache {
        return cached[i];
    }
    return ranges[i].xz;
}

// (object + 1, triangle) of a payload; (0, 0) for background.
fn ids_of(payload: u32, in_cache: bool) -> vec2u {
    var ids = vec2u(0u);
    if payload != 0u {
        // The payload is the complement of the scene's triangle index; the
        // entry is the last visible object whose first triangle is at most it.
        let index = ~payload;
        var lo = 0u;
        var hi = params.range_count - 1u;
        while lo < hi {
            let mid = (lo + hi + 1u) / 2u;
            if range_at(mid, in_cache).y <= index {
                lo = mid;
            } else {
                hi = mid - 1u;
            }
        }
        let r = range_at(lo, in_cache);
        ids = vec2u(r.x + 1u, index - r.y);
    }
    return ids;
}
