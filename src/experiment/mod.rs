//! Experiments: the thesis reproduction (issue 5). An experiment definition
//! (`experiments/*.json`, schema in `experiments/README.md`) names a model (a thesis
//! reconstruction from [`crate::generate::thesis`] with its ground truth, or an OBJ/`.mesh`
//! file), optional transforms, the subdivision, heuristic, estimator and stop rule, the
//! thesis's figures for the side-by-side table, and optionally other experiments to compare
//! portals with (the rotation check of thesis 4.3.4): the final portals, or the separating
//! portals of the room-separation state ([`eval::Separation`]).
//!
//! - [`definition`]: the schema and its parser ([`Definition::parse`]; every error names
//!   the file and the field); [`transform`]: the transforms.
//! - [`run_all`] (in `runner.rs`) runs definitions through the library pipeline
//!   ([`crate::pipeline`]); each experiment writes `results/<name>/` with the files of
//!   `portalfind run` ([`crate::output::write_outputs`]) and `evaluation.json`
//!   ([`eval::Evaluation`]); a whole directory also gets `results/summary.csv` and
//!   `results/README.md` ([`report`]). A failing experiment is reported as an
//!   [`ExperimentError`] naming its file; the others still run.
//! - [`eval`]: the evaluation against the ground truth.
//! - [`shard`]: `--shard I/N` (a deterministic subset per shard, its own record) and
//!   `--merge` (`summary.csv` and `README.md` from the shards' outputs).
//! - Visibility (`evaluate: true` or `--evaluate`): [`crate::evaluate`] on the final
//!   partition, `visibility.json` per experiment, summarised in `evaluation.json`,
//!   `summary_visibility.csv` and the README.

pub mod definition;
mod error;
pub mod eval;
pub mod report;
mod runner;
pub mod shard;
pub mod transform;

pub use crate::pipeline::Subdivision;
pub use definition::{
    COMPARE_FIELDS, CompareTo, DEFAULT_AREA_TOLERANCE, DEFAULT_DISTANCE_TOLERANCE, Definition, FIELDS, ModelSource,
    PortalSet, TRANSFORM_KINDS, definition_files, read_definitions,
};
pub use error::{ExperimentError, RunError, chain};
pub use runner::{
    EVALUATION_FILE, Outcome, Report, RunOptions, TIMINGS_FILE, default_evaluate_settings, load_model, run_all,
    run_experiment, run_experiment_with,
};
pub use shard::{Shard, merge};
pub use transform::{Transform, apply_all, invert_all, length_factor};
