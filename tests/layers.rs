//! Imports go one way (issue 32): down the layers of ARCHITECTURE.md.
//!
//! Reads every `crate::` and `super::` path in `src/` (in `use` lines and
//! inline, test modules at the end of a file left out: they are shells of
//! their own), resolves each to the unit it names (a top-level module, a
//! kind's folder `kinds/<kind>`, or the registry `src/kinds/mod.rs`), and
//! holds the graph of units against the layers below. It fails on an
//! import from a lower layer to a higher one, and on any circle between
//! units.
//!
//! `cargo test --test suite layers:: -- --nocapture` prints the counts. Set
//! `FRICTIONLAB_LAYERS_ROOT` to another checkout's root to measure it (the
//! counts of an older tree, say); the assertions then apply to it too.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The layers, lowest first: each unit's layer, and what each may import
/// (its own layer and those below). Units not listed are an error, so a new
/// module has to be placed.
const LAYERS: &[(&str, &[&str])] = &[
    (
        "1 foundation: friction core, hand, scenarios, utilities",
        &[
            "friction", "hand", "problem", "parallel", "scenario", "settings", "identify", "lsl",
            "audio", "realtime", "time",
        ],
    ),
    (
        "2 protocol core (kind traits, loader, plan, engine, record)",
        &["protocol"],
    ),
    ("3 devices", &["device"]),
    ("4 the simulated participant", &["participant"]),
    ("5 results folder and crash-safe log", &["results"]),
    ("6 analysis primitives and driver", &["analysis"]),
    ("7 the kinds, one folder each", &["kinds/*"]),
    ("8 the registry", &["registry"]),
    (
        "9 shells: session driver, power, window, command line",
        &[
            "session",
            "power",
            "gui",
            "cli",
            "claims",
            "validation",
            "render",
            "rerender",
            "interrupt",
        ],
    ),
];

/// Layer index of `unit`.
fn layer(unit: &str) -> Option<usize> {
    LAYERS.iter().position(|(_, units)| {
        units
            .iter()
            .any(|u| *u == unit || (*u == "kinds/*" && unit.starts_with("kinds/")))
    })
}

fn src_root() -> PathBuf {
    std::env::var_os("FRICTIONLAB_LAYERS_ROOT").map_or_else(
        || Path::new(env!("CARGO_MANIFEST_DIR")).join("src"),
        |r| PathBuf::from(r).join("src"),
    )
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.filter_map(Result::ok) {
        let p = e.path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The module path of a file under `src/` (`src/a/b.rs` and
/// `src/a/b/mod.rs`: `[a, b]`).
fn module_path(src: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src).unwrap_or(file);
    let mut parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    if let Some(last) = parts.pop() {
        let stem = last.trim_end_matches(".rs").to_owned();
        if stem != "mod" && stem != "lib" && stem != "main" {
            parts.push(stem);
        }
    }
    parts
}

/// The unit an absolute module path names: `kinds/<kind>` for a kind's
/// folder (or file), `registry` for `kinds` itself, else its first segment.
fn unit(src: &Path, path: &[String]) -> Option<String> {
    let first = path.first()?;
    if first == "kinds" {
        if let Some(second) = path.get(1) {
            let kinds = src.join("kinds");
            if kinds.join(second).is_dir() || kinds.join(format!("{second}.rs")).is_file() {
                return Some(format!("kinds/{second}"));
            }
        }
        return Some("registry".to_owned());
    }
    Some(first.clone())
}

/// The code of a file without comments, string and character literals,
/// cut before a test module at its end (`#[cfg(test)]` then `mod tests`).
fn code(text: &str) -> String {
    let text = text
        .find("#[cfg(test)]\nmod tests")
        .or_else(|| text.find("#[cfg(test)]\n#[allow("))
        .map_or(text, |i| &text[..i]);
    let b: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        let next = b.get(i + 1).copied();
        if c == '/' && next == Some('/') {
            while i < b.len() && b[i] != '\n' {
                i += 1;
            }
        } else if c == '/' && next == Some('*') {
            i += 2;
            while i + 1 < b.len() && !(b[i] == '*' && b[i + 1] == '/') {
                i += 1;
            }
            i += 2;
        } else if c == 'r'
            && (next == Some('"') || next == Some('#'))
            && !ident(b.get(i.wrapping_sub(1)))
        {
            // A raw string: r"..." or r#"..."#.
            let mut j = i + 1;
            let mut hashes = 0;
            while b.get(j) == Some(&'#') {
                hashes += 1;
                j += 1;
            }
            if b.get(j) == Some(&'"') {
                j += 1;
                loop {
                    if j >= b.len() {
                        break;
                    }
                    if b[j] == '"' && (0..hashes).all(|k| b.get(j + 1 + k) == Some(&'#')) {
                        j += 1 + hashes;
                        break;
                    }
                    j += 1;
                }
                out.push_str("\"\"");
                i = j;
            } else {
                out.push(c);
                i += 1;
            }
        } else if c == '"' {
            i += 1;
            while i < b.len() && b[i] != '"' {
                if b[i] == '\\' {
                    i += 1;
                }
                i += 1;
            }
            i += 1;
            out.push_str("\"\"");
        } else if c == '\''
            && (b.get(i + 2) == Some(&'\'')
                || (next == Some('\\') && b[i..].iter().skip(2).take(10).any(|&x| x == '\'')))
        {
            // A character literal ('x', '\n', '\u{..}'); a lifetime stays.
            i += 1;
            while i < b.len() && b[i] != '\'' {
                if b[i] == '\\' {
                    i += 1;
                }
                i += 1;
            }
            i += 1;
            out.push_str("' '");
        } else {
            out.push(c);
            i += 1;
        }
    }
    out
}

fn ident(c: Option<&char>) -> bool {
    c.is_some_and(|c| c.is_alphanumeric() || *c == '_')
}

/// The paths a `{...}` group starting at `s[0] == '{'` lists, each as its
/// segments (nested groups expanded), and the group's length.
fn group(s: &[char]) -> (Vec<Vec<String>>, usize) {
    let mut out = Vec::new();
    let mut i = 1;
    let mut current: Vec<String> = Vec::new();
    let mut word = String::new();
    while i < s.len() {
        let c = s[i];
        if c.is_alphanumeric() || c == '_' {
            word.push(c);
        } else if c == ':' {
            if !word.is_empty() {
                current.push(std::mem::take(&mut word));
            }
        } else if c == '{' {
            if !word.is_empty() {
                current.push(std::mem::take(&mut word));
            }
            let (inner, len) = group(&s[i..]);
            for p in inner {
                let mut full = current.clone();
                full.extend(p);
                out.push(full);
            }
            current.clear();
            i += len;
            continue;
        } else if c == ',' || c == '}' {
            if !word.is_empty() {
                current.push(std::mem::take(&mut word));
            }
            if !current.is_empty() {
                out.push(std::mem::take(&mut current));
            }
            if c == '}' {
                return (out, i + 1);
            }
        } else if c.is_whitespace() {
            // `as` renames end a path's segments.
            if word == "as" {
                word.clear();
            }
        }
        i += 1;
    }
    (out, i)
}

/// Every `crate::` and `super::` path in `code`, resolved to absolute
/// module paths, for a file at module path `here`.
fn paths(code: &str, here: &[String]) -> Vec<Vec<String>> {
    let chars: Vec<char> = code.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let at = |word: &str| {
            chars[i..].iter().take(word.len()).copied().eq(word.chars())
                && !ident(i.checked_sub(1).and_then(|j| chars.get(j)))
        };
        let (base, skip): (Vec<String>, usize) = if at("crate::") {
            (Vec::new(), 7)
        } else if at("super::") {
            // The module `super` names: the file's parent module.
            let mut base = here.to_vec();
            base.pop();
            let mut k = i + 7;
            while chars[k..].iter().take(7).copied().eq("super::".chars()) {
                base.pop();
                k += 7;
            }
            (base, k - i)
        } else {
            i += 1;
            continue;
        };
        let mut j = i + skip;
        if chars.get(j) == Some(&'{') {
            let (items, len) = group(&chars[j..]);
            for p in items {
                let mut full = base.clone();
                full.extend(p);
                out.push(full);
            }
            i = j + len;
            continue;
        }
        let mut full = base;
        let mut word = String::new();
        while j < chars.len() {
            let c = chars[j];
            if c.is_alphanumeric() || c == '_' {
                word.push(c);
            } else if c == ':' && chars.get(j + 1) == Some(&':') {
                full.push(std::mem::take(&mut word));
                j += 1;
                if chars.get(j + 1) == Some(&'{') {
                    let (items, len) = group(&chars[j + 1..]);
                    for p in items {
                        let mut f = full.clone();
                        f.extend(p);
                        out.push(f);
                    }
                    j += 1 + len;
                    full.clear();
                    break;
                }
            } else {
                break;
            }
            j += 1;
        }
        if !word.is_empty() {
            full.push(word);
        }
        if !full.is_empty() {
            out.push(full);
        }
        i = j.max(i + 1);
    }
    out
}

/// Imports between units: (from, to) -> (count, files).
type Edges = BTreeMap<(String, String), (usize, BTreeSet<String>)>;

fn edges(src: &Path) -> (Edges, BTreeSet<String>) {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    files.sort();
    let mut edges = Edges::new();
    let mut units = BTreeSet::new();
    for file in files {
        let here = module_path(src, &file);
        if here.is_empty() {
            continue; // lib.rs, main.rs: the crate's root declares the modules.
        }
        let Some(from) = unit(src, &here) else {
            continue;
        };
        units.insert(from.clone());
        let text = std::fs::read_to_string(&file).unwrap_or_default();
        let rel = file
            .strip_prefix(src.parent().unwrap_or(src))
            .unwrap_or(&file)
            .display()
            .to_string();
        for p in paths(&code(&text), &here) {
            let Some(to) = unit(src, &p) else { continue };
            if to == from || to == "self" {
                continue;
            }
            let e = edges.entry((from.clone(), to)).or_default();
            e.0 += 1;
            e.1.insert(rel.clone());
        }
    }
    (edges, units)
}

/// Tarjan's visit of `v`: its component, once complete, goes to `out`.
fn visit<'a>(
    v: &'a str,
    graph: &BTreeMap<&'a str, Vec<&'a str>>,
    index: &mut BTreeMap<&'a str, usize>,
    low: &mut BTreeMap<&'a str, usize>,
    stack: &mut Vec<&'a str>,
    on: &mut BTreeSet<&'a str>,
    out: &mut Vec<Vec<String>>,
) {
    let n = index.len();
    index.insert(v, n);
    low.insert(v, n);
    stack.push(v);
    on.insert(v);
    for &w in &graph[v] {
        if !index.contains_key(w) {
            visit(w, graph, index, low, stack, on, out);
            let lw = low[w];
            low.entry(v).and_modify(|l| *l = (*l).min(lw));
        } else if on.contains(w) {
            let iw = index[w];
            low.entry(v).and_modify(|l| *l = (*l).min(iw));
        }
    }
    if low[v] == index[v] {
        let mut scc = Vec::new();
        while let Some(w) = stack.pop() {
            on.remove(w);
            scc.push(w.to_owned());
            if w == v {
                break;
            }
        }
        if scc.len() > 1 {
            scc.sort();
            out.push(scc);
        }
    }
}

/// The units on circles of the import graph (Tarjan's strongly connected
/// components of more than one unit).
fn circles(edges: &Edges) -> Vec<Vec<String>> {
    let mut graph: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
    for (from, to) in edges.keys() {
        graph.entry(from).or_default().push(to);
        graph.entry(to).or_default();
    }
    let nodes: Vec<&str> = graph.keys().copied().collect();
    let mut index: BTreeMap<&str, usize> = BTreeMap::new();
    let mut low: BTreeMap<&str, usize> = BTreeMap::new();
    let mut stack: Vec<&str> = Vec::new();
    let mut on: BTreeSet<&str> = BTreeSet::new();
    let mut out = Vec::new();
    for v in nodes {
        if !index.contains_key(v) {
            visit(
                v, &graph, &mut index, &mut low, &mut stack, &mut on, &mut out,
            );
        }
    }
    out
}

#[test]
fn imports_go_down_the_layers_with_no_circle() {
    let src = src_root();
    let (edges, units) = edges(&src);
    assert!(
        !edges.is_empty(),
        "no imports found under {}",
        src.display()
    );

    let unplaced: Vec<&String> = units.iter().filter(|u| layer(u).is_none()).collect();
    let upward: Vec<String> = edges
        .iter()
        .filter_map(|((from, to), (n, files))| {
            let (lf, lt) = (layer(from)?, layer(to)?);
            (lt > lf).then(|| {
                format!(
                    "{from} (layer {}) -> {to} (layer {}): {n} in {}",
                    lf + 1,
                    lt + 1,
                    files.iter().cloned().collect::<Vec<_>>().join(", ")
                )
            })
        })
        .collect();
    let circles = circles(&edges);
    let kinds_outside: usize = edges
        .iter()
        .filter(|((from, to), _)| {
            (to == "registry" || to.starts_with("kinds/"))
                && !(from == "registry" || from.starts_with("kinds/"))
        })
        .map(|(_, (n, _))| n)
        .sum();
    let kinds_below: usize = edges
        .iter()
        .filter(|((from, to), _)| {
            (to == "registry" || to.starts_with("kinds/"))
                && layer(from).is_some_and(|l| Some(l) < layer("kinds/x"))
        })
        .map(|(_, (n, _))| n)
        .sum();

    let mut report = format!("imports between units under {}:\n", src.display());
    for ((from, to), (n, _)) in &edges {
        let _ = writeln!(report, "  {from:>24} -> {to:<24} {n}");
    }
    let _ = writeln!(
        report,
        "units: {}; unit pairs with imports: {}; crate::kinds paths outside src/kinds/: {kinds_outside} (from below the kinds: {kinds_below})",
        units.len(),
        edges.len()
    );
    let _ = write!(
        report,
        "circles: {} ({} units on them)",
        circles.len(),
        circles.iter().map(Vec::len).sum::<usize>()
    );
    for c in &circles {
        let _ = write!(report, "\n  {}", c.join(" <-> "));
    }
    let _ = write!(report, "\nupward imports: {}", upward.len());
    for u in &upward {
        let _ = write!(report, "\n  {u}");
    }
    report.push('\n');
    println!("{report}");

    assert!(
        unplaced.is_empty(),
        "units in no layer (place them in LAYERS): {unplaced:?}"
    );
    assert!(
        upward.is_empty(),
        "imports from a lower layer to a higher one:\n{report}"
    );
    assert!(circles.is_empty(), "circles between units:\n{report}");
    assert_eq!(
        kinds_below, 0,
        "a layer below the kinds names one:\n{report}"
    );
}

#[test]
fn the_path_reader_resolves_groups_super_and_the_kinds() {
    let src = src_root();
    let here: Vec<String> = ["kinds", "discrimination", "analysis"]
        .map(String::from)
        .to_vec();
    let text = r#"
use crate::{analysis::{Rows, stats::mean}, protocol};
use super::{Comparison, DiscriminationDesign};
use crate::kinds::paired::PairedTrial;
// use crate::session::Nope;
let s = "crate::gui::Nope";
let x = crate::results::csv::opt(1);
"#;
    let found: Vec<Option<String>> = paths(&code(text), &here)
        .iter()
        .map(|p| unit(&src, p))
        .collect();
    assert_eq!(
        found,
        [
            "analysis",
            "analysis",
            "protocol",
            "kinds/discrimination",
            "kinds/discrimination",
            "kinds/paired",
            "results"
        ]
        .map(|u| Some(u.to_owned()))
    );
    assert_eq!(
        unit(&src, &["kinds".into(), "Registry".into()]),
        Some("registry".into())
    );
}

/// Issue 43: every device is a folder under `src/device/` (a backend,
/// listed in `device::KINDS`); the haptic loop, the seam it drives, the
/// bring-up check (issue 63), the session and the window name none of
/// them.
#[test]
fn the_loop_the_session_and_the_window_name_no_device_backend() {
    let src = src_root();
    let backends: Vec<String> = std::fs::read_dir(src.join("device"))
        .unwrap()
        .filter_map(Result::ok)
        .filter(|e| e.path().join("mod.rs").is_file())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    for kind in frictionlab::device::KINDS {
        assert!(
            backends.iter().any(|b| b == kind.name),
            "the kind {} is a folder src/device/{}/",
            kind.name,
            kind.name
        );
    }
    let mut files = vec![
        src.join("device/haptic.rs"),
        src.join("device/backend.rs"),
        src.join("device/track.rs"),
        src.join("device/check.rs"),
    ];
    rust_files(&src.join("session"), &mut files);
    rust_files(&src.join("gui"), &mut files);
    let (mut into_device, mut named) = (0_usize, Vec::new());
    for file in &files {
        let here = module_path(&src, file);
        let text = std::fs::read_to_string(file).unwrap();
        for p in paths(&code(&text), &here) {
            if p.first().map(String::as_str) != Some("device") {
                continue;
            }
            into_device += 1;
            if p.get(1).is_some_and(|b| backends.contains(b)) {
                named.push(format!("{}: {}", file.display(), p.join("::")));
            }
        }
    }
    println!(
        "backends {backends:?}; {} files of the loop, session and window; {into_device} paths into device, {} naming a backend",
        files.len(),
        named.len()
    );
    assert!(backends.len() >= 3, "{backends:?}");
    assert!(
        into_device > 10,
        "the checked files do use the device layer"
    );
    assert!(named.is_empty(), "{named:#?}");
}
