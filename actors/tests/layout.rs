//! The crate's module graph has no import circle outside `supervision/`: each module can be
//! read knowing only the ones below it. Checked on the sources, so a new `use` that closes a
//! circle fails here.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Module (top-level name under `src/`) -> the top-level modules its code names as `crate::x`.
fn imports() -> BTreeMap<String, BTreeSet<String>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let mut stack = vec![src.clone()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).expect("read src") {
            let path = entry.expect("entry").path();
            if path.is_dir() {
                stack.push(path);
                continue;
            }
            let rel = path.strip_prefix(&src).expect("under src").to_string_lossy().replace('\\', "/");
            let module = rel.trim_end_matches(".rs").split('/').next().unwrap_or_default().to_string();
            let text = std::fs::read_to_string(&path).expect("read source");
            // Tests may look anywhere; comments are not imports.
            let code = text.split("#[cfg(test)]").next().unwrap_or_default();
            let deps = graph.entry(module.clone()).or_default();
            for line in code.lines().filter(|l| !l.trim_start().starts_with("//")) {
                for part in line.split("crate::").skip(1) {
                    let name: String =
                        part.chars().take_while(|c| c.is_ascii_lowercase() || *c == '_').collect();
                    if !name.is_empty() && name != module {
                        deps.insert(name);
                    }
                }
            }
        }
    }
    graph
}

/// A circle through `start`, if any (depth-first).
fn circle(graph: &BTreeMap<String, BTreeSet<String>>, start: &str) -> Option<Vec<String>> {
    fn walk(
        graph: &BTreeMap<String, BTreeSet<String>>,
        start: &str,
        path: &mut Vec<String>,
        seen: &mut BTreeSet<String>,
    ) -> bool {
        let Some(last) = path.last().cloned() else { return false };
        for next in graph.get(&last).into_iter().flatten() {
            if next == start {
                return true;
            }
            if next != "supervision" && seen.insert(next.clone()) {
                path.push(next.clone());
                if walk(graph, start, path, seen) {
                    return true;
                }
                path.pop();
            }
        }
        false
    }
    let mut path = vec![start.to_string()];
    walk(graph, start, &mut path, &mut BTreeSet::new()).then_some(path)
}

#[test]
fn no_module_outside_supervision_imports_itself_in_a_circle() {
    let graph = imports();
    assert!(graph.contains_key("addr") && graph.contains_key("registry"), "{:?}", graph.keys());
    assert!(graph["registry"].contains("addr"), "the graph is read: registry uses addr");
    for module in graph.keys().filter(|m| *m != "supervision") {
        if let Some(c) = circle(&graph, module) {
            panic!("import circle: {} -> {module}", c.join(" -> "));
        }
    }
}
