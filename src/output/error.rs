//! [`OutputError`]: why an output could not be written or read. Each names the file.

use std::path::PathBuf;

/// Why an output could not be written or read back. Each message names the file (or the
/// run's counts) and, where there is one, the fix.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The output directory cannot be created.
    #[error("cannot create {}", dir.display())]
    CreateDir {
        /// The directory.
        dir: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// An exporter failed to write one of its files.
    #[error("writing {file}")]
    Write {
        /// The file name.
        file: String,
        /// Why.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// A temporary file cannot be renamed into place.
    #[error("cannot rename {} to {}", from.display(), to.display())]
    Rename {
        /// The temporary file.
        from: PathBuf,
        /// The final name.
        to: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// An output path without a file name.
    #[error("output path {} has no file name", path.display())]
    NoFileName {
        /// The path.
        path: PathBuf,
    },
    /// Plotting failed (plotters' error, as text).
    #[error("plotting failed: {0}")]
    Plot(String),
    /// Statistics cannot be serialized.
    #[error("cannot serialize {what}")]
    Serialize {
        /// What.
        what: &'static str,
        /// Why.
        #[source]
        source: serde_json::Error,
    },
    /// A snapshot at a cell count the run never passed through.
    #[error(
        "snapshot at {n} cells: the run went from {initial} cells down to {last}; \
         choose counts in that range (lower the stop rule to reach fewer cells)"
    )]
    SnapshotCount {
        /// The count asked for.
        n: usize,
        /// Cells at the start of the run.
        initial: usize,
        /// Cells at its end.
        last: usize,
    },
    /// A snapshot count that the run cannot reach whatever the model (checked before the
    /// run: [`super::check_snapshot_counts`]).
    #[error("snapshot at {n} cells: {reason}; nothing was computed")]
    SnapshotUnreachable {
        /// The count asked for.
        n: usize,
        /// Why.
        reason: String,
    },
    /// The recorded steps do not replay.
    #[error("replaying the recorded steps")]
    Replay(#[source] crate::decimate::ReplayError),
    /// A file cannot be read.
    #[error("cannot read {}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// `result.json` is not a valid result document.
    #[error("bad {}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: serde_json::Error,
    },
    /// `result.json` of another schema or version.
    #[error("{} has schema {schema} v{version}, expected {} v{}", path.display(), super::SCHEMA, super::SCHEMA_VERSION)]
    Schema {
        /// The file.
        path: PathBuf,
        /// Its schema name.
        schema: String,
        /// Its version.
        version: u32,
    },
    /// A `manifest.json` of another schema or version.
    #[error("{} has schema {schema} v{version}, expected {} v{} to v{} (written by another portalfind version: run it again with this one)", path.display(), super::MANIFEST_SCHEMA, super::MANIFEST_VERSION_MIN, super::MANIFEST_VERSION)]
    ManifestSchema {
        /// The file.
        path: PathBuf,
        /// Its schema name.
        schema: String,
        /// Its version.
        version: u32,
    },
    /// The output path exists and is not a directory.
    #[error("{} is not a directory", path.display())]
    NotADirectory {
        /// The path.
        path: PathBuf,
    },
    /// A folder on the output directory's path is a file.
    #[error(
        "cannot use {} as the output directory: {} is a file, not a folder; choose an output \
         directory whose folders are folders",
        path.display(),
        file.display()
    )]
    ParentIsFile {
        /// The output directory asked for.
        path: PathBuf,
        /// Its first component (from the end) that exists and is not a folder.
        file: PathBuf,
    },
    /// The output directory holds files named like outputs that no run of ours wrote.
    #[error(
        "{} already holds {}, which no portalfind run wrote (no manifest.json of ours lists {}); \
         nothing was written: move {} away or choose another output directory",
        dir.display(), files.join(", "), if files.len() == 1 { "it" } else { "them" },
        if files.len() == 1 { "it" } else { "them" }
    )]
    Foreign {
        /// The directory.
        dir: PathBuf,
        /// The files' names.
        files: Vec<String>,
    },
    /// Writing was interrupted (Ctrl-C); what this run had staged was removed.
    #[error("interrupted: the outputs of this run were not written")]
    Interrupted,
    /// The directory holds a run that was stopped while its files were swapped in.
    #[error(
        "{} holds an incomplete run (its manifest.json says so: the run was stopped while \
         writing); run again to replace it",
        dir.display()
    )]
    IncompleteRun {
        /// The directory.
        dir: PathBuf,
    },
    /// A file that its directory's manifest does not list with this content.
    #[error(
        "{} does not match its directory's manifest.json (changed after the run wrote it, \
         or from another run); run again to replace the set",
        path.display()
    )]
    NotInManifest {
        /// The file.
        path: PathBuf,
    },
    /// A directory without a manifest where one is required.
    #[error("{} has no manifest.json (not written by a portalfind run with manifests)", dir.display())]
    NoManifest {
        /// The directory.
        dir: PathBuf,
    },
    /// A file of an earlier run cannot be removed.
    #[error("cannot remove {}", path.display())]
    Remove {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// A bad row of a points file (`locate`).
    #[error("{}:{line}: {message}", path.display())]
    Points {
        /// The file.
        path: PathBuf,
        /// The line (1-based).
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A points file without points.
    #[error("{}: no points (expected x,y,z rows, optionally after a header row)", path.display())]
    NoPoints {
        /// The file.
        path: PathBuf,
    },
}
