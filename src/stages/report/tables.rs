//! Report sections shown as they are: any CSV table (first rows, numbers
//! shortened) and any SVG figure or directory of figures.

use crate::report::document::Document;
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
        let rows: Vec<Vec<String>> = lines
            .by_ref()
            .take(MAX_ROWS)
            .map(|l| l.split(',').map(short_number).collect())
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

/// Numbers to 4 significant digits for reading; text as it is.
pub fn short_number(cell: &str) -> String {
    match cell.parse::<f64>() {
        Ok(v) if v.is_finite() && v != v.trunc() => format!("{v:.4e}")
            .parse::<f64>()
            .map_or(cell.to_string(), |r| format!("{r}")),
        _ => cell.to_string(),
    }
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
            let slug = stage.replace(|c: char| !c.is_ascii_alphanumeric(), "_");
            if name.is_empty() {
                doc.figure(stage.clone(), format!("{slug}.svg"), svg);
            } else {
                doc.figure(format!("{stage}: {name}"), format!("{slug}_{name}"), svg);
            }
        }
    }
    Ok(())
}
