// The atlas page view (`--view atlas-pages`): one mip level of one object's
// virtual shading texture over the whole frame, each texel found through
// the two-level page table as the gather finds it. Texels of backed pages
// show their shades; pages with no physical page show a dark checker.
#import shadespace::objectspace::{params, atlas_entries, entry_level, physical_page, virtual_page, atlas_texel, NOT_BACKED}

// Mirrors `objectspace::atlas_view::GpuAtlasPages`.
struct AtlasPages {
    object: u32,
    level: u32,
    pad_a: u32,
    pad_b: u32,
}

@group(2) @binding(0) var atlas: texture_2d_array<f32>;
@group(2) @binding(1) var hdr: texture_storage_2d<rgba16float, write>;
@group(2) @binding(2) var<storage, read> shown: AtlasPages;

// Greys of an unbacked page's checker (quarters of the page), before the
// tone mapper (Reinhard) brings them to about 0.04 and 0.11.
const UNBACKED_DARK: f32 = 0.04;
const UNBACKED_LIGHT: f32 = 0.125;

@compute @workgroup_size(8, 8)
fn atlas_view(@builtin(global_invocation_id) id: vec3u) {
    let size = textureDimensions(hdr);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    var out = vec4f(0.0, 0.0, 0.0, 1.0);
    let object = min(shown.object, arrayLength(&atlas_entries) - 1u);
    let e = atlas_entries[object];
    if shown.object < arrayLength(&atlas_entries) && e.size != 0u && shown.level < e.level_count {
        let l = entry_level(object, shown.level);
        // The level's square, as large as the frame holds it, centred; a
        // frame of the level's size shows one texel per pixel.
        let side = min(size.x, size.y);
        let corner = (size - vec2u(side)) / 2u;
        if all(id.xy >= corner) && all(id.xy < corner + side) {
            let texel = (id.xy - corner) * l.size / side;
            let page = physical_page(virtual_page(l, texel));
            if page == NOT_BACKED {
                let half = max(params.page_size / 2u, 1u);
                let cell = texel / half;
                out = vec4f(vec3f(select(UNBACKED_DARK, UNBACKED_LIGHT, ((cell.x + cell.y) & 1u) == 1u)), 1.0);
            } else {
                let at = atlas_texel(page, texel);
                out = vec4f(textureLoad(atlas, at.xy, at.layer, 0).rgb, 1.0);
            }
        }
    }
    textureStore(hdr, id.xy, out);
}
