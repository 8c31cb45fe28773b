//! The crates' layer maps hold: no module imports from a layer above its own, and no two modules
//! import each other, directly or round a longer loop.
//!
//! The maps are the ones the crate docs state (`core/src/lib.rs`, `host/src/lib.rs`,
//! `host/formats/src/lib.rs`). The check
//! reads every source file, drops comments, and resolves each `crate::a::b` and `super::b` path to
//! the deepest module file it names; `mod` declarations are not imports, `pub use` re-exports are.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// A crate's source folder and its top-level modules, lowest layer first. Modules on one line of
/// the map share a layer.
struct LayerMap {
    src: &'static str,
    layers: &'static [&'static [&'static str]],
}

const CORE: LayerMap = LayerMap {
    src: "core/src",
    layers: &[
        &["math"],
        &["geom"],
        &["accel"],
        &["scene"],
        &["render"],
        &["wire"],
        &["worker"],
    ],
};

const HOST: LayerMap = LayerMap {
    src: "host/src",
    layers: &[
        &["util"],
        &["generate", "output"],
        &["cluster"],
        &["bench", "view"],
        &["cli"],
    ],
};

const FORMATS: LayerMap = LayerMap {
    src: "host/formats/src",
    layers: &[
        &["error", "fs", "limits"],
        &["lines", "polygon"],
        &["config", "datafile", "obj", "hosts", "crease"],
        &["mesh", "nff", "fart"],
        &["convert", "load"],
    ],
};

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the tests crate sits in the workspace")
        .to_path_buf()
}

/// Every `.rs` file under `dir`, with its module path (`["scene", "effects"]`; `mod.rs` and
/// `lib.rs` name their folder).
fn modules(dir: &Path, prefix: &[String], out: &mut Vec<(Vec<String>, PathBuf)>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .expect("source folder readable")
        .map(|e| e.expect("folder entry").path())
        .collect();
    entries.sort();
    for path in entries {
        let name = path
            .file_stem()
            .and_then(|s| s.to_str())
            .expect("UTF-8 file name")
            .to_string();
        if path.is_dir() {
            let mut p = prefix.to_vec();
            p.push(name);
            modules(&path, &p, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            let mut p = prefix.to_vec();
            if name != "mod" && name != "lib" && name != "main" {
                p.push(name);
            }
            out.push((p, path));
        }
    }
}

/// The source without comments and string literals, so doc links and messages are not imports.
fn code_only(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for line in text.lines() {
        let mut in_str = false;
        let mut prev = ' ';
        let mut kept = String::new();
        let chars: Vec<char> = line.chars().collect();
        let mut i = 0;
        while i < chars.len() {
            let c = chars[i];
            if !in_str && c == '/' && chars.get(i + 1) == Some(&'/') {
                break;
            }
            if c == '"' && prev != '\\' {
                in_str = !in_str;
            } else if !in_str {
                kept.push(c);
            }
            prev = c;
            i += 1;
        }
        out.push_str(&kept);
        out.push('\n');
    }
    out
}

/// The paths a file names: `crate::a::b::…`, `super::…` and a `mod.rs`'s `pub use child::…`,
/// resolved against `module`, each as the list of its segments (identifiers only).
fn named_paths(code: &str, module: &[String]) -> Vec<Vec<String>> {
    let parent = &module[..module.len().saturating_sub(1)];
    let mut found = Vec::new();
    for (start, _) in code.char_indices() {
        let rest = &code[start..];
        let boundary = code[..start]
            .chars()
            .next_back()
            .is_none_or(|c| !(c.is_ascii_alphanumeric() || c == '_' || c == ':'));
        let (base, after) = if let Some(r) = rest.strip_prefix("crate::") {
            (Vec::new(), r)
        } else if let Some(r) = rest.strip_prefix("super::") {
            (parent.to_vec(), r)
        } else if let Some(r) = rest.strip_prefix("pub use ") {
            (module.to_vec(), r)
        } else {
            continue;
        };
        if boundary {
            found.push(segments(base, after));
        }
    }
    found
}

/// `base` followed by the identifiers of the path that starts `text`.
fn segments(mut path: Vec<String>, text: &str) -> Vec<String> {
    for seg in text.split("::") {
        let ident: String = seg
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect();
        let whole = ident.len() == seg.len();
        if ident.is_empty() || ident == "crate" || ident == "super" {
            break;
        }
        path.push(ident);
        if !whole {
            break;
        }
    }
    path
}

/// The deepest known module that `path` lies in.
fn owner(path: &[String], known: &BTreeSet<Vec<String>>) -> Option<Vec<String>> {
    (1..=path.len())
        .rev()
        .map(|n| path[..n].to_vec())
        .find(|p| known.contains(p))
}

/// The module graph of a crate: an edge from each module to every module its code names.
fn graph(map: &LayerMap) -> BTreeMap<Vec<String>, BTreeSet<Vec<String>>> {
    let mut files = Vec::new();
    modules(&workspace().join(map.src), &[], &mut files);
    let known: BTreeSet<Vec<String>> = files.iter().map(|(m, _)| m.clone()).collect();
    let mut edges = BTreeMap::new();
    for (module, path) in &files {
        let text = std::fs::read_to_string(path).expect("source readable");
        // Unit tests at the bottom of a file may use anything, and so may a file of test
        // support compiled for tests alone (`#![cfg(test)]`).
        let text = if text.lines().any(|l| l.trim() == "#![cfg(test)]") {
            ""
        } else {
            text.split("#[cfg(test)]").next().unwrap_or_default()
        };
        let mut to = BTreeSet::new();
        for named in named_paths(&code_only(text), module) {
            if let Some(target) = owner(&named, &known) {
                if &target != module && !module.starts_with(&target) {
                    to.insert(target);
                }
            }
        }
        edges.insert(module.clone(), to);
    }
    edges
}

fn layer_of(map: &LayerMap, module: &[String]) -> Option<usize> {
    let top = module.first()?;
    map.layers.iter().position(|l| l.contains(&top.as_str()))
}

fn check_layers(map: &LayerMap) -> Vec<String> {
    let mut wrong = Vec::new();
    let g = graph(map);
    for (from, tos) in &g {
        let Some(lf) = layer_of(map, from) else {
            if !from.is_empty() {
                wrong.push(format!("{}: not on the layer map", from.join("::")));
            }
            continue;
        };
        for to in tos {
            match layer_of(map, to) {
                Some(lt) if lt <= lf => {}
                _ => wrong.push(format!("{} imports {}", from.join("::"), to.join("::"))),
            }
        }
    }
    wrong
}

/// A loop in the module graph, if there is one.
fn find_cycle(g: &BTreeMap<Vec<String>, BTreeSet<Vec<String>>>) -> Option<Vec<String>> {
    fn visit(
        n: &Vec<String>,
        g: &BTreeMap<Vec<String>, BTreeSet<Vec<String>>>,
        state: &mut BTreeMap<Vec<String>, u8>,
        stack: &mut Vec<Vec<String>>,
    ) -> Option<Vec<String>> {
        match state.get(n) {
            Some(2) => return None,
            Some(1) => {
                let at = stack.iter().position(|m| m == n).unwrap_or(0);
                let mut cycle: Vec<String> = stack[at..].iter().map(|m| m.join("::")).collect();
                cycle.push(n.join("::"));
                return Some(cycle);
            }
            _ => {}
        }
        state.insert(n.clone(), 1);
        stack.push(n.clone());
        for m in g.get(n).into_iter().flatten() {
            if let Some(c) = visit(m, g, state, stack) {
                return Some(c);
            }
        }
        stack.pop();
        state.insert(n.clone(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for n in g.keys() {
        if let Some(c) = visit(n, g, &mut state, &mut Vec::new()) {
            return Some(c);
        }
    }
    None
}

#[test]
fn core_modules_import_only_from_their_own_layer_or_below() {
    let wrong = check_layers(&CORE);
    assert!(
        wrong.is_empty(),
        "layer map of core broken:\n{}",
        wrong.join("\n")
    );
}

#[test]
fn core_modules_import_each_other_in_no_loop() {
    let cycle = find_cycle(&graph(&CORE));
    assert_eq!(cycle, None, "an import loop in core");
}

#[test]
fn host_modules_import_only_from_their_own_layer_or_below() {
    let wrong = check_layers(&HOST);
    assert!(
        wrong.is_empty(),
        "layer map of host broken:\n{}",
        wrong.join("\n")
    );
}

#[test]
fn host_modules_import_each_other_in_no_loop() {
    let cycle = find_cycle(&graph(&HOST));
    assert_eq!(cycle, None, "an import loop in host");
}

#[test]
fn format_modules_import_only_from_their_own_layer_or_below() {
    let wrong = check_layers(&FORMATS);
    assert!(
        wrong.is_empty(),
        "layer map of the formats broken:\n{}",
        wrong.join("\n")
    );
}

#[test]
fn format_modules_import_each_other_in_no_loop() {
    let cycle = find_cycle(&graph(&FORMATS));
    assert_eq!(cycle, None, "an import loop in the formats");
}

#[test]
fn only_the_command_line_names_clap() {
    let mut files = Vec::new();
    modules(&workspace().join("host/src"), &[], &mut files);
    let others: Vec<_> = files
        .into_iter()
        .filter(|(module, path)| {
            module.first().is_none_or(|m| m != "cli") && !path.ends_with("main.rs")
        })
        .collect();
    let found = |group: &str| {
        others
            .iter()
            .any(|(m, _)| m.first().is_some_and(|m| m == group))
    };
    assert!(
        found("cluster") && found("bench"),
        "the cluster's and the benchmarks' files are found"
    );
    for (_, path) in others {
        let text = std::fs::read_to_string(&path).expect("source readable");
        let code = code_only(&text);
        assert!(
            !code.contains("clap::") && !code.contains("use clap"),
            "{} uses clap; clap types belong in cli/",
            path.display()
        );
    }
}

#[test]
fn the_check_sees_an_upward_import_and_a_loop() {
    let code =
        code_only("use crate::render::shade::trace; // crate::wire\nlet s = \"crate::worker\";");
    let named = named_paths(&code, &["scene".into(), "model".into()]);
    assert_eq!(named, vec![vec!["render", "shade", "trace"]]);
    let sup = named_paths(
        "use super::camera::Camera;",
        &["scene".into(), "model".into()],
    );
    assert_eq!(sup, vec![vec!["scene", "camera", "Camera"]]);
    let mut g = BTreeMap::new();
    let a = vec!["a".to_string()];
    let b = vec!["b".to_string()];
    g.insert(a.clone(), BTreeSet::from([b.clone()]));
    g.insert(b.clone(), BTreeSet::from([a.clone()]));
    assert_eq!(
        find_cycle(&g),
        Some(vec!["a".into(), "b".into(), "a".into()])
    );
}
