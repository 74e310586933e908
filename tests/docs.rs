//! The documentation as users read it (issue 29): the README is a short
//! landing page whose set-up is the two commands, its pipeline sample
//! validates, the guide's `kinds` sample is what `modalflow kinds` prints,
//! and every relative link of the README and the guide names a file.

use crate::util::{self, Workspace};
use std::path::Path;

const README: &str = include_str!("../README.md");
const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// Pages other branches add to the guide; the index links them already.
const RESERVED: &[&str] = &["fe-models.md", "screening.md", "uncertainty.md"];

/// The fenced block of `page` that follows the fence line `fence`.
fn block<'a>(page: &'a str, fence: &str) -> &'a str {
    let start = page
        .find(&format!("{fence}\n"))
        .map(|i| i + fence.len() + 1)
        .unwrap_or_else(|| panic!("no {fence} block"));
    let end = page[start..]
        .find("\n```")
        .map_or(page.len(), |e| start + e);
    &page[start..end]
}

#[test]
fn the_readme_is_a_landing_page_with_the_two_commands() {
    let lines = README.lines().count();
    assert!(lines <= 300, "README has {lines} lines");
    assert!(README.contains(
        "```sh\ncargo run --release -- run pipelines/quickstart.yaml\ncargo test --release\n```"
    ));
    for page in ["docs/README.md", "CHANGELOG.md", "docs/studies/README.md"] {
        assert!(README.contains(page), "README links {page}");
    }
}

#[test]
fn the_readme_pipeline_sample_validates() {
    let ws = Workspace::new();
    ws.write("pipelines/quickstart.yaml", block(README, "```yaml"));
    let model = std::fs::read_to_string(format!("{ROOT}/pipelines/models/three_mass.yaml"));
    ws.write("pipelines/models/three_mass.yaml", &model.unwrap());
    let out = ws.cmd(&["validate", "pipelines/quickstart.yaml"]);
    assert_eq!(out.status.code(), Some(0), "{}", util::text(&out.stderr));
}

#[test]
fn the_guides_kinds_sample_is_what_kinds_prints() {
    let page = std::fs::read_to_string(format!("{ROOT}/docs/stage-kinds.md")).unwrap();
    let start = page.find("```\nexport (version").expect("the kinds sample") + 4;
    let end = start + page[start..].find("\n```").unwrap();
    let ws = Workspace::new();
    let out = ws.cmd(&["kinds", "export"]);
    assert_eq!(util::text(&out.stdout).trim_end(), &page[start..end]);
}

/// Relative Markdown links `](target)` of `page` (in `dir`) that name no file.
fn broken_links(dir: &Path, page: &str) -> Vec<String> {
    let mut broken = Vec::new();
    for part in page.split("](").skip(1) {
        let Some(end) = part.find(')') else { continue };
        let target = part[..end].split('#').next().unwrap_or_default();
        if target.is_empty() || target.contains("://") || RESERVED.contains(&target) {
            continue;
        }
        if !dir.join(target).exists() {
            broken.push(target.to_string());
        }
    }
    broken
}

#[test]
fn every_relative_link_of_the_readme_and_the_guide_names_a_file() {
    let root = Path::new(ROOT);
    let mut pages = vec![root.join("README.md"), root.join("CHANGELOG.md")];
    for dir in ["docs", "docs/studies"] {
        for e in std::fs::read_dir(root.join(dir)).unwrap().flatten() {
            if e.path().extension().is_some_and(|x| x == "md") {
                pages.push(e.path());
            }
        }
    }
    for page in pages {
        let text = std::fs::read_to_string(&page).unwrap();
        let dir = page.parent().unwrap();
        let broken = broken_links(dir, &text);
        assert!(broken.is_empty(), "{}: {broken:?}", page.display());
    }
}
