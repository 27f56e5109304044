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

/// The paths a piece of code names from `roots` (`crate`, `super`, `self`, or the library's
/// name as the binary's commands write it), each as its root, how many `super::` it climbs
/// (the first included) and the names after them; a `use` group `a::{b::c, d}` gives one path
/// per item (`a::b::c`, `a::d`), over as many lines as it spans. `r#` and generics aside, this
/// is how `use` and expression paths are written in `src/`.
fn paths_in(code: &str, roots: &[&str]) -> Vec<(String, usize, Vec<String>)> {
    let chars: Vec<char> = code.chars().collect();
    let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let skip_space = |mut i: usize| {
        while i < chars.len() && chars[i].is_whitespace() {
            i += 1;
        }
        i
    };
    let sep = |i: usize| chars.get(i) == Some(&':') && chars.get(i + 1) == Some(&':');
    // The tree of names from `i`: one path per leaf, and where it ends.
    fn tree(
        chars: &[char],
        i: usize,
        ident: &dyn Fn(char) -> bool,
        skip_space: &dyn Fn(usize) -> usize,
        sep: &dyn Fn(usize) -> bool,
    ) -> (Vec<Vec<String>>, usize) {
        let mut i = skip_space(i);
        if chars.get(i) == Some(&'{') {
            let mut out = Vec::new();
            i += 1;
            loop {
                i = skip_space(i);
                match chars.get(i) {
                    None => return (out, i),
                    Some('}') => return (out, i + 1),
                    Some(',') => i += 1,
                    Some(_) => {
                        let (paths, end) = tree(chars, i, ident, skip_space, sep);
                        out.extend(paths);
                        // Past an `as NAME` or anything else up to the item's end.
                        i = end;
                        while i < chars.len() && !matches!(chars[i], ',' | '}') {
                            if chars[i] == '{' {
                                break;
                            }
                            i += 1;
                        }
                    }
                }
            }
        }
        let start = i;
        while i < chars.len() && ident(chars[i]) {
            i += 1;
        }
        let name: String = chars[start..i].iter().collect();
        if name.is_empty() {
            // `*` or the end: the path so far.
            return (vec![Vec::new()], i);
        }
        if sep(i) {
            let (rest, end) = tree(chars, i + 2, ident, skip_space, sep);
            let paths = rest
                .into_iter()
                .map(|mut p| {
                    if name != "self" {
                        p.insert(0, name.clone());
                    }
                    p
                })
                .collect();
            return (paths, end);
        }
        let leaf = if name == "self" { vec![] } else { vec![name] };
        (vec![leaf], i)
    }
    let mut out = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let before_ok = i == 0 || !(ident(chars[i - 1]) || chars[i - 1] == ':');
        let root = roots.iter().find(|r| {
            let r: Vec<char> = r.chars().collect();
            chars[i..].starts_with(&r) && sep(i + r.len())
        });
        match root {
            Some(root) if before_ok => {
                let mut j = i + root.len() + 2;
                let mut climbs = usize::from(*root == "super");
                while chars[j..].starts_with(&['s', 'u', 'p', 'e', 'r']) && sep(j + 5) {
                    climbs += 1;
                    j += 7;
                }
                let (paths, end) = tree(&chars, j, &ident, &skip_space, &sep);
                for path in paths {
                    out.push((root.to_string(), climbs, path));
                }
                i = end.max(i + 1);
            }
            _ => i += 1,
        }
    }
    out
}

/// The names a module's code re-exports (`pub use …;`, `pub(crate) use …;` starting a line),
/// each as the module's path plus the name, mapped to the path it stands for from the crate's
/// root. A path without `crate`, `super` or `self` is relative to the module (`pub use cmd::Cmd`
/// in `gpu` is `gpu::cmd::Cmd`; an external crate's `pub use ash::vk` then names no module of
/// ours and resolves to the re-exporting one); `a as b` re-exports `b`. Globs (`pub use x::*`),
/// `self as b` and a name that re-exports its own module's item (`pub use m::m`, which would
/// rewrite every path through it) are not followed.
fn reexports_in(module: &[String], code: &str) -> BTreeMap<Vec<String>, Vec<String>> {
    let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let mut out = BTreeMap::new();
    let mut rest = code;
    while let Some(line_start) = rest.find(|c: char| !c.is_whitespace()) {
        rest = &rest[line_start..];
        let line_end = rest.find('\n').unwrap_or(rest.len());
        let Some(after) = ["pub use ", "pub(crate) use ", "pub(super) use "]
            .iter()
            .find_map(|p| rest.strip_prefix(p))
        else {
            rest = &rest[line_end..];
            continue;
        };
        let end = after.find(';').unwrap_or(after.len());
        let statement = after[..end].trim();
        rest = &after[end..];
        // `name as alias` pairs, whole identifiers.
        let words: Vec<&str> = statement
            .split(|c: char| !ident(c))
            .filter(|w| !w.is_empty())
            .collect();
        let renames: BTreeMap<&str, &str> = words
            .windows(3)
            .filter(|w| w[1] == "as")
            .map(|w| (w[0], w[2]))
            .collect();
        let rooted = ["crate::", "super::", "self::"]
            .iter()
            .any(|r| statement.starts_with(r));
        let text = if rooted {
            statement.to_string()
        } else {
            format!("self::{statement}")
        };
        for (root, climbs, path) in paths_in(&text, &["crate", "super", "self"]) {
            let Some(leaf) = path.last() else { continue };
            let name = renames.get(leaf.as_str()).copied().unwrap_or(leaf);
            let target: Vec<String> = match root.as_str() {
                "crate" => path.clone(),
                "self" => module.iter().cloned().chain(path.clone()).collect(),
                _ => {
                    let keep = module.len().saturating_sub(climbs);
                    module[..keep].iter().cloned().chain(path.clone()).collect()
                }
            };
            let alias: Vec<String> = module.iter().cloned().chain([name.to_string()]).collect();
            if !target.starts_with(&alias) {
                out.insert(alias, target);
            }
        }
    }
    out
}

/// `path` with every re-exported prefix replaced by what it stands for, until none is left
/// (a chain of re-exports is followed to its end; at most 16 steps).
fn through_reexports(
    mut path: Vec<String>,
    reexports: &BTreeMap<Vec<String>, Vec<String>>,
) -> Vec<String> {
    for _ in 0..16 {
        let found = (1..=path.len())
            .rev()
            .find_map(|n| reexports.get(&path[..n]).map(|to| (n, to)));
        let Some((n, to)) = found else { break };
        path = to
            .iter()
            .cloned()
            .chain(path[n..].iter().cloned())
            .collect();
    }
    path
}

#[test]
fn re_exports_are_read_and_followed_to_the_defining_module() {
    let gpu = vec!["gpu".to_string()];
    let code =
        "pub use cmd::{Cmd, SubCmd as Sub,\n    Shaders};\npub use crate::gpu::device::Gpu;\n\
                }\n#[cfg(unix)]\npub(crate) use super::timing::Clock;\npub use tracker::*;\n\
                pub use uses::Use as U;\npub use own::own;\nuse private::Hidden;\n\
                // pub use commented::Out;";
    let map = reexports_in(&gpu, code);
    let shown: Vec<String> = map
        .iter()
        .map(|(a, t)| format!("{} = {}", a.join("::"), t.join("::")))
        .collect();
    assert_eq!(
        shown,
        [
            "gpu::Clock = timing::Clock",
            "gpu::Cmd = gpu::cmd::Cmd",
            "gpu::Gpu = gpu::device::Gpu",
            "gpu::Shaders = gpu::cmd::Shaders",
            "gpu::Sub = gpu::cmd::SubCmd",
            "gpu::U = gpu::uses::Use",
        ]
    );
    let path = |p: &str| p.split("::").map(str::to_string).collect::<Vec<_>>();
    assert_eq!(
        through_reexports(path("gpu::Cmd::new"), &map),
        path("gpu::cmd::Cmd::new")
    );
    assert_eq!(
        through_reexports(path("gpu::other"), &map),
        path("gpu::other")
    );
}

/// `node → nodes it imports` over `src/` (`lib.rs` and `main.rs` excluded: they sit above every
/// floor). With `depth` 1 the nodes are the rooms, the root's folders (`render`, `gpu`, …);
/// with `depth` 2 they are the modules inside them (`render::frame`, `gpu::scene`, …: a room's
/// `mod.rs` is the room itself). A path (`crate::…`, `super::…` resolved against the file's
/// module, or `ispm::…` in the commands of `cli/`) names the deepest node it reaches, after
/// re-exports are followed ([`through_reexports`]: `crate::gpu::Cmd` names `gpu::cmd`, where
/// `Cmd` is defined, not the room that re-exports it).
fn import_graph(depth: usize) -> BTreeMap<String, BTreeSet<String>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    // A file's module path: `src/render/frame/new.rs` is `render::frame::new`.
    let module_of = |path: &Path| -> Vec<String> {
        let mut parts: Vec<String> = path
            .strip_prefix(&src)
            .expect("under src")
            .components()
            .map(|c| {
                let name = c.as_os_str().to_str().unwrap_or_default();
                name.strip_suffix(".rs").unwrap_or(name).to_string()
            })
            .collect();
        if parts.last().is_some_and(|n| n == "mod") {
            parts.pop();
        }
        parts
    };
    let node_of = |path: &Path| -> Option<String> {
        let module = module_of(path);
        let first = module.first()?;
        (first != "lib" && first != "main").then(|| module[..module.len().min(depth)].join("::"))
    };
    let nodes: BTreeSet<String> = files.iter().filter_map(|f| node_of(f)).collect();
    let mut graph: BTreeMap<String, BTreeSet<String>> =
        nodes.iter().map(|m| (m.clone(), BTreeSet::new())).collect();
    let mut code = Vec::new();
    let mut test_files = BTreeSet::new();
    let mut reexports = BTreeMap::new();
    for file in &files {
        let text = std::fs::read_to_string(file).expect("read source");
        let (lines, tests) = code_lines(file, &text);
        test_files.extend(tests);
        let lines = lines.join("\n");
        // `lib.rs` and `main.rs` are the crate's root module.
        let module = module_of(file);
        let root = module.len() == 1 && (module[0] == "lib" || module[0] == "main");
        reexports.extend(reexports_in(if root { &[] } else { &module }, &lines));
        code.push((file, lines));
    }
    for (file, text) in code {
        let Some(node) = node_of(file) else {
            continue;
        };
        if test_files.contains(file.as_path()) {
            continue;
        }
        let module = module_of(file);
        let roots: &[&str] = if node == "cli" {
            &["crate", "super", "ispm"]
        } else {
            &["crate", "super", "self"]
        };
        for (root, climbs, path) in paths_in(&text, roots) {
            // The path from the crate's root.
            let absolute: Vec<String> = match root.as_str() {
                "crate" | "ispm" => path,
                "self" => module.iter().cloned().chain(path).collect(),
                _ => {
                    let keep = module.len().saturating_sub(climbs);
                    module[..keep].iter().cloned().chain(path).collect()
                }
            };
            let absolute = through_reexports(absolute, &reexports);
            let target = (1..=absolute.len().min(depth))
                .rev()
                .map(|n| absolute[..n].join("::"))
                .find(|t| nodes.contains(t));
            if let Some(target) = target {
                if target != node {
                    graph.get_mut(&node).expect("node").insert(target);
                }
            }
        }
    }
    graph
}

#[test]
fn the_path_reader_follows_groups_lines_and_super() {
    let code =
        "use crate::render::{frame::Renderer, stats,\n    photon_frame::{self, PhotonFrame}};\n\
                let x = crate::gpu::Cmd::new(); use super::super::frame::X; foo::crate::no;";
    let paths = paths_in(code, &["crate", "super"]);
    let shown: Vec<String> = paths
        .iter()
        .map(|(root, climbs, p)| format!("{root}{climbs}:{}", p.join("::")))
        .collect();
    assert_eq!(
        shown,
        [
            "crate0:render::frame::Renderer",
            "crate0:render::stats",
            "crate0:render::photon_frame",
            "crate0:render::photon_frame::PhotonFrame",
            "crate0:gpu::Cmd::new",
            "super2:frame::X",
        ]
    );
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
            let Some(&below) = floors.get(import.as_str()) else {
                panic!("the room {import} has no floor in FLOORS (docs/architecture.md)");
            };
            assert!(
                below < floor,
                "{room} (floor {floor}) imports {import} (floor {below}): imports point down"
            );
        }
    }
    assert_eq!(graph.len(), FLOORS.len(), "a room in FLOORS is gone");
    // The reader found imports at all (one it cannot read would pass anything).
    assert!(graph["render"].contains("passes"), "{:?}", graph["render"]);
    assert!(graph["cli"].contains("render"), "{:?}", graph["cli"]);
}

#[test]
fn no_import_circle_forms_between_the_modules_beyond_the_known_ones() {
    let graph = import_graph(2);
    assert!(graph.contains_key("render::frame") && graph.contains_key("plan::bounce_plan"));
    // Re-exports are followed: `passes/direct.rs` imports `crate::gpu::{Cmd, Gpu, …}`, which
    // `gpu/mod.rs` re-exports from `gpu::cmd` and `gpu::device`.
    for defining in ["gpu::cmd", "gpu::device"] {
        assert!(
            graph["passes::direct"].contains(defining),
            "{:?}",
            graph["passes::direct"]
        );
    }
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
            "a new import circle {c:?} (docs/architecture.md):\n{}",
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

#[test]
fn unsafe_code_lives_only_in_src_gpu() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    let mut found = Vec::new();
    for file in files.iter().filter(|f| !f.starts_with(src.join("gpu"))) {
        let text = std::fs::read_to_string(file).expect("read source");
        // Every line but comments, tests included.
        for (n, line) in text.lines().enumerate() {
            let code = line.trim_start();
            if code.starts_with("//") {
                continue;
            }
            let words = code.split(|c: char| !(c.is_ascii_alphanumeric() || c == '_'));
            if words.into_iter().any(|w| w == "unsafe") {
                found.push(format!("{}:{}", file.display(), n + 1));
            }
        }
    }
    assert!(found.is_empty(), "unsafe outside src/gpu/: {found:?}");
    // The reader sees the unsafe code there is inside src/gpu/.
    let cmd = std::fs::read_to_string(src.join("gpu/cmd.rs")).expect("read gpu/cmd.rs");
    assert!(cmd.contains("unsafe {"), "gpu/cmd.rs without unsafe?");
}
