//! Constants that WGSL shares with Rust, generated from their Rust
//! definitions as the composable module `shadespace::contract`, so the two
//! sides cannot disagree (WGSL files import them by name instead of
//! repeating the values). The layers above list the constants
//! (`render::shader_set::contract_constants`); this module writes the WGSL.

use std::fmt::Write;

/// The WGSL source of `shadespace::contract` declaring `constants`
/// (name, value) as `u32` constants.
pub fn wgsl(constants: &[(&str, u32)]) -> String {
    let mut s = String::from(
        "// Generated from the Rust definitions (src/render/shader_set.rs); do not edit.\n\
         #define_import_path shadespace::contract\n\n",
    );
    for (name, value) in constants {
        writeln!(s, "const {name}: u32 = {value}u;").expect("writing to a String");
    }
    s
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_constant_is_declared_with_its_value() {
        let s = super::wgsl(&[("A", 1), ("B_C", 4_000_000)]);
        assert!(s.contains("#define_import_path shadespace::contract\n"));
        assert!(s.contains("const A: u32 = 1u;\n"), "{s}");
        assert!(s.contains("const B_C: u32 = 4000000u;\n"), "{s}");
    }
}
