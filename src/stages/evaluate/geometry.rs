//! The `geometry` input of evaluate (and the report): a synthesize stage's
//! model.json (the model file's sensor points, per position) or an import
//! stage's geometry.json (one geometry for every position).

use crate::artifacts::model::ModelJson;
use crate::dynamics::model_file::ModelFile;
use crate::geometry::Geometry;
use crate::stages::StageError;
use std::path::Path;

/// A geometry source.
pub enum Source {
    Model(Box<ModelFile>),
    Fixed(Geometry),
}

impl Source {
    /// The geometry of a position.
    pub fn at(&self, position: u32) -> Option<Geometry> {
        match self {
            Source::Model(spec) => Some(Geometry::from_model_file(spec, position as usize)),
            Source::Fixed(g) => (!g.nodes.is_empty()).then(|| g.clone()),
        }
    }

    /// The model file's vertical axis (`vertical:`, 0–2), if it states one;
    /// a geometry.json states none.
    pub fn vertical(&self) -> Option<usize> {
        match self {
            Source::Model(spec) => spec.vertical.map(|a| a.index()),
            Source::Fixed(_) => None,
        }
    }
}

/// Read a model.json or geometry.json.
pub fn read(path: &Path) -> Result<Source, StageError> {
    let bad = |message: String| StageError::InvalidInput {
        input: "geometry".into(),
        message,
    };
    let bytes =
        std::fs::read(path).map_err(|e| StageError::io("cannot read input `geometry`", e))?;
    let json: serde_json::Value =
        serde_json::from_slice(&bytes).map_err(|e| bad(format!("not JSON: {e}")))?;
    if json.get("yaml").is_some() {
        let model: ModelJson =
            serde_json::from_value(json).map_err(|e| bad(format!("model.json: {e}")))?;
        model
            .schema_version
            .check(
                crate::artifacts::model::FILE,
                crate::artifacts::model::SCHEMA_VERSION,
            )
            .map_err(bad)?;
        return Ok(Source::Model(Box::new(model.spec().map_err(bad)?)));
    }
    if json.get("nodes").is_some() {
        let g: Geometry =
            serde_json::from_value(json).map_err(|e| bad(format!("geometry.json: {e}")))?;
        return Ok(Source::Fixed(g));
    }
    Err(bad(
        "neither a model.json (synthesize `model`) nor a geometry.json (import `geometry`)".into(),
    ))
}
