//! Reading and writing the files researchers' test software uses: universal
//! files (UFF datasets 58/58b functions, 55 modes, 15/2411 nodes) and CSV
//! tables of FRFs and modal models. Every reader takes bytes plus a source
//! name and returns an [`IoError`] naming that source and the line or byte
//! offset; nothing here panics on input, prints, or touches the file system.
//!
//! # Which function for what
//!
//! | task | function |
//! |---|---|
//! | any universal file → datasets + warnings | [`read_uff`] → [`UffFile`] |
//! | datasets 58 → FRF sets (coherence attached) | [`frf_sets_from_uff`] |
//! | datasets 55 → modal models | [`modal_models_from_uff`] |
//! | node coordinates (15/2411) | [`UffFile::node_coordinates`] |
//! | the `frf` artifact | [`write_frf_artifact`], [`read_frf_artifact`] |
//! | export | [`write_uff58`] (+ [`uff58_from_frf_sets`]), [`write_uff55`] (+ [`uff55_from_modal_models`]) |
//! | CSV | [`read_frf_csv`], [`write_frf_csv`], [`read_modal_csv`], [`write_modal_csv`] |
//! | choose channels and a band | [`Selection`], [`select_frf_sets`], [`select_functions`] |
//! | physical validity (frequency axis, coherence) | [`check_abscissa`], [`check_frequency`], [`check_coherence`] |
//! | coherence a little outside [0, 1] | [`read_uff_with`], [`read_frf_csv_with`] + [`clamp_coherence`] |
//!
//! Every reader refuses what no measurement can hold — a negative or
//! non-increasing frequency line, a coherence outside [0, 1], NaN or inf —
//! at the value's line ([`validity`]); the `_with` readers take a
//! [`CoherencePolicy`] that accepts coherences to be clamped or ignored
//! (the import's `coherence` param). Every reader checks every count read from a
//! file against the bytes that follow and the memory limit
//! (`--max-memory`) before allocating for it.
//!
//! The UFF record layouts, the 58b header and the artifact's encoding of
//! positions are described in [`uff::ds58`], [`uff::ds58_binary`],
//! [`uff::ds55`], [`uff::ds15_2411`], [`uff::frf_sets`] and [`uff::artifact`].
//!
//! # DOF notation
//!
//! A DOF is written `<node><sign><axis>`: `101+X`, `7-RZ`; axis `X Y Z RX RY
//! RZ` for UFF direction codes 1–6, `S` (no sign) for a scalar DOF (code 0),
//! e.g. `12S`. An FRF channel is `<response>/<reference>`: `101+X/1-Z`.
//!
//! # CSV FRF format (`frf.csv`)
//!
//! ```text
//! # quantity: receptance
//! position,position_label,frequency_hz,re:101+X/1-Z,im:101+X/1-Z,coh:101+X/1-Z
//! 0,wpt=0.250,10,1.25e-6,-3.5e-7,0.98
//! 0,wpt=0.250,10.25,1.31e-6,-3.9e-7,0.97
//! ```
//!
//! - Optional leading `#` lines hold metadata; `# quantity: receptance`
//!   (or `mobility`, `accelerance`) sets the FRF quantity, default receptance.
//! - `frequency_hz` (required): frequency line in Hz, ≥ 0 and strictly
//!   increasing within a position.
//! - `re:<channel>` and `im:<channel>` (in pairs): real and imaginary part of
//!   the FRF in SI units; `coh:<channel>` (optional): coherence γ² in [0, 1].
//! - `position` (optional): 0-based configuration index; without it every row
//!   is position 0. `position_label` (optional): the configuration's label.
//! - A channel that a position did not measure has empty cells in all of
//!   that position's rows. Column order is free.
//! - Numbers are written in the shortest form that reads back bit for bit.
//!
//! # CSV modal formats (`modes.csv`, `mode_shapes.csv`)
//!
//! ```text
//! position,position_label,mode,frequency_hz,damping_ratio
//! 0,wpt=0.250,1,42.5,0.012
//! position,mode,node,direction,real,imag
//! 0,1,101,+X,0.71,0
//! ```
//!
//! - `modes.csv`: `mode` is the 1-based mode number within its position,
//!   `frequency_hz` the undamped natural frequency, `damping_ratio` ζ (an
//!   empty cell: not given, NaN in memory). Every writer writes these
//!   columns; the reader also takes hand-written tables without `position`
//!   (one configuration), `position_label` or `damping_ratio`, and an empty
//!   `mode_shapes.csv` (modes without shapes).
//! - `mode_shapes.csv`: one row per mode and DOF; `direction` is `+X … -RZ`,
//!   `S`, or the UFF code (`-3`); `real`/`imag` the shape coefficient. Every
//!   mode of a position lists the same DOFs; their first-appearance order is
//!   the model's DOF order.

pub mod csv_frf;
pub mod csv_modal;
mod csv_table;
pub mod dof_text;
pub mod error;
pub mod fe;
pub(crate) mod limits;
pub mod select;
pub mod uff;
pub mod validity;

pub use csv_frf::{read_frf_csv, read_frf_csv_with, write_frf_csv};
pub use csv_modal::{read_modal_csv, write_modal_csv, ModalCsv};
pub use dof_text::{format_channel, parse_channel, parse_dof};
pub use error::{IoError, Location, Place};
pub use select::{select_frf_sets, select_functions, DofPattern, Selection};
pub use uff::artifact::{
    read_frf_artifact, read_frf_artifact_scaled, uff58_from_frf_sets, write_frf_artifact,
    write_frf_artifact_scaled,
};
pub use uff::ds15_2411::{NodeTable, UffNode};
pub use uff::ds55::{Uff55, Uff55Mode};
pub use uff::ds58::{
    Abscissa, AxisInfo, ByteOrder, Entity58, FunctionType, NumberText, Ordinate, Precision,
    Storage, Uff58, Uff58Format,
};
pub use uff::frf_sets::{frf_sets_from_uff, FrfImport, FrfImportOptions};
pub use uff::modal_models::{modal_models_from_uff, uff55_from_modal_models, ModalImport};
pub use uff::units::{check_override_labels, UnitsOverride, UNCALIBRATED_LABEL};
pub use uff::{
    read_uff, read_uff_with, write_uff55, write_uff58, UffBlock, UffDataset, UffFile, UffWarning,
};
pub use validity::{
    check_abscissa, check_coherence, check_coherence_with, check_even_abscissa, check_frequency,
    clamp_coherence, CoherenceClamps, CoherencePolicy,
};
