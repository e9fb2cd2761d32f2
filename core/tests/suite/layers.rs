//! The core's modules import one way: [`LAYERS`] lists the top-level modules lowest first, and
//! a module may use only modules listed before it (and itself). A cycle, or a low module
//! reaching up (the plan importing a peak search), fails here with the file and the line.

use std::path::{Path, PathBuf};

/// The pipeline's layers, lowest first (the table in `lib.rs`'s docs follows it).
const LAYERS: [&str; 12] = [
    "math",
    "plan",
    "candidate",
    "wire",
    "noise",
    "transform",
    "peak",
    "search",
    "block",
    "decoder",
    "baseline",
    "methods",
];

/// Top-level modules `lib.rs` declares.
fn declared_modules(src: &Path) -> Vec<String> {
    let lib = std::fs::read_to_string(src.join("lib.rs")).unwrap();
    let mut modules: Vec<String> = lib
        .lines()
        .filter_map(|l| l.trim().strip_prefix("pub mod "))
        .filter_map(|l| l.strip_suffix(';'))
        .map(str::to_owned)
        .collect();
    modules.sort();
    modules
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The code of a line without its comment (doc links name modules without importing them).
fn code(line: &str) -> &str {
    line.find("//").map_or(line, |i| &line[..i])
}

/// The top-level modules a line of code names through `crate::`, also inside `crate::{…}`
/// groups that continue over the following lines.
fn crate_paths(lines: &[&str], i: usize) -> Vec<String> {
    let mut names = Vec::new();
    let line = code(lines[i]);
    let mut rest = line;
    while let Some(at) = rest.find("crate::") {
        let after = &rest[at + "crate::".len()..];
        if let Some(group) = after.strip_prefix('{') {
            // Gather the group up to its closing brace, over several lines if need be.
            let mut text = group.to_owned();
            let mut j = i;
            while closing_brace(&text).is_none() && j + 1 < lines.len() {
                j += 1;
                text.push_str(code(lines[j]));
            }
            let inner = &text[..closing_brace(&text).unwrap_or(text.len())];
            let mut depth = 0;
            let mut item = String::new();
            for ch in inner.chars().chain([',']) {
                match ch {
                    '{' => depth += 1,
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        let head: String = item
                            .trim()
                            .chars()
                            .take_while(|c| c.is_alphanumeric() || *c == '_')
                            .collect();
                        if !head.is_empty() {
                            names.push(head);
                        }
                        item.clear();
                        continue;
                    }
                    _ => {}
                }
                item.push(ch);
            }
        } else {
            let head: String = after
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            names.push(head);
        }
        rest = after;
    }
    names
}

/// The index of the brace that closes a group whose opening brace precedes `text`.
fn closing_brace(text: &str) -> Option<usize> {
    let mut depth = 0;
    for (i, ch) in text.char_indices() {
        match ch {
            '{' => depth += 1,
            '}' if depth == 0 => return Some(i),
            '}' => depth -= 1,
            _ => {}
        }
    }
    None
}

#[test]
fn modules_import_only_lower_layers() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut listed: Vec<String> = LAYERS.iter().map(|s| s.to_string()).collect();
    listed.sort();
    assert_eq!(
        declared_modules(&src),
        listed,
        "lib.rs's modules and LAYERS differ: place every module in a layer"
    );
    let order: Vec<String> = LAYERS.iter().map(|s| s.to_string()).collect();
    let rank = |name: &str| order.iter().position(|m| m == name);
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut violations = Vec::new();
    for file in &files {
        let relative = file.strip_prefix(&src).unwrap();
        let top = relative
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy()
            .trim_end_matches(".rs")
            .to_owned();
        if top == "lib" {
            continue;
        }
        let own = rank(&top).unwrap_or_else(|| panic!("{top} is not listed in lib.rs"));
        let text = std::fs::read_to_string(file).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        for (i, line) in lines.iter().enumerate() {
            // `super::` from a top-level file is the crate root: it would bypass the check.
            if relative.components().count() == 1 && code(line).contains("super::") {
                let in_test = text[..text.find(line).unwrap_or(0)].contains("#[cfg(test)]");
                if !in_test {
                    violations.push(format!(
                        "{}:{}: super:: from a top-level module",
                        relative.display(),
                        i + 1
                    ));
                }
            }
            for name in crate_paths(&lines, i) {
                match rank(&name) {
                    Some(r) if r > own => violations.push(format!(
                        "{}:{}: `{top}` (layer {own}) uses `{name}` (layer {r}), a higher layer",
                        relative.display(),
                        i + 1
                    )),
                    Some(_) => {}
                    // Re-exports at the root (`crate::Decoder`) hide the layer: name the module.
                    None => violations.push(format!(
                        "{}:{}: `crate::{name}` is not a module path; name the module it lives in",
                        relative.display(),
                        i + 1
                    )),
                }
            }
        }
    }
    assert!(
        violations.is_empty(),
        "modules import upwards (lib.rs order: {}):\n{}",
        order.join(" < "),
        violations.join("\n")
    );
}

#[test]
fn the_checker_sees_grouped_and_nested_imports() {
    let lines = [
        "use crate::{math::sqrt, plan::{Method,",
        "    ScanPlan}};",
        "let x = crate::block::in_guard(1.0); // crate::decoder in a comment",
    ];
    assert_eq!(crate_paths(&lines, 0), ["math", "plan"]);
    assert_eq!(crate_paths(&lines, 2), ["block"]);
}
