//! The import rules between strahl's rooms (docs/architecture.md), read from the source: every
//! path `crate::room::…` (`strahl::room::…` in the command; `super::…`, `self::…` and a
//! declared module's `child::…` resolved) outside comments and test modules is an import of
//! that room.
//!
//! The rooms are the top-level modules of `src/` and the command (`main.rs`, `cli/`); the two
//! backends `accel::embree` and `accel::bvh` are rooms of their own beneath the interface
//! they implement (`accel`), and so is `output::passes`, the list of passes that both the
//! scene's `[output]` settings and the film name, which imports no other room.
//!
//! The rules: no circle of imports between rooms; the accel interface names no backend; the
//! scene imports nothing of the accel, the integrator or the output (but `output::passes`);
//! the integrator imports no backend; `sys` imports no other room; only the command imports
//! the verification tools. Each failure names the file and line of the import at fault.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// An import of room `to` at `file:line`.
#[derive(Clone, Debug)]
struct Import {
    to: String,
    at: String,
}

/// Every `.rs` file under `dir`.
fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            sources(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The module path of the file `rel` (relative to `src/`): `accel/embree/scene.rs` →
/// `[accel, embree, scene]`, `accel/mod.rs` → `[accel]`; the command's files are under `cli`.
fn module_of(rel: &Path) -> Vec<String> {
    let mut parts: Vec<String> = rel.iter().map(|p| p.to_string_lossy().into_owned()).collect();
    let last = parts.pop().unwrap();
    let stem = last.trim_end_matches(".rs");
    if !(stem == "mod" || stem == "lib") {
        parts.push(if stem == "main" { "cli".into() } else { stem.into() });
    }
    parts
}

/// The room a module path lies in.
fn room_of(path: &[String]) -> String {
    match path {
        [a, b, ..] if a == "accel" && (b == "embree" || b == "bvh") => format!("{a}::{b}"),
        [a, b, ..] if a == "output" && b == "passes" => format!("{a}::{b}"),
        [a, ..] => a.clone(),
        [] => "lib".into(),
    }
}

/// The module paths a line names: `crate::a::b` (`strahl::a::b` in the command),
/// `crate::{a, b::c}`, and `super::…`, `self::…` and `child::…` (a module the file declares)
/// resolved from `module`.
fn paths_in(line: &str, root: &str, module: &[String], children: &[String]) -> Vec<Vec<String>> {
    let ident = |s: &str| s.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect::<String>();
    let segments = |mut rest: &str, mut path: Vec<String>| {
        loop {
            let name = ident(rest);
            if name.is_empty() {
                break;
            }
            rest = &rest[name.len()..];
            path.push(name);
            match rest.strip_prefix("::") {
                Some(r) => rest = r,
                None => break,
            }
        }
        path
    };
    let mut found = Vec::new();
    let bytes = line.as_bytes();
    for (i, _) in line.match_indices(&format!("{root}::")) {
        if i > 0 && (bytes[i - 1].is_ascii_alphanumeric() || bytes[i - 1] == b'_') {
            continue;
        }
        let rest = &line[i + root.len() + 2..];
        if let Some(group) = rest.strip_prefix('{') {
            for item in group.split(['}', ',']).map(str::trim) {
                found.push(segments(item, Vec::new()));
            }
        } else {
            found.push(segments(rest, Vec::new()));
        }
    }
    for (i, _) in line.match_indices("super::") {
        if i > 0 && (bytes[i - 1].is_ascii_alphanumeric() || bytes[i - 1] == b'_' || bytes[i - 1] == b':') {
            continue;
        }
        // A `mod.rs` file is its folder's module, so its `super` is the folder's parent.
        let mut base = module.to_vec();
        let mut rest = &line[i..];
        while let Some(r) = rest.strip_prefix("super::") {
            base.pop();
            rest = r;
        }
        found.push(segments(rest, base));
    }
    for name in children.iter().map(String::as_str).chain(["self"]) {
        for (i, _) in line.match_indices(&format!("{name}::")) {
            if i > 0 && (bytes[i - 1].is_ascii_alphanumeric() || bytes[i - 1] == b'_' || bytes[i - 1] == b':') {
                continue;
            }
            let rest = if name == "self" { &line[i + 6..] } else { &line[i..] };
            found.push(segments(rest, module.to_vec()));
        }
    }
    found.retain(|p| !p.is_empty());
    found
}

/// The modules a file declares (`mod name;`, `pub mod name;`).
fn children(text: &str) -> Vec<String> {
    text.lines()
        .filter_map(|l| {
            let l = l.trim_start();
            let l = l.strip_prefix("pub ").or_else(|| l.strip_prefix("pub(crate) ")).unwrap_or(l);
            l.strip_prefix("mod ")?.strip_suffix(';').map(str::to_string)
        })
        .collect()
}

/// Every import between rooms in `src/`, by importing room.
fn imports() -> BTreeMap<String, Vec<Import>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    files.sort();
    let mut out: BTreeMap<String, Vec<Import>> = BTreeMap::new();
    for file in files {
        let rel = file.strip_prefix(&src).unwrap();
        let module = module_of(rel);
        let command = module.first().is_some_and(|m| m == "cli");
        let root = if command { "strahl" } else { "crate" };
        let from = room_of(&module);
        let text = std::fs::read_to_string(&file).unwrap();
        let children = children(&text);
        for (n, line) in text.lines().enumerate() {
            let code = line.trim_start();
            // A test module ends the file (the project's convention); comments import nothing.
            if code.starts_with("#[cfg(test)]") {
                break;
            }
            if code.starts_with("//") {
                continue;
            }
            let code = if code.contains('"') { code } else { code.split("//").next().unwrap_or("") };
            for path in paths_in(code, root, &module, &children) {
                let to = room_of(&path);
                // Paths into the command's own modules, and into std or crates, are not rooms.
                let is_room = src.join(&path[0]).is_dir() || src.join(format!("{}.rs", path[0])).is_file();
                if to != from && is_room && !(command && path[0] == "cli") {
                    let at = format!("src/{}:{}", rel.display(), n + 1);
                    out.entry(from.clone()).or_default().push(Import { to, at });
                }
            }
        }
    }
    out
}

/// The imports of `from` into any of `rooms`, as `file:line → room` lines.
fn offending(all: &BTreeMap<String, Vec<Import>>, from: &str, rooms: &[&str]) -> Vec<String> {
    all.get(from)
        .into_iter()
        .flatten()
        .filter(|i| rooms.contains(&i.to.as_str()))
        .map(|i| format!("{} imports {}", i.at, i.to))
        .collect()
}

#[test]
fn the_rooms_import_no_circle() {
    let all = imports();
    let graph: BTreeMap<&str, BTreeSet<&str>> =
        all.iter().map(|(from, v)| (from.as_str(), v.iter().map(|i| i.to.as_str()).collect())).collect();
    // Depth-first search for a back edge; the circle found is reported with the imports on it.
    fn visit<'a>(
        room: &'a str,
        graph: &BTreeMap<&'a str, BTreeSet<&'a str>>,
        state: &mut BTreeMap<&'a str, bool>,
        stack: &mut Vec<&'a str>,
    ) -> Option<Vec<&'a str>> {
        match state.get(room) {
            Some(true) => return None,
            Some(false) => {
                let start = stack.iter().position(|r| *r == room).unwrap();
                return Some([&stack[start..], &[room]].concat());
            }
            None => {}
        }
        state.insert(room, false);
        stack.push(room);
        for next in graph.get(room).into_iter().flatten() {
            if let Some(circle) = visit(next, graph, state, stack) {
                return Some(circle);
            }
        }
        stack.pop();
        state.insert(room, true);
        None
    }
    let mut state = BTreeMap::new();
    for room in graph.keys() {
        if let Some(circle) = visit(room, &graph, &mut state, &mut Vec::new()) {
            let imports: Vec<String> =
                circle.windows(2).flat_map(|w| offending(&all, w[0], &[w[1]]).into_iter().take(1)).collect();
            panic!("the rooms import each other in a circle: {}\n{}", circle.join(" → "), imports.join("\n"));
        }
    }
    // The rooms are found at all (a parser that sees nothing would pass the rest).
    for (from, to) in [("integrator", "accel"), ("accel::embree", "accel"), ("output", "scene"), ("cli", "job")] {
        assert!(graph.get(from).is_some_and(|t| t.contains(to)), "no import of {to} by {from} found");
    }
}

#[test]
fn the_accel_interface_names_no_backend() {
    let all = imports();
    let bad = offending(&all, "accel", &["accel::embree", "accel::bvh"]);
    assert!(bad.is_empty(), "the Accel interface must not depend on a backend:\n{}", bad.join("\n"));
}

#[test]
fn the_scene_is_plain_data_below_the_accel_integrator_and_output() {
    let all = imports();
    let rooms = ["accel", "accel::embree", "accel::bvh", "integrator", "output", "job", "verify"];
    let bad = offending(&all, "scene", &rooms);
    assert!(bad.is_empty(), "the scene must not import these rooms:\n{}", bad.join("\n"));
}

#[test]
fn the_integrator_knows_only_the_accel_interface() {
    let all = imports();
    let bad = offending(&all, "integrator", &["accel::embree", "accel::bvh", "job", "verify"]);
    assert!(bad.is_empty(), "the integrator must trace through the Accel trait alone:\n{}", bad.join("\n"));
}

#[test]
fn sys_and_the_verification_tools_stay_in_their_places() {
    let all = imports();
    let bad = all.get("sys").into_iter().flatten().map(|i| format!("{} imports {}", i.at, i.to)).collect::<Vec<_>>();
    assert!(bad.is_empty(), "sys must import no other room:\n{}", bad.join("\n"));
    let users: Vec<String> = all
        .iter()
        .filter(|(from, _)| *from != "cli")
        .flat_map(|(from, _)| offending(&all, from, &["verify"]))
        .collect();
    assert!(users.is_empty(), "only the command may use the verification tools:\n{}", users.join("\n"));
}
