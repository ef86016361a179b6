// Automatic exposure: the log-average luminance of the HDR frame, reduced in
// two dispatches (per 64x64 tile, then over the tiles), turned into the
// multiplier that maps it to mid-grey, written where the tone mapper reads
// its exposure. No CPU round trip.

@group(0) @binding(0) var hdr: texture_2d<f32>;
// Per tile: (sum of log2 luminance, number of pixels summed).
@group(0) @binding(1) var<storage, read_write> tiles: array<vec2f>;
// x: the exposure multiplier (the tone mapper's uniform).
@group(0) @binding(2) var<storage, read_write> exposure: vec4f;

// Pixels per tile side: 16x16 threads, each reading 4x4 pixels 16 apart (so
// that neighbouring threads read neighbouring pixels).
const TILE: u32 = 64u;
// The log-average is mapped to this (Reinhard's key, mid-grey).
const KEY: f32 = 0.18;
// Pixels darker than this received no light (the background): averaging
// them in would make any model on black look underexposed.
const MIN_LUMINANCE: f32 = 5.9604645e-8; // 2^-24
// The brightest luminance an Rgba16Float target holds; infinities count as it.
const MAX_LUMINANCE: f32 = 65504.0;
// Exposure stays within 2^-20 to 2^20.
const MIN_EXPOSURE: f32 = 9.536743e-7;
const MAX_EXPOSURE: f32 = 1048576.0;

var<workgroup> partial: array<vec2f, 256>;

// Sums `value` over the 256 threads of the workgroup (every thread gets it).
fn workgroup_sum(local: u32, value: vec2f) -> vec2f {
    partial[local] = value;
    workgroupBarrier();
    for (var step = 128u; step > 0u; step >>= 1u) {
        if local < step {
            partial[local] += partial[local + step];
        }
        workgroupBarrier();
    }
    return workgroupUniformLoad(&partial[0]);
}

@compute @workgroup_size(16, 16)
fn sum_tiles(
    @builtin(workgroup_id) group: vec3u,
    @builtin(num_workgroups) groups: vec3u,
    @builtin(local_invocation_id) thread: vec3u,
    @builtin(local_invocation_index) local: u32,
) {
    let size = textureDimensions(hdr);
    var sum = vec2f(0.0);
    for (var j = 0u; j < 4u; j++) {
        for (var i = 0u; i < 4u; i++) {
            let p = group.xy * TILE + thread.xy + 16u * vec2u(i, j);
            if all(p < size) {
                let lum = min(dot(textureLoad(hdr, p, 0).rgb, vec3f(0.2126, 0.7152, 0.0722)), MAX_LUMINANCE);
                // NaN fails the test too.
                if lum > MIN_LUMINANCE {
                    sum += vec2f(log2(lum), 1.0);
                }
            }
        }
    }
    let total = workgroup_sum(local, sum);
    if local == 0u {
        tiles[group.y * groups.x + group.x] = total;
    }
}

@compute @workgroup_size(256)
fn average(@builtin(local_invocation_index) local: u32) {
    var sum = vec2f(0.0);
    for (var i = local; i < arrayLength(&tiles); i += 256u) {
        sum += tiles[i];
    }
    let total = workgroup_sum(local, sum);
    if local == 0u {
        // Nothing lit: leave the frame as it is.
        var e = 1.0;
        if total.y > 0.0 {
            e = clamp(KEY / exp2(total.x / total.y), MIN_EXPOSURE, MAX_EXPOSURE);
        }
        exposure = vec4f(e, 0.0, 0.0, 0.0);
    }
}
