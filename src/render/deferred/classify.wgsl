// Light volumes, sorted (one workgroup): every point and spot light whose
// lit region may be in view goes into one of four lists: sphere or cone,
// seen from outside (the eye and near plane clear of the volume: drawn front
// faces, depth-tested) or from inside (drawn back faces, untested). Lights go
// in 256 at a time, each list keeping light order (places from population
// counts of a bit ballot, not from atomic counters whose order would vary,
// so blending sums in the same order every frame). Writes the lists and
// the instance counts of the four indirect draws.
#import shadespace::contract::{VOLUME_POINT_OUTSIDE, VOLUME_POINT_INSIDE, VOLUME_SPOT_OUTSIDE, VOLUME_SPOT_INSIDE,
    VOLUME_LISTS}
#import shadespace::lighting::Light
#import shadespace::light_bounds::{light_bounds, sphere_touches}
#import shadespace::scene_bindings::{view, lights}
#import shadespace::deferred::{VolumeParams, drawn_as_cone, volume_reach}

@group(1) @binding(0) var<uniform> params: VolumeParams;
@group(1) @binding(1) var<storage, read_write> lists: array<u32>;
// Four `DrawIndexedIndirectArgs` of 5 words; the instance count is word 1.
@group(1) @binding(2) var<storage, read_write> draws: array<u32>;

const CHUNK: u32 = 256u;
const NO_LIST: u32 = 0xffffffffu;

// Per list, one bit per thread of this chunk.
var<workgroup> ballots: array<atomic<u32>, 32>;
var<workgroup> counts: array<u32, 4>;

fn list_of(l: Light) -> u32 {
    if !sphere_touches(params.frustum, light_bounds(l)) {
        return NO_LIST;
    }
    let inside = distance(view.camera_position.xyz, l.position) < volume_reach(params, l) + params.near_reach;
    if drawn_as_cone(params, l) {
        return select(VOLUME_SPOT_OUTSIDE, VOLUME_SPOT_INSIDE, inside);
    }
    return select(VOLUME_POINT_OUTSIDE, VOLUME_POINT_INSIDE, inside);
}

@compute @workgroup_size(256)
fn classify(@builtin(local_invocation_index) thread: u32) {
    if thread < VOLUME_LISTS {
        counts[thread] = 0u;
    }
    if thread < 8u * VOLUME_LISTS {
        atomicStore(&ballots[thread], 0u);
    }
    let word = thread / 32u;
    let bit = 1u << (thread % 32u);
    let count = view.light_count;
    for (var first = view.global_light_count; first < count; first += CHUNK) {
        workgroupBarrier();
        let index = first + thread;
        var list = NO_LIST;
        if index < count {
            list = list_of(lights[index]);
        }
        if list != NO_LIST {
            atomicOr(&ballots[list * 8u + word], bit);
        }
        workgroupBarrier();
        if list != NO_LIST {
            var below = countOneBits(atomicLoad(&ballots[list * 8u + word]) & (bit - 1u));
            for (var w = 0u; w < word; w++) {
                below += countOneBits(atomicLoad(&ballots[list * 8u + w]));
            }
            lists[list * params.capacity + counts[list] + below] = index;
        }
        workgroupBarrier();
        if thread < VOLUME_LISTS {
            for (var w = 0u; w < 8u; w++) {
                counts[thread] += countOneBits(atomicLoad(&ballots[thread * 8u + w]));
            }
        }
        workgroupBarrier();
        if thread < 8u * VOLUME_LISTS {
            atomicStore(&ballots[thread], 0u);
        }
    }
    workgroupBarrier();
    if thread < VOLUME_LISTS {
        draws[thread * 5u + 1u] = counts[thread];
    }
}
