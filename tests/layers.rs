//! Module layering (the design notes, "Data flow"): imports between the top-level modules of `src/`
//! run one way only. Read from the sources: every `crate::x` path (also `crate::{x, ..}` and
//! `super::` paths that climb to the crate root) in `src/x.rs` or `src/x/**` is an edge from `x`;
//! `//` and `/* */` comments do not count, nor does anything from a file's first `#[cfg(test)]` on
//! (unit tests may reach across layers).

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::path::{Path, PathBuf};

/// The core, lowest first: a module may import only modules listed before it. (`math` and `rng`
/// are one level, but neither imports the other today, so a strict order does no harm.)
const CORE: [&str; 8] = [
    "math",
    "rng",
    "accel",
    "scene",
    "kernel",
    "transport",
    "ftpd",
    "domain",
];

/// Where an edge was seen first: file and 1-based line.
type Site = (PathBuf, usize);

/// `from → to → first site`, over the top-level modules of `src/` (crate roots excluded).
fn imports() -> BTreeMap<String, BTreeMap<String, Site>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    collect_rs(&src, &mut files);
    files.sort();
    let mut graph: BTreeMap<String, BTreeMap<String, Site>> = BTreeMap::new();
    for file in files {
        let rel = file.strip_prefix(&src).unwrap();
        let mut parts: Vec<String> = rel
            .iter()
            .map(|c| c.to_string_lossy().trim_end_matches(".rs").to_string())
            .collect();
        if parts.len() == 1 && (parts[0] == "lib" || parts[0] == "main") {
            continue;
        }
        if parts.last().is_some_and(|p| p == "mod") {
            parts.pop();
        }
        let top = parts[0].clone();
        let depth = parts.len();
        let text = std::fs::read_to_string(&file).unwrap();
        let code = strip(&text);
        let out = graph.entry(top.clone()).or_default();
        for (line, target) in references(&code, depth) {
            if target != top {
                out.entry(target).or_insert((rel.to_path_buf(), line));
            }
        }
    }
    let known: BTreeSet<String> = graph.keys().cloned().collect();
    for edges in graph.values_mut() {
        edges.retain(|to, _| known.contains(to));
    }
    graph
}

fn collect_rs(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            collect_rs(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The source up to its first `#[cfg(test)]`, with comments blanked (newlines kept, so that line
/// numbers stay right). String literals are not parsed: a `//` inside one only hides the rest of
/// that line, which can hide an import only in contrived code.
fn strip(text: &str) -> String {
    let text = match text.find("#[cfg(test)]") {
        Some(i) => &text[..i],
        None => text,
    };
    let b = text.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i..].starts_with(b"//") {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if b[i..].starts_with(b"/*") {
            let mut nest = 0;
            while i < b.len() {
                if b[i..].starts_with(b"/*") {
                    nest += 1;
                    i += 2;
                } else if b[i..].starts_with(b"*/") {
                    nest -= 1;
                    i += 2;
                    if nest == 0 {
                        break;
                    }
                } else {
                    if b[i] == b'\n' {
                        out.push(b'\n');
                    }
                    i += 1;
                }
            }
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).unwrap()
}

fn is_ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// The top-level modules that `code` (from a module `depth` levels below the crate root) names,
/// with their 1-based lines.
fn references(code: &str, depth: usize) -> Vec<(usize, String)> {
    references_under(code, "", depth)
}

/// The modules directly under the module `under` (a path from the crate root such as `scene::`,
/// empty for the root) that `code` names, from a module `depth` levels below `under`.
fn references_under(code: &str, under: &str, depth: usize) -> Vec<(usize, String)> {
    let mut found = Vec::new();
    for (n, line) in code.lines().enumerate() {
        let chars: Vec<char> = line.chars().collect();
        let mut i = 0;
        while i < chars.len() {
            let starts_word = i == 0 || !is_ident(chars[i - 1]);
            if !starts_word || !is_ident(chars[i]) {
                i += 1;
                continue;
            }
            let mut j = i;
            while j < chars.len() && is_ident(chars[j]) {
                j += 1;
            }
            let word: String = chars[i..j].iter().collect();
            if word == "crate" {
                // crate::x or crate::{x, y::z, ..}
                let rest: String = chars[j..].iter().collect();
                if let Some(rest) = rest.strip_prefix("::").and_then(|r| r.strip_prefix(under)) {
                    let rest = rest.trim_start();
                    if let Some(group) = rest.strip_prefix('{') {
                        for name in group_heads(group) {
                            found.push((n + 1, name));
                        }
                    } else {
                        found.push((n + 1, rest.chars().take_while(|c| is_ident(*c)).collect()));
                    }
                }
            } else if word == "super" {
                // super::super::x climbing to `under`
                let mut k = i;
                let mut ups = 0;
                while chars[k..].starts_with(&['s', 'u', 'p', 'e', 'r', ':', ':']) {
                    ups += 1;
                    k += 7;
                }
                if ups == depth {
                    let name: String = chars[k..].iter().take_while(|c| is_ident(**c)).collect();
                    found.push((n + 1, name));
                }
                j = j.max(k);
            }
            i = j;
        }
    }
    found.retain(|(_, name)| !name.is_empty() && name != "self");
    found
}

/// The first path segment of each item of a `{a, b::c, d::{e, f}}` group (the text after `{`).
fn group_heads(group: &str) -> Vec<String> {
    let mut heads = Vec::new();
    let mut depth = 0;
    let mut at_item = true;
    let mut word = String::new();
    for c in group.chars() {
        if at_item && depth == 0 && is_ident(c) {
            word.push(c);
            continue;
        }
        if !word.is_empty() {
            heads.push(std::mem::take(&mut word));
            at_item = false;
        }
        match c {
            '{' => depth += 1,
            '}' if depth == 0 => break,
            '}' => depth -= 1,
            ',' if depth == 0 => at_item = true,
            _ => {}
        }
    }
    if !word.is_empty() {
        heads.push(word);
    }
    heads
}

/// Strongly connected components with more than one module (Tarjan), each sorted.
fn cycles(graph: &BTreeMap<String, BTreeMap<String, Site>>) -> Vec<Vec<String>> {
    struct T<'a> {
        g: &'a BTreeMap<String, BTreeMap<String, Site>>,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on: BTreeSet<&'a str>,
        out: Vec<Vec<String>>,
    }
    fn visit<'a>(t: &mut T<'a>, v: &'a str) {
        let i = t.index.len();
        t.index.insert(v, i);
        t.low.insert(v, i);
        t.stack.push(v);
        t.on.insert(v);
        for w in t.g[v].keys() {
            let w = w.as_str();
            if !t.index.contains_key(w) {
                visit(t, w);
                let lw = t.low[w];
                let lv = t.low.get_mut(v).unwrap();
                *lv = (*lv).min(lw);
            } else if t.on.contains(w) {
                let iw = t.index[w];
                let lv = t.low.get_mut(v).unwrap();
                *lv = (*lv).min(iw);
            }
        }
        if t.low[v] == t.index[v] {
            let mut comp = Vec::new();
            loop {
                let w = t.stack.pop().unwrap();
                t.on.remove(w);
                comp.push(w.to_string());
                if w == v {
                    break;
                }
            }
            if comp.len() > 1 {
                comp.sort();
                t.out.push(comp);
            }
        }
    }
    let mut t = T {
        g: graph,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in graph.keys() {
        if !t.index.contains_key(v.as_str()) {
            visit(&mut t, v);
        }
    }
    t.out
}

/// A shortest cycle through `start` inside `comp`, as `start → … → start`.
fn cycle_through(
    graph: &BTreeMap<String, BTreeMap<String, Site>>,
    comp: &[String],
    start: &str,
) -> Vec<String> {
    let mut prev: BTreeMap<&str, &str> = BTreeMap::new();
    let mut queue = VecDeque::from([start]);
    while let Some(v) = queue.pop_front() {
        for w in graph[v].keys() {
            let w = w.as_str();
            if !comp.iter().any(|c| c == w) {
                continue;
            }
            if w == start {
                let mut path = vec![start.to_string(), v.to_string()];
                let mut u = v;
                while u != start {
                    u = prev[u];
                    path.push(u.to_string());
                }
                path.reverse();
                return path;
            }
            if !prev.contains_key(w) {
                prev.insert(w, v);
                queue.push_back(w);
            }
        }
    }
    unreachable!("{start} lies on no cycle of {comp:?}")
}

fn site(graph: &BTreeMap<String, BTreeMap<String, Site>>, from: &str, to: &str) -> String {
    let (file, line) = &graph[from][to];
    format!("{from} -> {to} (src/{}:{line})", file.display())
}

#[test]
fn top_level_modules_import_each_other_without_cycles() {
    let graph = imports();
    for m in CORE {
        assert!(graph.contains_key(m), "no module {m} found under src/");
    }
    let found = cycles(&graph);
    let report: Vec<String> = found
        .iter()
        .map(|comp| {
            let path = cycle_through(&graph, comp, &comp[0]);
            let edges: Vec<String> = path
                .windows(2)
                .map(|e| site(&graph, &e[0], &e[1]))
                .collect();
            format!(
                "cycle {} among {{{}}}: {}",
                path.join(" -> "),
                comp.join(", "),
                edges.join("; ")
            )
        })
        .collect();
    assert!(
        report.is_empty(),
        "top-level modules of src/ import each other in a circle:\n{}",
        report.join("\n")
    );
}

#[test]
fn core_modules_import_only_lower_layers() {
    let graph = imports();
    let mut wrong = Vec::new();
    for (level, m) in CORE.iter().enumerate() {
        for to in graph[*m].keys() {
            if let Some(l) = CORE.iter().position(|c| c == to)
                && l > level
            {
                wrong.push(site(&graph, m, to));
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "imports against the layer order {}:\n{}",
        CORE.join(" -> "),
        wrong.join("\n")
    );
}

#[test]
fn the_reader_sees_grouped_super_and_commented_imports_right() {
    let code = strip(
        "use crate::{a::X, b, c::{d, e}};\n// use crate::hidden;\n/* crate::hidden2 */ use \
         super::super::f::G;\n#[cfg(test)]\nuse crate::tested;\n",
    );
    let names: Vec<(usize, String)> = references(&code, 2);
    let names: Vec<(usize, &str)> = names.iter().map(|(l, n)| (*l, n.as_str())).collect();
    assert_eq!(names, [(1, "a"), (1, "b"), (1, "c"), (3, "f")]);
    assert_eq!(references("use super::x;", 1), [(1, "x".to_string())]);
    assert!(references("use super::x;", 2).is_empty());
}

/// The submodules of `src/scene` in the order its module docs give them (the list under
/// "# Module order" in `src/scene/mod.rs`): one level per list item, lowest first.
fn scene_levels() -> Vec<Vec<String>> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/scene/mod.rs");
    let text = std::fs::read_to_string(path).unwrap();
    let mut levels = Vec::new();
    let mut in_order = false;
    for line in text.lines().map_while(|l| l.strip_prefix("//!")) {
        let line = line.trim();
        if line.starts_with('#') {
            in_order = line == "# Module order";
        } else if in_order && let Some(item) = line.strip_prefix("- ") {
            // The names are the backticked words before the dash that starts the description.
            let names = item.split(" — ").next().unwrap();
            let level: Vec<String> = names
                .split('`')
                .skip(1)
                .step_by(2)
                .map(str::to_string)
                .collect();
            levels.push(level);
        }
    }
    levels
}

/// `from → to → first site` over the submodules of `src/scene` (a directory counts as one), and
/// the names from `crate::scene` that are no submodule (the root's re-exports) each names.
fn scene_imports() -> BTreeMap<String, BTreeMap<String, Site>> {
    submodule_imports(&["scene"])
}

/// `from → to → first site` over the children of the directory module `src/<dir>` (a directory
/// counts as one), read from `crate::<dir>::x` and `super::` paths that climb to it; a name of
/// the parent that is no child (a re-export) appears as a target too.
fn submodule_imports(dir: &[&str]) -> BTreeMap<String, BTreeMap<String, Site>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    collect_rs(&dir.iter().fold(src.clone(), |p, d| p.join(d)), &mut files);
    files.sort();
    let under = format!("{}::", dir.join("::"));
    let mut graph: BTreeMap<String, BTreeMap<String, Site>> = BTreeMap::new();
    for file in files {
        let rel = file.strip_prefix(&src).unwrap();
        let mut parts: Vec<String> = rel
            .iter()
            .map(|c| c.to_string_lossy().trim_end_matches(".rs").to_string())
            .collect();
        if parts.last().is_some_and(|p| p == "mod") {
            parts.pop();
        }
        if parts.len() <= dir.len() {
            continue; // the parent: module docs, declarations and re-exports
        }
        let from = parts[dir.len()].clone();
        let code = strip(&std::fs::read_to_string(&file).unwrap());
        let out = graph.entry(from.clone()).or_default();
        for (line, target) in references_under(&code, &under, parts.len() - dir.len()) {
            if target != from {
                out.entry(target).or_insert((rel.to_path_buf(), line));
            }
        }
    }
    graph
}

/// Every directory module below `src/`, as its path of module names.
fn directory_modules(dir: &Path, path: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_dir())
        .collect();
    entries.sort();
    for d in entries {
        path.push(d.file_name().unwrap().to_string_lossy().into_owned());
        if d.join("mod.rs").is_file() {
            out.push(path.clone());
        }
        directory_modules(&d, path, out);
        path.pop();
    }
}

#[test]
fn the_children_of_every_directory_module_import_without_circles() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut dirs = Vec::new();
    directory_modules(&src, &mut Vec::new(), &mut dirs);
    assert!(dirs.len() > 5, "directory modules found: {dirs:?}");
    let mut report = Vec::new();
    for dir in &dirs {
        let names: Vec<&str> = dir.iter().map(String::as_str).collect();
        let graph = submodule_imports(&names);
        let mut children = graph.clone();
        for edges in children.values_mut() {
            edges.retain(|to, _| graph.contains_key(to));
        }
        for comp in cycles(&children) {
            let path = cycle_through(&children, &comp, &comp[0]);
            let edges: Vec<String> = path
                .windows(2)
                .map(|e| site(&children, &e[0], &e[1]))
                .collect();
            report.push(format!("src/{}: {}", dir.join("/"), edges.join("; ")));
        }
    }
    assert!(
        report.is_empty(),
        "submodules import each other in a circle:\n{}",
        report.join("\n")
    );
}

#[test]
fn scene_modules_import_one_way_in_the_documented_order() {
    let levels = scene_levels();
    let graph = scene_imports();
    let level_of = |m: &str| levels.iter().position(|l| l.iter().any(|n| n == m));
    let listed: Vec<&String> = levels.iter().flatten().collect();
    assert!(!listed.is_empty(), "src/scene/mod.rs lists no module order");
    for m in graph.keys() {
        assert!(
            listed.iter().filter(|n| ***n == *m).count() == 1,
            "src/scene/{m} must appear once in the module order of src/scene/mod.rs"
        );
    }
    for m in &listed {
        assert!(
            graph.contains_key(*m),
            "the module order lists scene::{m}, which does not exist"
        );
    }
    let mut wrong = Vec::new();
    for (from, edges) in &graph {
        for to in edges.keys() {
            match (level_of(from), level_of(to)) {
                (_, None) => wrong.push(format!(
                    "{} imports the root's `{to}`: name the module that defines it",
                    site(&graph, from, to)
                )),
                (Some(a), Some(b)) if b >= a => wrong.push(site(&graph, from, to)),
                _ => {}
            }
        }
    }
    let mut modules = graph.clone();
    for edges in modules.values_mut() {
        edges.retain(|to, _| graph.contains_key(to));
    }
    let circles = cycles(&modules);
    assert!(
        wrong.is_empty() && circles.is_empty(),
        "src/scene imports against its module order ({}):\n{}\ncircles: {circles:?}",
        levels
            .iter()
            .map(|l| l.join(" "))
            .collect::<Vec<_>>()
            .join(" < "),
        wrong.join("\n")
    );
}
