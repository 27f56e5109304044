//! The floor plan (docs/architecture.md): `src/`'s root holds only rooms (folders), each room
//! imports only from the floors below its own, and no import circle forms between the modules
//! inside them. A node's imports are its `crate::…` paths outside comments and tests; a circle
//! is a strongly connected component of that graph with more than one module. There is none:
//! a circle that forms fails here (list it in [`KNOWN_CIRCLES`] only with the reason and the
//! cut that would break it).

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

/// `node → nodes it imports` over `src/` (`lib.rs` and `main.rs` excluded: they sit above every
/// floor). With `depth` 1 the nodes are the rooms, the root's folders (`render`, `gpu`, …);
/// with `depth` 2 they are the modules inside them (`render::frame`, `gpu::scene`, …: a room's
/// `mod.rs` is the room itself). A `crate::a::b::…` path names the deepest node it reaches.
fn import_graph(depth: usize) -> BTreeMap<String, BTreeSet<String>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    let node_of = |path: &Path| -> Option<String> {
        let parts: Vec<String> = path
            .strip_prefix(&src)
            .ok()?
            .components()
            .take(depth)
            .map(|c| {
                let name = c.as_os_str().to_str().unwrap_or_default();
                name.strip_suffix(".rs").unwrap_or(name).to_string()
            })
            .filter(|n| n != "mod")
            .collect();
        let first = parts.first()?;
        (first != "lib" && first != "main").then(|| parts.join("::"))
    };
    let nodes: BTreeSet<String> = files.iter().filter_map(|f| node_of(f)).collect();
    let mut graph: BTreeMap<String, BTreeSet<String>> =
        nodes.iter().map(|m| (m.clone(), BTreeSet::new())).collect();
    let mut code = Vec::new();
    let mut test_files = BTreeSet::new();
    for file in &files {
        let text = std::fs::read_to_string(file).expect("read source");
        let (lines, tests) = code_lines(file, &text);
        test_files.extend(tests);
        code.push((file, lines));
    }
    for (file, lines) in code {
        let Some(node) = node_of(file) else {
            continue;
        };
        if test_files.contains(file.as_path()) {
            continue;
        }
        for line in lines {
            for (i, _) in line.match_indices("crate::") {
                let segments: Vec<&str> = line[i + "crate::".len()..]
                    .split("::")
                    .take(depth)
                    .map(|s| {
                        let end = s
                            .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                            .unwrap_or(s.len());
                        &s[..end]
                    })
                    .collect();
                let target = (1..=segments.len())
                    .rev()
                    .map(|n| segments[..n].join("::"))
                    .find(|t| nodes.contains(t));
                if let Some(target) = target {
                    if target != node {
                        graph.get_mut(&node).expect("node").insert(target);
                    }
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

/// The floor of each room, as drawn in docs/architecture.md: a room imports only from lower
/// floors. A new room must be given its floor here (and in the picture).
const FLOORS: &[(&str, u32)] = &[
    ("cli", 7),
    ("app", 6),
    ("tools", 6),
    ("render", 5),
    ("passes", 4),
    ("plan", 4),
    ("reference", 4),
    ("config", 3),
    ("gpu", 2),
    ("photon", 2),
    ("timing", 1),
    ("layout", 0),
    ("output", 0),
    ("scene", 0),
];

#[test]
fn the_root_holds_only_rooms_each_importing_only_from_the_floors_below() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let loose: Vec<String> = std::fs::read_dir(&src)
        .expect("read src")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.is_file())
        .filter_map(|p| p.file_name()?.to_str().map(str::to_string))
        .filter(|n| n != "lib.rs" && n != "main.rs" && !n.starts_with('.'))
        .collect();
    assert!(
        loose.is_empty(),
        "files at the root of src/, not in a room: {loose:?}"
    );
    let floors: BTreeMap<&str, u32> = FLOORS.iter().copied().collect();
    let graph = import_graph(1);
    for (room, imports) in &graph {
        let Some(&floor) = floors.get(room.as_str()) else {
            panic!("the room {room} has no floor in FLOORS (docs/architecture.md)");
        };
        for import in imports {
            let below = floors[import.as_str()];
            assert!(
                below < floor,
                "{room} (floor {floor}) imports {import} (floor {below}): imports point down"
            );
        }
    }
    assert_eq!(graph.len(), FLOORS.len(), "a room in FLOORS is gone");
}

#[test]
fn no_import_circle_forms_between_the_modules_beyond_the_known_ones() {
    let graph = import_graph(2);
    assert!(graph.contains_key("render::frame") && graph.contains_key("plan::bounce_plan"));
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
fn the_frames_parts_the_stats_and_the_pass_names_never_call_up() {
    let graph = import_graph(2);
    // The frame drives its two parts and fills in the stats; none of them calls back up.
    for part in [
        "render::photon_frame",
        "render::translucent_frame",
        "render::stats",
    ] {
        assert!(
            !graph[part].contains("render::frame"),
            "{part}: {:?}",
            graph[part]
        );
    }
    assert!(
        !graph["render::stats"].contains("render::photon_frame"),
        "{:?}",
        graph["render::stats"]
    );
    // Every stage's name is the bottom of everything that names a stage.
    assert!(
        graph["timing::pass_id"].is_empty(),
        "{:?}",
        graph["timing::pass_id"]
    );
    // The reader sees past `#[cfg(test)] mod tests;` at the top of a file: the plan's own
    // imports are found (a reader that stopped there would pass anything).
    for low in ["config::settings", "photon", "scene"] {
        let found = graph["plan"]
            .iter()
            .any(|i| i == low || i.starts_with(&format!("{low}::")));
        assert!(found, "plan: {:?}", graph["plan"]);
    }
}
