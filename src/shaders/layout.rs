//! Structs whose bytes cross between Rust and WGSL. Each is declared with
//! `gpu_struct!`, which also records its members (name, offset, size), so a
//! test can compare every member, by name, with the layout naga computes for
//! the WGSL struct of the same name: a swapped, renamed, missing or
//! misaligned field fails, not only a wrong total size.

/// One member of a host-shared struct.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Member {
    pub name: &'static str,
    pub offset: usize,
}

/// A `#[repr(C)]` plain-data struct that mirrors the WGSL struct `WGSL_NAME`.
pub trait GpuStruct: bytemuck::Pod {
    const WGSL_NAME: &'static str;
    /// Members in declaration order.
    fn members() -> Vec<Member>;
}

/// Declares a `#[repr(C)]`, `Pod` struct mirroring a WGSL struct, and
/// implements [`GpuStruct`] for it from the same field list (so the list
/// the layout test checks cannot drift from the struct).
macro_rules! gpu_struct {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident as $wgsl:literal {
            $( $(#[$fmeta:meta])* $fvis:vis $field:ident : $ty:ty ),* $(,)?
        }
    ) => {
        $(#[$meta])*
        #[repr(C)]
        #[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
        $vis struct $name {
            $( $(#[$fmeta])* $fvis $field: $ty ),*
        }

        impl $crate::shaders::layout::GpuStruct for $name {
            const WGSL_NAME: &'static str = $wgsl;
            fn members() -> Vec<$crate::shaders::layout::Member> {
                vec![$( $crate::shaders::layout::Member {
                    name: stringify!($field),
                    offset: std::mem::offset_of!($name, $field),
                } ),*]
            }
        }
    };
}
pub(crate) use gpu_struct;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::deferred::volumes::GpuVolumeParams;
    use crate::render::forward_multipass::LightPair;
    use crate::render::gpu_types::{GpuLight, GpuObject, GpuVertex, GpuView};
    use crate::render::objectspace::atlas::{GpuAtlasEntry, GpuAtlasLevel};
    use crate::render::objectspace::atlas_view::GpuAtlasPages;
    use crate::render::objectspace::resources::GpuParams;
    use crate::render::objectspace::trimap::GpuChartGrid;
    use crate::render::passes::gbuffer::GpuUnproject;
    use crate::render::passes::light_grid::GpuLightGridParams;
    use crate::render::passes::visibility::compute::{GpuRasterParams, GpuResolveParams};
    use crate::shaders::{ShaderLibrary, pass_shaders};
    use wgpu::naga;

    /// Members (name, offset) and size of the WGSL struct called `name` (or
    /// naga_oil's mangled name of it) in any of `modules`.
    fn wgsl_layout(modules: &[naga::Module], name: &str) -> (Vec<Member>, usize) {
        let mangled = format!("{name}X_naga_oil_mod_X");
        for module in modules {
            for (_, ty) in module.types.iter() {
                let Some(ty_name) = ty.name.as_deref() else { continue };
                if ty_name != name && !ty_name.starts_with(&mangled) {
                    continue;
                }
                if let naga::TypeInner::Struct { members, span } = &ty.inner {
                    let members = members
                        .iter()
                        .map(|m| Member { name: m.name.clone().unwrap_or_default().leak(), offset: m.offset as usize })
                        .collect();
                    return (members, *span as usize);
                }
            }
        }
        panic!("no WGSL struct {name} in any pass shader");
    }

    fn check<T: GpuStruct>(modules: &[naga::Module]) {
        let (wgsl, size) = wgsl_layout(modules, T::WGSL_NAME);
        let rust = T::members();
        assert_eq!(rust, wgsl, "{}: Rust members (left) differ from WGSL (right)", T::WGSL_NAME);
        assert_eq!(size_of::<T>(), size, "{}: size", T::WGSL_NAME);
    }

    /// Every host-shared struct matches its WGSL struct member by member.
    #[test]
    fn rust_structs_match_wgsl_member_by_member() {
        let mut library = ShaderLibrary::new().unwrap();
        let modules: Vec<naga::Module> = pass_shaders().into_iter().map(|s| library.compose(s).unwrap()).collect();
        check::<GpuVertex>(&modules);
        check::<GpuObject>(&modules);
        check::<GpuView>(&modules);
        check::<GpuLight>(&modules);
        check::<GpuAtlasLevel>(&modules);
        check::<GpuAtlasEntry>(&modules);
        check::<GpuParams>(&modules);
        check::<GpuAtlasPages>(&modules);
        check::<GpuChartGrid>(&modules);
        check::<LightPair>(&modules);
        check::<GpuLightGridParams>(&modules);
        check::<GpuUnproject>(&modules);
        check::<GpuVolumeParams>(&modules);
        check::<GpuRasterParams>(&modules);
        check::<GpuResolveParams>(&modules);
    }

    gpu_struct! {
        struct Swapped as "AtlasLevel" {
            page_base: u32,
            size: u32,
            tile_base: u32,
            pad: u32,
        }
    }

    /// A struct with the right size but two members swapped is caught.
    #[test]
    #[should_panic(expected = "Rust members (left) differ from WGSL")]
    fn swapped_members_are_caught() {
        let mut library = ShaderLibrary::new().unwrap();
        let modules: Vec<naga::Module> = pass_shaders().into_iter().map(|s| library.compose(s).unwrap()).collect();
        check::<Swapped>(&modules);
    }
}
