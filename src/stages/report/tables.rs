//! Report sections shown as they are: any CSV table (first rows, numbers
//! shortened) and any SVG figure or directory of figures.

use crate::report::document::Document;
use crate::report::format;
use crate::report::svg::caption_of;
use crate::stages::StageError;
use std::path::PathBuf;

/// CSV inputs as tables, each under its `stage.output` name.
pub fn tables(doc: &mut Document, inputs: &[(String, PathBuf)]) -> Result<(), StageError> {
    const MAX_ROWS: usize = 200;
    for (stage, path) in inputs {
        let text = std::fs::read_to_string(path)
            .map_err(|e| StageError::io("cannot read input `csv`", e))?;
        let mut lines = text.lines().filter(|l| !l.trim().is_empty());
        let header: Vec<String> = lines
            .next()
            .unwrap_or_default()
            .split(',')
            .map(str::to_string)
            .collect();
        // p-value columns in scientific notation (style guide rule 7).
        let p_columns: Vec<bool> = header
            .iter()
            .map(|h| matches!(h.trim(), "p" | "p_value" | "pvalue"))
            .collect();
        let rows: Vec<Vec<String>> = lines
            .by_ref()
            .take(MAX_ROWS)
            .map(|l| {
                l.split(',')
                    .enumerate()
                    .map(|(i, c)| format::cell(c, p_columns.get(i).copied().unwrap_or(false)))
                    .collect()
            })
            .collect();
        doc.heading(2, stage.clone());
        doc.table(header, rows);
        let rest = lines.count();
        if rest > 0 {
            doc.paragraph(format!("{rest} more rows in {stage}."));
        }
    }
    Ok(())
}

pub fn figures(doc: &mut Document, inputs: &[(String, PathBuf)]) -> Result<(), StageError> {
    if inputs.is_empty() {
        return Ok(());
    }
    doc.heading(2, "Figures");
    for (stage, path) in inputs {
        let mut files: Vec<PathBuf> = if path.is_dir() {
            std::fs::read_dir(path)
                .map_err(|e| StageError::io("cannot read input `figures`", e))?
                .flatten()
                .map(|e| e.path())
                .filter(|p| p.extension().is_some_and(|x| x == "svg"))
                .collect()
        } else {
            vec![path.clone()]
        };
        files.sort();
        for f in files {
            let svg = std::fs::read_to_string(&f)
                .map_err(|e| StageError::io("cannot read input `figures`", e))?;
            if !svg.contains("<svg") {
                return Err(StageError::InvalidInput {
                    input: "figures".into(),
                    message: format!("{} from {stage} is not an SVG", f.display()),
                });
            }
            // A directory's SVGs keep their file names; a single file is
            // named by its output (`stage.output`).
            let name = if path.is_dir() {
                f.file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default()
            } else {
                String::new()
            };
            // The figure says what it shows in its <desc>; the stage that
            // made it follows in brackets.
            let slug = stage.replace(|c: char| !c.is_ascii_alphanumeric(), "_");
            let caption = |fallback: String| match caption_of(&svg) {
                Some(c) => format!("{c} [{stage}]"),
                None => fallback,
            };
            if name.is_empty() {
                let c = caption(describe(stage, ""));
                doc.figure(c, format!("{slug}.svg"), svg);
            } else {
                let c = caption(describe(stage, &name));
                doc.figure(c, format!("{slug}_{name}"), svg);
            }
        }
    }
    Ok(())
}

/// A caption for a figure that carries none, from what made it.
fn describe(stage: &str, file: &str) -> String {
    let what = if file.starts_with("stabilization") || stage.ends_with(".stabilization") {
        "Stabilization diagram: poles per model order (symbols by class), selected modes ringed, CMIF curves beneath"
    } else if file.starts_with("mac_") {
        "MAC matrix"
    } else if file.starts_with("frf_") {
        "FRF overlay"
    } else {
        "Figure"
    };
    if file.is_empty() {
        format!("{what} [{stage}]")
    } else {
        format!("{what} [{stage}: {file}]")
    }
}
