// Dilation of a triangle-index map by one texel, inside one level's square:
// an empty texel takes the id of a covered neighbour (edge neighbours first),
// so that bilinear taps just outside a chart find a triangle to extrapolate.
struct Square {
    origin: vec2u,
    size: u32,
    page: u32,
}

@group(0) @binding(0) var<uniform> square: Square;
@group(0) @binding(1) var source: texture_2d_array<u32>;
@group(0) @binding(2) var dilated: texture_storage_2d_array<r32uint, write>;

@compute @workgroup_size(8, 8)
fn dilate(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= square.size || id.y >= square.size {
        return;
    }
    let p = vec2i(id.xy);
    let s = i32(square.size);
    let o = vec2i(square.origin);
    var value = textureLoad(source, o + p, square.page, 0).x;
    let offsets = array<vec2i, 8>(vec2i(1, 0), vec2i(-1, 0), vec2i(0, 1), vec2i(0, -1),
                                  vec2i(1, 1), vec2i(-1, 1), vec2i(1, -1), vec2i(-1, -1));
    for (var i = 0u; i < 8u && value == 0u; i++) {
        let q = p + offsets[i];
        if all(q >= vec2i(0)) && all(q < vec2i(s)) {
            value = textureLoad(source, o + q, square.page, 0).x;
        }
    }
    textureStore(dilated, o + p, square.page, vec4u(value, 0u, 0u, 0u));
}
