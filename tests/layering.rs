//! The crate's layering, read from its source text (as a new engineer
//! would): no stage kind imports another stage kind — they share only the
//! artifacts' schemas (`src/artifacts`), the core and the stage contract —
//! and no two top-level areas of `src/` import each other, directly or
//! through others. Production code only: `#[cfg(test)]` modules may reach
//! across (a test builds its fixtures where they are).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
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

/// The text of a file without comments and without its test modules
/// (from the first `#[cfg(test)]` on; test modules sit at the end).
fn production_code(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap();
    let text = text.split("#[cfg(test)]").next().unwrap_or_default();
    text.lines()
        .map(|l| l.split("//").next().unwrap_or_default())
        .collect::<Vec<_>>()
        .join("\n")
}

/// The module path of a file below `src/` (`stages/identify/outputs.rs` →
/// `[stages, identify, outputs]`; `mod.rs` is its directory's module).
fn module_path(rel: &Path) -> Vec<String> {
    let mut parts: Vec<String> = rel
        .iter()
        .map(|c| c.to_string_lossy().into_owned())
        .collect();
    let last = parts.pop().unwrap_or_default();
    let stem = last.trim_end_matches(".rs");
    if stem != "mod" {
        parts.push(stem.to_string());
    }
    parts
}

/// Every absolute module path a file refers to (`crate::a::b`, and
/// `super::…` resolved against the file's own module path), as the list of
/// its first two segments.
fn references(code: &str, own: &[String]) -> Vec<Vec<String>> {
    let words: Vec<&str> = code
        .split(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
        .filter(|w| w.contains("::"))
        .collect();
    let mut out = Vec::new();
    for w in words {
        let segs: Vec<&str> = w.split("::").filter(|s| !s.is_empty()).collect();
        let (base, rest): (Vec<String>, &[&str]) = match segs.first() {
            Some(&"crate") => (Vec::new(), &segs[1..]),
            Some(&"super") => {
                let ups = segs.iter().take_while(|s| **s == "super").count();
                if ups > own.len() {
                    continue;
                }
                (own[..own.len() - ups].to_vec(), &segs[ups..])
            }
            _ => continue,
        };
        let mut path = base;
        path.extend(rest.iter().map(|s| s.to_string()));
        path.truncate(2);
        out.push(path);
    }
    out
}

/// Modules under `src/stages/` that are not stage kinds: the contract, the
/// params, shared helpers every kind may use.
const SHARED: &[&str] = &["stage", "params", "shard", "limits", "model_files"];

#[test]
fn no_stage_kind_imports_another() {
    let root = src();
    let mut files = Vec::new();
    rust_files(&root.join("stages"), &mut files);
    let mut offences = Vec::new();
    for f in &files {
        let rel = f.strip_prefix(&root).unwrap();
        let own = module_path(rel);
        // The kind a file belongs to (`autoema_tests.rs` is autoema's).
        let Some(kind) = own.get(1).map(|k| k.trim_end_matches("_tests").to_string()) else {
            continue;
        };
        if SHARED.contains(&kind.as_str()) {
            continue;
        }
        for r in references(&production_code(f), &own) {
            if r.len() == 2 && r[0] == "stages" {
                let target = r[1].trim_end_matches("_tests");
                let is_kind = !SHARED.contains(&target)
                    && target.chars().all(|c| c.is_lowercase() || c == '_')
                    && (root.join("stages").join(target).is_dir()
                        || root.join("stages").join(format!("{target}.rs")).is_file());
                if is_kind && target != kind {
                    offences.push(format!("{}: {kind} uses stages::{target}", rel.display()));
                }
            }
        }
    }
    offences.sort();
    offences.dedup();
    assert!(
        offences.is_empty(),
        "stage kinds must share artifacts (src/artifacts) or the core, not each other:\n{}",
        offences.join("\n")
    );
}

#[test]
fn top_level_areas_form_no_cycle() {
    let root = src();
    let mut files = Vec::new();
    rust_files(&root, &mut files);
    let area = |rel: &Path| -> String {
        let first = rel.iter().next().unwrap().to_string_lossy().into_owned();
        first.trim_end_matches(".rs").to_string()
    };
    let areas: BTreeSet<String> = files
        .iter()
        .map(|f| area(f.strip_prefix(&root).unwrap()))
        .filter(|a| a != "lib" && a != "main")
        .collect();
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in &files {
        let rel = f.strip_prefix(&root).unwrap();
        let from = area(rel);
        // The binary's command line sits on top of everything.
        if from == "lib" || from == "main" || from == "cli" {
            continue;
        }
        for r in references(&production_code(f), &module_path(rel)) {
            if let Some(to) = r.first().filter(|t| areas.contains(*t) && **t != from) {
                graph.entry(from.clone()).or_default().insert(to.clone());
            }
        }
    }
    // A cycle: some area reaches itself.
    let reach = |start: &str| -> BTreeSet<String> {
        let mut seen = BTreeSet::new();
        let mut todo: Vec<String> = graph.get(start).into_iter().flatten().cloned().collect();
        while let Some(a) = todo.pop() {
            if seen.insert(a.clone()) {
                todo.extend(graph.get(&a).into_iter().flatten().cloned());
            }
        }
        seen
    };
    let cyclic: Vec<String> = areas
        .iter()
        .filter(|a| reach(a).contains(*a))
        .map(|a| {
            let via: Vec<&String> = graph[a].iter().filter(|b| reach(b).contains(a)).collect();
            format!("{a} → {via:?} → … → {a}")
        })
        .collect();
    assert!(
        cyclic.is_empty(),
        "top-level areas import each other in a cycle:\n{}",
        cyclic.join("\n")
    );
}
