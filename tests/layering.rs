//! The layering test (after rust-analyzer's `xtask/src/tidy.rs`): a module may use only
//! modules of a lower layer. The layer table is the one in ARCHITECTURE.md ("Layers");
//! keep the two in step. Test code (`#[cfg(test)]` and below, `tests.rs`, `testutil.rs`)
//! is exempt: tests may use anything.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Layers, bottom first. Modules in one layer may not use each other.
const LAYERS: &[&[&str]] = &[
    &["base"],
    &["ids", "tolerances"],
    &["predicates"],
    &["geom", "model"],
    &["delaunay", "generate"],
    &["complex"],
    &["bsp", "decimate"],
    &["rooms", "visibility"],
    &["output"],
    &["pipeline"],
    &["evaluate"],
    &["experiment", "bench"],
    &["suite"],
];

fn layer_of(module: &str) -> Option<usize> {
    LAYERS.iter().position(|l| l.contains(&module))
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The top-level module a file of `src/` belongs to (`None` for lib.rs and main.rs).
fn module_of(src: &Path, file: &Path) -> Option<String> {
    let rel = file.strip_prefix(src).unwrap();
    let first = rel.components().next()?.as_os_str().to_str()?.to_string();
    let name = first.strip_suffix(".rs").unwrap_or(&first).to_string();
    (name != "lib" && name != "main").then_some(name)
}

/// Top-level modules named as `crate::NAME` in production code of `text`, with lines.
fn uses(text: &str) -> Vec<(String, usize)> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("#[cfg(test)]") {
            break;
        }
        let code = line.split("//").next().unwrap_or("");
        let mut rest = code;
        while let Some(k) = rest.find("crate::") {
            rest = &rest[k + 7..];
            let name: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
            if !name.is_empty() {
                out.push((name, i + 1));
            }
        }
        // `use crate::{a, b}` groups.
        if let Some(k) = code.find("crate::{") {
            for part in code[k + 8..].split(['}', ',']) {
                let name: String = part
                    .trim()
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                if !name.is_empty() {
                    out.push((name, i + 1));
                }
            }
        }
    }
    out
}

#[test]
fn lower_modules_never_use_higher_ones() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.sort();
    let mut unknown = BTreeMap::new();
    let mut violations = Vec::new();
    for f in &files {
        let name = f.file_name().unwrap().to_str().unwrap();
        if name == "tests.rs" || name == "testutil.rs" {
            continue;
        }
        let Some(m) = module_of(&src, f) else { continue };
        let Some(lm) = layer_of(&m) else {
            unknown.insert(m, f.clone());
            continue;
        };
        let text = std::fs::read_to_string(f).unwrap();
        for (used, line) in uses(&text) {
            if used == m {
                continue;
            }
            match layer_of(&used) {
                Some(lu) if lu < lm => {}
                Some(_) => violations.push(format!(
                    "{}:{line}: `{m}` (layer {lm}) uses `{used}` (layer {})",
                    f.display(),
                    layer_of(&used).unwrap()
                )),
                // Re-exports at the crate root (`crate::CellId`, `crate::Tolerances`).
                None if used.chars().next().is_some_and(|c| c.is_uppercase()) => {}
                None => {
                    unknown.insert(used, f.clone());
                }
            }
        }
    }
    assert!(
        unknown.is_empty(),
        "modules missing from the layer table (add them here and in ARCHITECTURE.md): {unknown:?}"
    );
    assert!(violations.is_empty(), "layering violations:\n{}", violations.join("\n"));
}

#[test]
fn the_checker_sees_a_violation() {
    // A file of a low layer naming a higher one must be caught, grouped or not.
    let text =
        "use crate::{base, decimate::Step};\nfn f() { crate::pipeline::run(); }\n#[cfg(test)]\nuse crate::suite;";
    let names: Vec<String> = uses(text).into_iter().map(|(n, _)| n).collect();
    assert!(names.contains(&"decimate".to_string()));
    assert!(names.contains(&"pipeline".to_string()));
    assert!(!names.contains(&"suite".to_string()), "test code is exempt");
    assert!(layer_of("geom") < layer_of("decimate"));
}
