//! Structs whose bytes cross between Rust and WGSL. Each is declared with
//! `gpu_struct!`, which also records its members (name, offset, size), so a
//! test can compare every member, by name, with the layout naga computes for
//! the WGSL struct of the same name (`wgsl_layout` and `check`, test builds only): a swapped,
//! renamed, missing or misaligned field fails, not only a wrong total size.
//! The test that checks every struct of the renderer lives with them, in
//! `render::shader_set`.

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

/// Members (name, offset) and size of the WGSL struct called `name` (or
/// naga_oil's mangled name of it) in any of `modules`.
#[cfg(test)]
pub(crate) fn wgsl_layout(modules: &[wgpu::naga::Module], name: &str) -> (Vec<Member>, usize) {
    let mangled = format!("{name}X_naga_oil_mod_X");
    for module in modules {
        for (_, ty) in module.types.iter() {
            let Some(ty_name) = ty.name.as_deref() else { continue };
            if ty_name != name && !ty_name.starts_with(&mangled) {
                continue;
            }
            if let wgpu::naga::TypeInner::Struct { members, span } = &ty.inner {
                let members = members
                    .iter()
                    .map(|m| Member { name: m.name.clone().unwrap_or_default().leak(), offset: m.offset as usize })
                    .collect();
                return (members, *span as usize);
            }
        }
    }
    panic!("no WGSL struct {name} in any of the modules");
}

/// Asserts that `T` has the members (by name and offset) and the size of
/// its WGSL struct in `modules`.
#[cfg(test)]
pub(crate) fn check<T: GpuStruct>(modules: &[wgpu::naga::Module]) {
    let (wgsl, size) = wgsl_layout(modules, T::WGSL_NAME);
    let rust = T::members();
    assert_eq!(rust, wgsl, "{}: Rust members (left) differ from WGSL (right)", T::WGSL_NAME);
    assert_eq!(size_of::<T>(), size, "{}: size", T::WGSL_NAME);
}

#[cfg(test)]
mod tests {
    use super::*;

    const WGSL: &str = "struct Level { size: u32, page_base: u32, tile_base: u32, scale: f32 }
        @group(0) @binding(0) var<storage> levels: array<Level>;";

    fn modules() -> Vec<wgpu::naga::Module> {
        vec![wgpu::naga::front::wgsl::parse_str(WGSL).unwrap()]
    }

    gpu_struct! {
        struct Level as "Level" {
            size: u32,
            page_base: u32,
            tile_base: u32,
            scale: f32,
        }
    }

    gpu_struct! {
        struct Swapped as "Level" {
            page_base: u32,
            size: u32,
            tile_base: u32,
            scale: f32,
        }
    }

    gpu_struct! {
        struct Short as "Level" {
            size: u32,
            page_base: u32,
            tile_base: u32,
        }
    }

    #[test]
    fn a_matching_struct_passes() {
        check::<Level>(&modules());
    }

    /// A struct with the right size but two members swapped is caught.
    #[test]
    #[should_panic(expected = "Rust members (left) differ from WGSL")]
    fn swapped_members_are_caught() {
        check::<Swapped>(&modules());
    }

    #[test]
    #[should_panic(expected = "Rust members (left) differ from WGSL")]
    fn a_missing_member_is_caught() {
        check::<Short>(&modules());
    }
}
