//! The library's modules form layers, and no module imports from a layer
//! above its own: `render` builds on `scene` and `shaders`, never the other
//! way round. Read from the sources (no GPU): every `crate::NAME` path in
//! code (comments aside) of a top-level module names a module of its own
//! layer or a lower one.

use std::path::{Path, PathBuf};

/// Top-level modules of `src/`, lowest layer first; modules of one layer
/// may use each other.
const LAYERS: &[&[&str]] = &[
    &["cache_dir", "color", "hash", "memo", "gpu", "metrics", "shaders"],
    &["scene", "materials"],
    &["charts"],
    &["render"],
    &["bench", "reference", "stage"],
    &["experiments", "viewer"],
];

fn layer_of(module: &str) -> Option<usize> {
    LAYERS.iter().position(|layer| layer.contains(&module))
}

fn rust_files(path: &Path, out: &mut Vec<PathBuf>) {
    if path.is_dir() {
        for entry in std::fs::read_dir(path).unwrap() {
            rust_files(&entry.unwrap().path(), out);
        }
    } else if path.is_file() && path.extension().is_some_and(|e| e == "rs") {
        out.push(path.to_path_buf());
    }
}

/// The top-level modules that code in `source` names as `crate::NAME`.
fn crate_paths(source: &str) -> Vec<String> {
    let mut names = Vec::new();
    for line in source.lines() {
        let code = line.split("//").next().unwrap_or("");
        let mut rest = code;
        while let Some(at) = rest.find("crate::") {
            rest = &rest[at + "crate::".len()..];
            let name: String = rest.chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
            assert!(!name.is_empty(), "unparsed `crate::` path (a `crate::{{..}}` group?) in: {line}");
            names.push(name);
        }
    }
    names
}

#[test]
fn no_module_imports_from_a_layer_above_its_own() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut checked = 0;
    let mut wrong = Vec::new();
    for (layer, modules) in LAYERS.iter().enumerate() {
        for module in *modules {
            let mut files = Vec::new();
            rust_files(&src.join(module), &mut files);
            rust_files(&src.join(format!("{module}.rs")), &mut files);
            assert!(!files.is_empty(), "module {module} of LAYERS has no source in src/");
            for file in files {
                let source = std::fs::read_to_string(&file).unwrap();
                for name in crate_paths(&source) {
                    let Some(used) = layer_of(&name) else { continue };
                    checked += 1;
                    if used > layer {
                        wrong.push(format!("{} (layer of {module}) uses crate::{name}", file.display()));
                    }
                }
            }
        }
    }
    assert!(checked > 100, "only {checked} crate paths found: the scan is broken");
    assert!(wrong.is_empty(), "imports against the layers:\n{}", wrong.join("\n"));
}

/// Every top-level module of the library has a layer, so a new module
/// cannot escape the check.
#[test]
fn every_library_module_has_a_layer() {
    let lib = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("src/lib.rs")).unwrap();
    let modules: Vec<&str> =
        lib.lines().filter_map(|l| l.trim().strip_prefix("pub mod ")).map(|m| m.trim_end_matches(';')).collect();
    assert!(modules.len() >= 10, "{modules:?}");
    for module in modules {
        assert!(layer_of(module).is_some(), "src/lib.rs declares `{module}`, which LAYERS in this test does not place");
    }
}

#[test]
fn the_scan_sees_an_upward_import() {
    let names = crate_paths(
        "use crate::render::Renderer; // crate::bench\n/// [`crate::experiments`]\nlet x = crate::scene::load;",
    );
    assert_eq!(names, ["render", "scene"]);
}
