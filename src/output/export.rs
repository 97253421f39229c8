//! The exporter extension point: an [`Exporter`] writes one kind of output file from an
//! [`ExportContext`]; [`exporters`] lists them. To add a format, write one file with a
//! type implementing [`Exporter`] and add one line to [`exporters`].

use super::{OutputError, ResultDoc, Snapshot};
use crate::complex::CellComplex;
use crate::decimate::Decimation;
use crate::model::Model;
use std::path::{Path, PathBuf};

/// What an exporter may read: the run and where to write.
pub struct ExportContext<'a> {
    /// The output directory (exists).
    pub dir: &'a Path,
    /// The model.
    pub model: &'a Model,
    /// The result document (`result.json`).
    pub doc: &'a ResultDoc,
    /// The decimation (steps, settings).
    pub dec: &'a Decimation,
    /// Intermediate states to draw (from [`super::snapshot`]).
    pub snapshots: &'a [(Snapshot, ResultDoc)],
    /// The cell complex (the convex pieces' polyhedra, patches, portals), when the caller
    /// passed it ([`super::write_outputs_exporting`]); the opt-in exporters need it.
    pub cx: Option<&'a CellComplex>,
    /// The opt-in formats requested ([`Exporter::opt_in`] names, e.g. `run --export prt,obj`).
    pub export: &'a [String],
    /// Annotations for the pictures ([`super::Notes`]).
    pub notes: super::Notes<'a>,
    /// Leave timings out of `result.json` ([`super::SetOptions::strip_timings`]).
    pub strip_timings: bool,
    /// Manifest entries of files the exporters hashed while writing them
    /// ([`super::HashingWriter`]), by final path; the others are read back and hashed.
    pub hashed: &'a std::sync::Mutex<Vec<(PathBuf, super::FileEntry)>>,
}

impl ExportContext<'_> {
    /// The cell complex, or an error naming `file` when the caller did not pass it.
    pub fn complex(&self, file: &str) -> Result<&CellComplex, OutputError> {
        self.cx.ok_or_else(|| OutputError::Write {
            file: file.to_string(),
            source: "this export needs the cell complex (write_outputs_exporting)".into(),
        })
    }
}

/// One output format. Exporters are `Send + Sync` (they hold no state): a set's exporters
/// write their files in parallel.
pub trait Exporter: Send + Sync {
    /// A short name (for messages).
    fn name(&self) -> &'static str;

    /// The file names it writes for this run, in the order [`Exporter::write`] returns them.
    fn files(&self, ctx: &ExportContext<'_>) -> Vec<String>;

    /// Whether `file_name` is a name this exporter writes for some run: such a file in an
    /// output directory that no manifest lists makes a run refuse, and in output written
    /// before manifests existed it is taken for the earlier run's.
    fn owns(&self, file_name: &str) -> bool;

    /// Taken after every other exporter (`result.json`, which `locate` reads, so that it
    /// exists only beside a complete set): its files come last in the set's order, and an
    /// earlier exporter's error is reported first. It is written in parallel with the
    /// others, started first (into the staging directory, which a failed set removes).
    fn last(&self) -> bool {
        false
    }

    /// `Some(name)`: an opt-in format, written only when `name` is among
    /// [`ExportContext::export`] (`run --export name`); `None` (the default): written on
    /// every run.
    fn opt_in(&self) -> Option<&'static str> {
        None
    }

    /// Writes its files into `ctx.dir`, each through [`write_atomic`]; returns their paths.
    /// On an error it leaves none of its files behind.
    fn write(&self, ctx: &ExportContext<'_>) -> Result<Vec<PathBuf>, OutputError>;
}

/// Today's outputs, in the order their paths are reported.
pub fn exporters() -> Vec<Box<dyn Exporter>> {
    vec![
        Box::new(super::result_json::ResultJson),
        Box::new(super::weight_csv::WeightCsv),
        Box::new(super::plot::WeightPlot),
        Box::new(super::svg::CellsSvg),
        Box::new(super::svg::Snapshots),
        Box::new(super::leak_pts::LeakPts),
        Box::new(super::prt::Prt),
        Box::new(super::cells_obj::CellsObj),
        Box::new(super::gltf::Glb),
        Box::new(super::dot::Dot),
        Box::new(super::viewer::Viewer),
    ]
}

/// The names of the opt-in formats ([`Exporter::opt_in`]), in registry order.
pub fn opt_in_formats() -> Vec<&'static str> {
    exporters().iter().filter_map(|x| x.opt_in()).collect()
}

/// Writes `path`'s content through a temporary file in the same directory (named with the
/// same extension, as plotters picks the image format from it) and renames it into place.
/// An error from `write` or the rename is [`OutputError::Write`] naming the file.
pub fn write_atomic<E>(path: &Path, write: impl FnOnce(&Path) -> Result<(), E>) -> Result<(), OutputError>
where
    E: Into<Box<dyn std::error::Error + Send + Sync>>,
{
    let dir = path.parent().unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .ok_or_else(|| OutputError::NoFileName {
            path: path.to_path_buf(),
        })?
        .to_string_lossy()
        .into_owned();
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{}.tmp-{}.{}", name, std::process::id(), ext));
    let r = write(&tmp).map_err(|e| e.into()).and_then(|()| {
        std::fs::rename(&tmp, path).map_err(|source| {
            OutputError::Rename {
                from: tmp.clone(),
                to: path.to_path_buf(),
                source,
            }
            .into()
        })
    });
    r.map_err(|source| {
        let _ = std::fs::remove_file(&tmp);
        OutputError::Write { file: name, source }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exporters_own_distinct_files_and_only_result_json_is_last() {
        let list = exporters();
        let fixed = [
            "result.json",
            "weight_curve.csv",
            "weight_curve.png",
            "cells.svg",
            "cells_20.svg",
        ];
        for f in fixed {
            let owners: Vec<&str> = list.iter().filter(|x| x.owns(f)).map(|x| x.name()).collect();
            assert_eq!(owners.len(), 1, "{f}: {owners:?}");
        }
        assert!(!list.iter().any(|x| x.owns("evaluation.json")));
        let last: Vec<&str> = list.iter().filter(|x| x.last()).map(|x| x.name()).collect();
        assert_eq!(last, ["result document"]);
        let mut names: Vec<&str> = list.iter().map(|x| x.name()).collect();
        names.dedup();
        assert_eq!(names.len(), list.len());
    }

    #[test]
    fn write_atomic_leaves_no_temporary_file_on_error() {
        let dir = std::env::temp_dir().join(format!("portalfind-export-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("x.txt");
        let e = write_atomic(&path, |tmp| {
            std::fs::write(tmp, "partial")?;
            Err(std::io::Error::other("disk full"))
        })
        .unwrap_err();
        assert_eq!(e.to_string(), "writing x.txt");
        assert_eq!(std::error::Error::source(&e).unwrap().to_string(), "disk full");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
        write_atomic(&path, |tmp| std::fs::write(tmp, "whole")).unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "whole");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
