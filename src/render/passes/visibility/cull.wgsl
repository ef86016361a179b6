// GPU culling of the compute rasterizer's clusters (`--culling`,
// `visibility::compute`). One workgroup per chunk of up to 64 clusters of an
// object in view (the CPU has already skipped the objects outside the
// frustum, and lists the chunks), a thread per cluster; each is tested against the frustum (its object-space
// box through the object's model-view-projection) and, where the scene culls
// back faces, its normal cone. `cull_early` appends the survivors to list 0
// (with occlusion: only those visible last frame); the rasterizer draws
// them; `hiz.wgsl` builds a depth pyramid from that depth; `cull_late` tests
// every survivor against the pyramid, remembers the result for the next
// frame, and appends the newly visible to list 1, which is drawn after.
// Every test is conservative: it skips only clusters that could not have
// written a pixel, so the visibility buffer is the same with and without.
// With INDEXED_DRAWS (the hardware raster passes' indexed cluster draws,
// `passes::cluster_draws`) each run of consecutive clusters of a chunk
// appended to a list also gets one indexed indirect draw of its range of the
// cluster-ordered index buffer (a mesh's clusters are consecutive ranges).
// With SHADOW_FACES as well (the shadow maps' culling, `shadows::cull`),
// every range is one caster of one shadow face (`ranges[r].w`): its
// clusters are tested against that face's frustum, and its draws go to
// that face's part of `draws`, counted per face.
#import shadespace::scene_bindings::{view, objects}

// Mirrors `clusters::GpuCluster`.
struct Cluster {
    min: vec3f,
    first: u32,
    max: vec3f,
    count: u32,
    center: vec3f,
    radius: f32,
    cone_axis: vec3f,
    cone_cutoff: f32,
}

// Mirrors `visibility::compute::GpuCullParams`.
struct CullParams {
    // Entries of `ranges` (visible objects).
    range_count: u32,
    // CULL_CONE | CULL_OCCLUSION.
    flags: u32,
    // Entries of each list in `cluster_lists` (list 1 starts there).
    capacity: u32,
    // Levels of `hiz`.
    levels: u32,
    width: u32,
    height: u32,
    // Entries of `chunks`: the workgroups.
    chunk_count: u32,
    pad: u32,
    // First entry of each level in `hiz` (level k: [k / 4][k % 4]).
    level_offsets: array<vec4u, 4>,
}

// `CullParams.flags`.
const CULL_CONE: u32 = 1u;
const CULL_OCCLUSION: u32 = 2u;
// The raster passes draw every object in view this frame (the lists are
// only counted, `cluster_draws::CULL_PLAIN`): with occlusion the early pass
// lists nothing and the late pass lists every cluster it sees, so that the
// lists count what the frame shows; no indexed draws are written.
const CULL_PLAIN: u32 = 4u;

// Entries of `counts` (`compute::CullCount`).
const LIST_EARLY: u32 = 0u;
const LIST_LATE: u32 = 1u;
const TESTED: u32 = 2u;
const FRUSTUM_CULLED: u32 = 3u;
const CONE_CULLED: u32 = 4u;
const OCCLUSION_CULLED: u32 = 5u;

// Mirrors `clusters::CONE_MARGIN`.
const CONE_MARGIN: f32 = 0.01;
// A cluster is occluded only when its nearest depth is this much (relative)
// farther than the pyramid's farthest: its triangles' depths at pixel
// centres, interpolated from rounded vertices, may exceed the box's a little,
// and at equal depth the earlier triangle wins (so a tie must be drawn).
const DEPTH_MARGIN: f32 = 1e-5;
const CULL_WORKGROUP: u32 = 64u;
// Most workgroups along x of one indirect dispatch (`compute::MAX_GROUPS_X`).
const MAX_GROUPS_X: u32 = 32768u;

@group(1) @binding(0) var<uniform> params: CullParams;
// Per visible object: (object, first triangle in the frame's list, first
// triangle in the scene's numbering, 0).
@group(1) @binding(1) var<storage, read> ranges: array<vec4u>;
@group(1) @binding(2) var<storage, read> clusters: array<Cluster>;
// Per object: (first cluster, cluster count, first slot of `history`, first
// triangle in the scene's numbering).
@group(1) @binding(3) var<storage, read> object_clusters: array<vec4u>;
// Per slot (object and cluster): 1 when the cluster was visible last frame.
@group(1) @binding(4) var<storage, read_write> history: array<u32>;
// Two lists of (entry of `ranges`, cluster): list 0 from 0, list 1 from
// `params.capacity`.
@group(1) @binding(5) var<storage, read_write> cluster_lists: array<vec2u>;
@group(1) @binding(6) var<storage, read_write> counts: array<atomic<u32>, 6>;
// The depth pyramid (`hiz.wgsl`): level k's texel covers 2^(k+1) pixels a
// side and holds the farthest depth among them (reversed Z: the least).
@group(1) @binding(7) var<storage, read> hiz: array<f32>;
// Indirect dispatch sizes of `raster_clusters` for lists 0 and 1.
@group(1) @binding(8) var<storage, read_write> dispatch: array<u32, 6>;
// The workgroups' work: (entry of `ranges`, first cluster of its object).
@group(1) @binding(9) var<storage, read> chunks: array<vec2u>;

#ifdef SHADOW_FACES
// Every shadow face's view-projection (the scene group's binding 10, as
// `shadows.wgsl` declares it).
@group(0) @binding(10) var<storage, read> shadow_faces: array<mat4x4f>;

// The view-projection visible object `range_index` is culled by.
fn range_view_proj(range_index: u32) -> mat4x4f {
    return shadow_faces[ranges[range_index].w];
}
#else
fn range_view_proj(range_index: u32) -> mat4x4f {
    return view.view_proj;
}
#endif

#ifdef INDEXED_DRAWS
// `draw_indexed_indirect` arguments.
struct DrawIndexedArgs {
    index_count: u32,
    instance_count: u32,
    first_index: u32,
    base_vertex: i32,
    // The entry of `cluster_lists` (list * capacity + index) of the run's
    // first cluster: the vertex shader reads its object and cluster there.
    first_instance: u32,
}

#ifdef SHADOW_FACES
// Per shadow face: the first entry of its opaque casters' draws in `draws`
// and of its alpha-masked casters'.
@group(2) @binding(0) var<storage, read> face_draws: array<vec2u>;
#else
// x: the first entry of the alpha-masked objects' draws in each list's
// `params.capacity` entries of `draws` (the opaque ones' come first).
@group(2) @binding(0) var<uniform> draw_split: vec4u;
#endif
@group(2) @binding(1) var<storage, read_write> draws: array<DrawIndexedArgs>;
// Draws per list and kind: list 0 opaque, list 0 masked, list 1 opaque,
// list 1 masked (the count buffer of `multi_draw_indexed_indirect_count`).
// With SHADOW_FACES: every face's draws, 0, then per face opaque, masked.
@group(2) @binding(2) var<storage, read_write> draw_counts: array<atomic<u32>>;

// Per thread of the chunk: its cluster's list entry + 1, 0 when not appended.
var<workgroup> appended: array<u32, CULL_WORKGROUP>;
#endif

var<workgroup> group_counts: array<atomic<u32>, 4>;

fn corner(mvp: mat4x4f, c: Cluster, i: u32) -> vec4f {
    let p = select(c.min, c.max, vec3<bool>((i & 1u) != 0u, (i & 2u) != 0u, (i & 4u) != 0u));
    return mvp * vec4f(p, 1.0);
}

// Whether the box lies wholly outside one clip plane (the twin of
// `Cluster::outside_frustum`).
fn outside_frustum(mvp: mat4x4f, c: Cluster) -> bool {
    var all_out = 63u;
    for (var i = 0u; i < 8u; i++) {
        let q = corner(mvp, c, i);
        var out = select(0u, 1u, q.x < -q.w) | select(0u, 2u, q.x > q.w);
        out |= select(0u, 4u, q.y < -q.w) | select(0u, 8u, q.y > q.w);
        out |= select(0u, 16u, q.z < 0.0) | select(0u, 32u, q.z > q.w);
        all_out &= out;
    }
    return all_out != 0u;
}

// Whether every triangle faces away from `eye` (object space; `flip` is -1
// for a mirroring transform, whose back faces are the other side): the twin
// of `Cluster::backfacing`.
fn backfacing(c: Cluster, eye: vec3f, flip: f32) -> bool {
    let d = c.center - eye;
    return dot(d, c.cone_axis * flip) > (c.cone_cutoff + CONE_MARGIN) * length(d) + c.radius;
}

// Size of pyramid level k.
fn level_size(k: u32) -> vec2u {
    let side = 1u << (k + 1u);
    return (vec2u(params.width, params.height) + side - 1u) >> vec2u(k + 1u);
}

// Whether the box is hidden behind the depth in the pyramid: its screen
// rectangle (every pixel centre it may hold, and one more pixel each side)
// lies in at most 2x2 texels of one level, and its nearest depth is farther
// than theirs. A box reaching in front of the near plane is never hidden; one
// holding no pixel centre is (it draws nothing).
fn occluded(mvp: mat4x4f, c: Cluster) -> bool {
    var lo = vec2f(3.0e38);
    var hi = vec2f(-3.0e38);
    var nearest = 0.0;
    for (var i = 0u; i < 8u; i++) {
        let q = corner(mvp, c, i);
        if !(q.w > 0.0) || q.z > q.w {
            return false;
        }
        let ndc = q.xyz / q.w;
        lo = min(lo, ndc.xy);
        hi = max(hi, ndc.xy);
        nearest = max(nearest, ndc.z);
    }
    let size = vec2f(f32(params.width), f32(params.height));
    // Pixel coordinates with pixel i's centre at i, y down.
    let p_lo = clamp(vec2f(lo.x + 1.0, 1.0 - hi.y) * 0.5 * size - 0.5, vec2f(-2.0), size + 1.0);
    let p_hi = clamp(vec2f(hi.x + 1.0, 1.0 - lo.y) * 0.5 * size - 0.5, vec2f(-2.0), size + 1.0);
    let a = max(vec2i(floor(p_lo)) - 1, vec2i(0));
    let b = min(vec2i(ceil(p_hi)) + 1, vec2i(i32(params.width), i32(params.height)) - 1);
    if any(a > b) {
        return true;
    }
    let ua = vec2u(a);
    let ub = vec2u(b);
    var k = 0u;
    while k + 1u < params.levels && any((ub >> vec2u(k + 1u)) - (ua >> vec2u(k + 1u)) > vec2u(1u)) {
        k++;
    }
    let t0 = ua >> vec2u(k + 1u);
    let t1 = ub >> vec2u(k + 1u);
    let width = level_size(k).x;
    let offset = params.level_offsets[k / 4u][k % 4u];
    var farthest = 3.0e38;
    for (var y = t0.y; y <= t1.y; y++) {
        for (var x = t0.x; x <= t1.x; x++) {
            farthest = min(farthest, hiz[offset + y * width + x]);
        }
    }
    return nearest * (1.0 + DEPTH_MARGIN) < farthest;
}

// Appends the cluster to `list`; returns its entry + 1.
fn append(list: u32, range_index: u32, cluster: u32) -> u32 {
    let at = atomicAdd(&counts[list], 1u);
    let entry = list * params.capacity + at;
    cluster_lists[entry] = vec2u(range_index, cluster);
    return entry + 1u;
}

#ifdef INDEXED_DRAWS
// One draw of clusters `i0` to `i1` (inclusive) of visible object
// `range_index`, appended to `list`, the first at `entry`.
fn append_draw(list: u32, range_index: u32, i0: u32, i1: u32, entry: u32) {
    let object = ranges[range_index].x;
    let o = objects[object];
    let c0 = clusters[object_clusters[object].x + i0];
    let c1 = clusters[object_clusters[object].x + i1];
    // Opaque and alpha-masked objects are drawn by pipelines of their own
    // (`passes::ScenePipeline`), each from its own run of draws.
    let masked = o.alpha_cutoff > 0.0;
#ifdef SHADOW_FACES
    let face = ranges[range_index].w;
    atomicAdd(&draw_counts[0], 1u);
    let k = atomicAdd(&draw_counts[2u + 2u * face + select(0u, 1u, masked)], 1u);
    let first = select(face_draws[face].x, face_draws[face].y, masked);
#else
    let k = atomicAdd(&draw_counts[2u * list + select(0u, 1u, masked)], 1u);
    let first = list * params.capacity + select(0u, draw_split.x, masked);
#endif
    let count = c1.first + c1.count - c0.first;
    draws[first + k] = DrawIndexedArgs(3u * count, 1u, 3u * c0.first, i32(o.base_vertex), entry);
}
#endif

// Cluster `i` of visible object `range_index`. Early: the frustum and cone
// tests and the early list; late: the occlusion test, the history and the
// late list. Returns its list entry + 1 where it was appended, else 0.
fn cull_cluster(range_index: u32, i: u32, late: bool) -> u32 {
    let object = ranges[range_index].x;
    let oc = object_clusters[object];
    if i >= oc.y {
        return 0u;
    }
    let o = objects[object];
    let mvp = range_view_proj(range_index) * o.model;
    let cluster = oc.x + i;
    let slot = oc.z + i;
    let c = clusters[cluster];
    // Counted once a frame, in the early pass.
    if !late {
        atomicAdd(&group_counts[0], 1u);
    }
    let outside = outside_frustum(mvp, c);
    var away = false;
    // Only single-sided objects' clusters may face away.
    if !outside && (params.flags & CULL_CONE) != 0u && o.cull_back != 0u {
        // The model's inverse is the transpose of the normal matrix.
        let eye = (transpose(o.normal_model) * vec4f(view.camera_position.xyz, 1.0)).xyz;
        let linear = mat3x3f(o.model[0].xyz, o.model[1].xyz, o.model[2].xyz);
        away = backfacing(c, eye, select(1.0, -1.0, determinant(linear) < 0.0));
    }
    if outside || away {
        if late {
            history[slot] = 0u;
        } else {
            atomicAdd(&group_counts[select(2u, 1u, outside)], 1u);
        }
        return 0u;
    }
    let plain = (params.flags & CULL_PLAIN) != 0u;
    if !late {
        // (The history is read only with occlusion: the shadow faces bind none.)
        if (params.flags & CULL_OCCLUSION) == 0u || (!plain && history[slot] != 0u) {
            return append(LIST_EARLY, range_index, cluster);
        }
        return 0u;
    }
    let was_visible = !plain && history[slot] != 0u;
    let seen = !occluded(mvp, c);
    history[slot] = select(0u, 1u, seen);
    if !was_visible {
        if seen {
            return append(LIST_LATE, range_index, cluster);
        } else {
            atomicAdd(&group_counts[3], 1u);
        }
    }
    return 0u;
}

// Chunk `chunk` of the frame's list (`chunks`: up to CULL_WORKGROUP clusters
// of one visible object), a thread per cluster; the workgroup's counts are
// summed before one global add each. With INDEXED_DRAWS, the first thread
// of each run of consecutive appended clusters writes the run's draw.
fn cull_chunk(chunk: u32, local: u32, late: bool) {
    if local < 4u {
        atomicStore(&group_counts[local], 0u);
    }
    workgroupBarrier();
    var entry = 0u;
    if chunk < params.chunk_count {
        let ch = chunks[chunk];
        entry = cull_cluster(ch.x, ch.y + local, late);
    }
#ifdef INDEXED_DRAWS
    appended[local] = entry;
#endif
    workgroupBarrier();
    if local < 4u {
        let n = atomicLoad(&group_counts[local]);
        if n > 0u {
            atomicAdd(&counts[TESTED + local], n);
        }
    }
#ifdef INDEXED_DRAWS
    let plain = (params.flags & CULL_PLAIN) != 0u;
    if !plain && entry != 0u && (local == 0u || appended[local - 1u] == 0u) {
        var last = local;
        while last + 1u < CULL_WORKGROUP && appended[last + 1u] != 0u {
            last++;
        }
        let ch = chunks[chunk];
        append_draw(select(LIST_EARLY, LIST_LATE, late), ch.x, ch.y + local, ch.y + last, entry - 1u);
    }
#endif
}

@compute @workgroup_size(CULL_WORKGROUP)
fn cull_early(
    @builtin(workgroup_id) group: vec3u,
    @builtin(num_workgroups) groups: vec3u,
    @builtin(local_invocation_index) local: u32,
) {
    cull_chunk(group.y * groups.x + group.x, local, false);
}

@compute @workgroup_size(CULL_WORKGROUP)
fn cull_late(
    @builtin(workgroup_id) group: vec3u,
    @builtin(num_workgroups) groups: vec3u,
    @builtin(local_invocation_index) local: u32,
) {
    cull_chunk(group.y * groups.x + group.x, local, true);
}

// Sizes the indirect dispatches of both lists (one workgroup per entry,
// at most MAX_GROUPS_X along x).
@compute @workgroup_size(1)
fn finish() {
    for (var l = 0u; l < 2u; l++) {
        let n = atomicLoad(&counts[l]);
        let x = min(n, MAX_GROUPS_X);
        dispatch[3u * l] = x;
        dispatch[3u * l + 1u] = select(0u, (n + x - 1u) / max(x, 1u), x > 0u);
        dispatch[3u * l + 2u] = 1u;
    }
}
