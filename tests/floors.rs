//! The floor plan (docs/architecture.md): which top-level modules of `src/` import which, and
//! that no new import circle forms. A module's imports are its `crate::NAME` paths outside
//! comments and tests; a circle is a strongly connected component of that graph with more than
//! one module. There is none: a circle that forms fails here (list it in [`KNOWN_CIRCLES`]
//! only with the reason and the cut that would break it).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Circles tolerated, each sorted: none (issue #22 broke the last, the frame's three parts).
const KNOWN_CIRCLES: &[&[&str]] = &[];

/// Every `.rs` file under `dir` (not editors' hidden files).
fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("read src") {
        let path = entry.expect("entry").path();
        let hidden = path
            .file_name()
            .and_then(|n| n.to_str())
            .is_none_or(|n| n.starts_with('.'));
        if hidden {
            continue;
        }
        if path.is_dir() {
            sources(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The lines of `text` that are code outside tests, and the files of the test modules it
/// declares (`#[cfg(test)] mod NAME;`, as paths relative to `file`). An inline
/// `#[cfg(test)] mod NAME {` ends the code (test modules come last); any other item marked
/// `#[cfg(test)]` drops its first line. Comment lines are dropped.
fn code_lines(file: &Path, text: &str) -> (Vec<String>, Vec<PathBuf>) {
    // Where `mod x;` of this file lives: beside a mod.rs/lib.rs, in a folder named after
    // any other file.
    let stem = file
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or_default();
    let dir = file.parent().expect("in src");
    let children = if stem == "mod" || stem == "lib" || stem == "main" {
        dir.to_path_buf()
    } else {
        dir.join(stem)
    };
    let (mut code, mut test_files) = (Vec::new(), Vec::new());
    let mut lines = text.lines().map(str::trim);
    while let Some(line) = lines.next() {
        if line.starts_with("//") {
            continue;
        }
        if line.starts_with("#[cfg(test)]") {
            let next = lines
                .by_ref()
                .find(|l| !l.is_empty() && !l.starts_with("//"));
            let Some(item) = next else { break };
            let item = item.strip_prefix("pub ").unwrap_or(item);
            if let Some(name) = item.strip_prefix("mod ") {
                match name.strip_suffix(';') {
                    Some(name) => test_files.push(children.join(format!("{name}.rs"))),
                    None => break,
                }
            }
            continue;
        }
        code.push(line.to_string());
    }
    (code, test_files)
}

/// `module → modules it imports` over `src/`'s top-level modules (files and folders; `lib.rs`
/// and `main.rs` excluded: they sit above every floor).
fn import_graph() -> BTreeMap<String, BTreeSet<String>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    let module_of = |path: &Path| -> Option<String> {
        let first = path.strip_prefix(&src).ok()?.components().next()?;
        let name = first.as_os_str().to_str()?;
        let name = name.strip_suffix(".rs").unwrap_or(name);
        (name != "lib" && name != "main").then(|| name.to_string())
    };
    let modules: BTreeSet<String> = files.iter().filter_map(|f| module_of(f)).collect();
    let mut graph: BTreeMap<String, BTreeSet<String>> = modules
        .iter()
        .map(|m| (m.clone(), BTreeSet::new()))
        .collect();
    let mut code = Vec::new();
    let mut test_files = BTreeSet::new();
    for file in &files {
        let text = std::fs::read_to_string(file).expect("read source");
        let (lines, tests) = code_lines(file, &text);
        test_files.extend(tests);
        code.push((file, lines));
    }
    for (file, lines) in code {
        let Some(module) = module_of(file) else {
            continue;
        };
        if test_files.contains(file.as_path()) {
            continue;
        }
        for line in lines {
            for (i, _) in line.match_indices("crate::") {
                let rest = &line[i + "crate::".len()..];
                let name: String = rest
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                    .collect();
                if name != module && modules.contains(&name) {
                    graph.get_mut(&module).expect("module").insert(name);
                }
            }
        }
    }
    graph
}

/// The strongly connected components of `graph` with more than one module, each sorted.
fn circles(graph: &BTreeMap<String, BTreeSet<String>>) -> BTreeSet<Vec<String>> {
    // Two modules share a component when each reaches the other.
    let reach = |from: &str| -> BTreeSet<String> {
        let mut seen = BTreeSet::new();
        let mut stack = vec![from.to_string()];
        while let Some(m) = stack.pop() {
            for next in &graph[&m] {
                if seen.insert(next.clone()) {
                    stack.push(next.clone());
                }
            }
        }
        seen
    };
    let reaches: BTreeMap<&String, BTreeSet<String>> =
        graph.keys().map(|m| (m, reach(m))).collect();
    graph
        .keys()
        .map(|a| {
            let mut component: Vec<String> = graph
                .keys()
                .filter(|b| *b == a || (reaches[a].contains(*b) && reaches[*b].contains(a)))
                .cloned()
                .collect();
            component.sort();
            component
        })
        .filter(|c| c.len() > 1)
        .collect()
}

#[test]
fn no_import_circle_forms_between_the_top_level_modules_beyond_the_known_ones() {
    let graph = import_graph();
    assert!(graph.contains_key("frame") && graph.contains_key("plan"));
    let found = circles(&graph);
    let known: BTreeSet<Vec<String>> = KNOWN_CIRCLES
        .iter()
        .map(|c| c.iter().map(|m| m.to_string()).collect())
        .collect();
    let edges = |c: &Vec<String>| {
        c.iter()
            .map(|m| {
                let inside: Vec<&String> = graph[m].iter().filter(|n| c.contains(n)).collect();
                format!("  {m} → {inside:?}")
            })
            .collect::<Vec<_>>()
            .join("\n")
    };
    if let Some(c) = found.difference(&known).next() {
        panic!(
            "a new import circle {c:?} (docs/architecture.md, \"Floors\"):\n{}",
            edges(c)
        );
    }
    if let Some(c) = known.difference(&found).next() {
        panic!("the circle {c:?} is broken: take it off KNOWN_CIRCLES");
    }
}

#[test]
fn the_plan_the_passes_the_settings_and_the_stats_import_nothing_of_the_frame() {
    let graph = import_graph();
    for low in ["settings", "pass_id", "plan", "passes", "stats"] {
        for high in ["frame", "photon_frame", "translucent_frame", "bench"] {
            assert!(
                !graph[low].contains(high),
                "{low} imports {high}: {:?}",
                graph[low]
            );
        }
    }
    // The frame drives its two parts; they never call back up.
    for part in ["photon_frame", "translucent_frame"] {
        assert!(!graph[part].contains("frame"), "{part}: {:?}", graph[part]);
    }
    assert!(!graph["timing"].contains("gpu"), "{:?}", graph["timing"]);
    assert!(graph["pass_id"].is_empty(), "{:?}", graph["pass_id"]);
    // The reader sees past `#[cfg(test)] mod tests;` at the top of a file: the plan's own
    // imports are found (a reader that stopped there would pass anything).
    for low in ["settings", "photon", "scene"] {
        assert!(graph["plan"].contains(low), "plan: {:?}", graph["plan"]);
    }
}
