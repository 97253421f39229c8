//! Typed errors of experiments: [`ExperimentError`] (always names the definition file)
//! and [`RunError`] (why a run failed; printed as its chain of causes).

use crate::model::ModelError;
use crate::output::OutputError;
use crate::pipeline::PipelineError;
use std::path::{Path, PathBuf};

/// An experiment that could not be read or run; always names the definition file.
#[derive(Debug, thiserror::Error)]
pub enum ExperimentError {
    /// The definition file (or directory) cannot be read.
    #[error("{}: cannot read: {source}", file.display())]
    Read {
        /// The file.
        file: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// Not valid JSON.
    #[error("{}: not valid JSON: {source}", file.display())]
    Json {
        /// The file.
        file: PathBuf,
        /// The parse error.
        #[source]
        source: serde_json::Error,
    },
    /// A field that the schema does not have.
    #[error("{}: unknown field `{field}` (see experiments/README.md for the schema)", file.display())]
    UnknownField {
        /// The file.
        file: PathBuf,
        /// The field, as a path (`compare_to.foo`, `transforms[1].spin`).
        field: String,
    },
    /// A missing or invalid field.
    #[error("{}: field `{field}`: {message}", file.display())]
    Invalid {
        /// The file.
        file: PathBuf,
        /// The field, as a path.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// Two definitions use the same name (the results directory).
    #[error("{}: experiment name {name:?} is already used by {}", file.display(), other.display())]
    DuplicateName {
        /// The file.
        file: PathBuf,
        /// The name.
        name: String,
        /// The other definition with this name.
        other: PathBuf,
    },
    /// A failure a shard reported (`experiment --shard`), as it printed it; the merge
    /// reports it again with the same text.
    #[error("{message}")]
    Recorded {
        /// The definition file.
        file: PathBuf,
        /// The error as the shard printed it.
        message: String,
    },
    /// The experiment ran and failed.
    #[error("{}: experiment {name:?} failed: {message}", file.display())]
    Failed {
        /// The file.
        file: PathBuf,
        /// The experiment name.
        name: String,
        /// The error chain.
        message: String,
    },
}

impl ExperimentError {
    /// The definition file the error is about.
    pub fn file(&self) -> &Path {
        match self {
            ExperimentError::Read { file, .. }
            | ExperimentError::Json { file, .. }
            | ExperimentError::UnknownField { file, .. }
            | ExperimentError::Invalid { file, .. }
            | ExperimentError::DuplicateName { file, .. }
            | ExperimentError::Recorded { file, .. }
            | ExperimentError::Failed { file, .. } => file,
        }
    }
}

/// Why an experiment run failed. Wrapped in [`ExperimentError::Failed`] with the
/// definition file; each message names the file or the field, and the cause follows.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The results directory cannot be created.
    #[error("cannot create {}", dir.display())]
    CreateDir {
        /// The directory.
        dir: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// `model` names no thesis model.
    #[error("unknown thesis model {name:?}")]
    UnknownThesisModel {
        /// The name.
        name: String,
    },
    /// The model file cannot be loaded.
    #[error("cannot load the model")]
    LoadModel(#[source] Box<ModelError>),
    /// The transformed model is invalid.
    #[error("invalid model {name}")]
    InvalidModel {
        /// The model name.
        name: String,
        /// Why.
        #[source]
        source: Box<ModelError>,
    },
    /// The ground-truth file cannot be read.
    #[error("cannot read truth {}", path.display())]
    ReadTruth {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// The ground-truth file is not valid.
    #[error("bad truth file {}", path.display())]
    BadTruth {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: serde_json::Error,
    },
    /// A doorway of the ground truth names a room that does not exist.
    #[error("truth file {}: a doorway names room {rooms:?} of {count}", path.display())]
    TruthRoom {
        /// The file.
        path: PathBuf,
        /// The doorway's rooms.
        rooms: [usize; 2],
        /// How many rooms there are.
        count: usize,
    },
    /// The pipeline failed.
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
    /// Writing the run's outputs failed.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// A snapshot count the run never passed through.
    #[error("{}: field `snapshots`", file.display())]
    Snapshots {
        /// The definition file.
        file: PathBuf,
        /// Why.
        #[source]
        source: OutputError,
    },
    /// `compare_to` asks for separating portals of an experiment without ground truth.
    #[error("compare_to: experiment {experiment:?} has no ground truth, so no separating portals")]
    NoSeparatingPortals {
        /// The other experiment.
        experiment: String,
    },
    /// `compare_to` names an experiment neither run now nor found in the results.
    #[error("compare_to: experiment {experiment:?} is neither in this run nor in {}", out.display())]
    MissingComparison {
        /// The other experiment.
        experiment: String,
        /// The results directory searched.
        out: PathBuf,
        /// Why its files could not be read.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// An earlier run's `evaluation.json` does not parse.
    #[error("cannot parse {}", path.display())]
    ParseEvaluation {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: serde_json::Error,
    },
    /// An earlier run's `evaluation.json` has no separating portals.
    #[error("compare_to: {} has no separating portals (no ground truth, or an older schema)", path.display())]
    NoSeparatingPortalsIn {
        /// The file.
        path: PathBuf,
    },
    /// The evaluation cannot be serialized.
    #[error("cannot serialize the evaluation")]
    SerializeEvaluation(#[source] serde_json::Error),
    /// A file cannot be written.
    #[error("cannot write {}", path.display())]
    WriteFile {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// The visibility evaluation (`evaluate: true`) failed.
    #[error("visibility evaluation")]
    Evaluate(#[source] Box<crate::evaluate::EvaluateError>),
    /// `summary.csv` cannot be formatted.
    #[error("cannot write summary.csv")]
    SummaryCsv(#[source] Box<dyn std::error::Error + Send + Sync>),
}

/// An error and its causes, joined by `: ` (as the command line prints them).
pub fn chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut cur = e.source();
    while let Some(c) = cur {
        s.push_str(": ");
        s.push_str(&c.to_string());
        cur = c.source();
    }
    s
}
