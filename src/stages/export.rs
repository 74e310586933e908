//! The `export` kind: FRFs and modal models in the formats other tools read
//! — UFF 58 (ASCII with the standard fixed-width layout, or 58b), UFF 55,
//! or CSV — so results open in test and FE software.
//!
//! With `to: FOLDER` the files are a declared output below the pipeline
//! directory (like a `command` stage's `outs`): the output is named by the
//! folder, written there after every run or cache hit, and a stage that
//! names a file in it by path (an `import` with `path: FOLDER/frf.uff`)
//! depends on this stage, so export → import works in one pipeline.

use super::{Artifact, InputSpec, Kind, StageContext, StageError, StageOutputs};
use crate::artifacts::modes::{read_modes, read_shape_scaling};
use crate::io::{self, ByteOrder, NumberText, Storage, Uff58Format};

pub struct Export;

crate::string_enum! {
    /// The file formats `export` writes.
    pub enum Format {
        Uff = "uff",
        UffBinary = "uff-binary",
        Csv = "csv",
    }
}

crate::params! {
    /// The `export` kind's params.
    pub struct Params {
        /// uff (ASCII 58 + 55, standard column widths), uff-binary (58b
        /// little-endian + ASCII 55), or csv
        pub format: Format = Format::Uff,
        /// folder below the pipeline directory to write the files to, as
        /// a declared output (the output is then named by it instead of
        /// `files`): an `import` reads them by path, e.g. `to: data/machine`,
        /// then `path: data/machine/frf.uff`
        pub to: Option<String> = None,
    }
}

const INPUTS: &[InputSpec] = &[
    InputSpec {
        name: "frf",
        required: false,
        list: false,
        artifact: Artifact::Frf,
        doc: "an frf artifact (from import or synthesize) to write as FRFs",
    },
    InputSpec {
        name: "modes",
        required: false,
        list: false,
        artifact: Artifact::Modes,
        doc: "a modes artifact to write as a modal model",
    },
];

impl Kind for Export {
    type Params = Params;
    const NAME: &'static str = "export";

    /// 2: dataset 55 per its definition (data type 2/5, shapes in E25.16,
    /// modal mass / modal A of mass-normalized shapes, exact ID line 5).
    /// 3: modes.csv always has the position columns (issue 31); the
    /// uncalibrated mark on FRFs kept in UFF, refused in CSV.
    fn version(&self) -> u32 {
        3
    }

    fn summary(&self) -> &'static str {
        "write FRFs and modes as UFF 58/58b/55 or CSV for other tools"
    }

    fn inputs(&self) -> Option<&'static [InputSpec]> {
        Some(INPUTS)
    }

    /// `files`, or the folder `to` names.
    const OUTPUTS: &'static [(&'static str, Artifact)] = &[("files", Artifact::Any)];

    fn outputs(&self, p: &Params) -> Vec<super::Output> {
        let name = p.to.clone().unwrap_or_else(|| "files".into());
        vec![super::Output::new(name, Artifact::Any)]
    }

    fn workspace_outputs(&self, p: &Params) -> Vec<String> {
        p.to.iter().cloned().collect()
    }

    fn check(&self, p: &Params) -> Vec<super::ParamProblem> {
        let Some(to) = &p.to else {
            return Vec::new();
        };
        match crate::paths::relative(to) {
            Ok(_) => Vec::new(),
            Err(problem) => vec![super::ParamProblem::new(
                &["to"],
                format!("output folder `{}` {problem}", to.escape_debug()),
                "name a folder of the stage's own strictly below the pipeline directory, \
                 e.g. `data/machine`",
            )],
        }
    }

    fn check_inputs(&self, _p: &Params, bound: &[&str]) -> Vec<super::ParamProblem> {
        if bound.is_empty() {
            return vec![super::ParamProblem::new(
                &[],
                "nothing to export",
                "bind an `frf` and/or a `modes` input",
            )];
        }
        Vec::new()
    }

    fn run(&self, p: &Params, ctx: &StageContext) -> Result<StageOutputs, StageError> {
        let format = p.format;
        if !ctx.inputs.contains_key("frf") && !ctx.inputs.contains_key("modes") {
            return Err(StageError::Failed(
                "nothing to export: bind an `frf` and/or a `modes` input".into(),
            ));
        }
        let dir = ctx.scratch.join("export");
        std::fs::create_dir_all(&dir)
            .map_err(|e| StageError::io("cannot create export directory", e))?;
        let write = |name: &str, bytes: &[u8]| {
            std::fs::write(dir.join(name), bytes)
                .map_err(|e| StageError::io(format!("cannot write {name}"), e))
        };
        let failed = |e: io::IoError| StageError::Failed(e.to_string());
        if ctx.inputs.contains_key("frf") {
            let (sets, calibrated) = crate::artifacts::frf::read_scaled(ctx.input("frf")?, "frf")?;
            match format {
                Format::Csv if !calibrated => {
                    return Err(crate::artifacts::frf::uncalibrated_refused(
                        "export",
                        "frf",
                        "CSV format (whose values are SI by definition)",
                    )
                    .into())
                }
                Format::Csv => write("frf.csv", &io::write_frf_csv(&sets).map_err(failed)?)?,
                _ => {
                    let storage = if format == Format::Uff {
                        Storage::Ascii
                    } else {
                        Storage::Binary(ByteOrder::Little)
                    };
                    let fmt = Uff58Format {
                        storage,
                        digits: NumberText::Standard,
                    };
                    let mut datasets = io::uff58_from_frf_sets(&sets);
                    if !calibrated {
                        // The mark modalflow reads back; other tools see the label.
                        for d in &mut datasets {
                            if d.function == io::FunctionType::Frf {
                                d.ordinate_axis.units = io::UNCALIBRATED_LABEL.into();
                                d.denominator_axis.units = "NONE".into();
                            }
                        }
                    }
                    write("frf.uff", &io::write_uff58(&datasets, &fmt))?;
                }
            }
        }
        if ctx.inputs.contains_key("modes") {
            let dir = ctx.input("modes")?;
            let models = read_modes(dir, "modes")?;
            let scaling = read_shape_scaling(dir, "modes")?;
            match format {
                Format::Csv => {
                    let csv = io::write_modal_csv(&models).map_err(failed)?;
                    write("modes.csv", &csv.modes)?;
                    write("mode_shapes.csv", &csv.mode_shapes)?;
                }
                _ => {
                    // Record 10 in E25.16: the shapes exactly (ds55 docs).
                    let ds = io::uff55_from_modal_models(&models, scaling).map_err(failed)?;
                    write("modes.uff", &io::write_uff55(&ds, NumberText::RoundTrip))?;
                }
            }
        }
        Ok(StageOutputs {
            warnings: Vec::new(),
            files: vec![(p.to.clone().unwrap_or_else(|| "files".into()), dir)],
            counters: Default::default(),
        })
    }
}
