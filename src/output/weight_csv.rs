//! `weight_curve.csv`: one row per collapse.

use super::{ExportContext, Exporter, OutputError, write_atomic};
use crate::decimate::Decimation;
use std::path::{Path, PathBuf};

const FILE: &str = "weight_curve.csv";

/// Writes `weight_curve.csv`.
pub struct WeightCsv;

impl Exporter for WeightCsv {
    fn name(&self) -> &'static str {
        "weight curve (CSV)"
    }

    fn files(&self, _: &ExportContext<'_>) -> Vec<String> {
        vec![FILE.into()]
    }

    fn owns(&self, file_name: &str) -> bool {
        file_name == FILE
    }

    fn write(&self, ctx: &ExportContext<'_>) -> Result<Vec<PathBuf>, OutputError> {
        let path = ctx.dir.join(FILE);
        write_weight_csv(&path, ctx.dec)?;
        Ok(vec![path])
    }
}

/// Rows of `weight_curve.csv`, written to `path`.
pub fn write_weight_csv(path: &Path, dec: &Decimation) -> Result<(), OutputError> {
    write_atomic(path, |tmp| -> Result<(), csv::Error> {
        let mut w = csv::Writer::from_path(tmp)?;
        w.write_record([
            "step",
            "weight",
            "cells_remaining",
            "cell_a",
            "cell_b",
            "portal_area",
            "projected_a",
            "projected_b",
        ])?;
        for (i, s) in dec.steps.iter().enumerate() {
            w.write_record([
                (i + 1).to_string(),
                s.weight.to_string(),
                s.cells_remaining.to_string(),
                s.a.0.to_string(),
                s.b.0.to_string(),
                s.portal_area.to_string(),
                s.projected[0].to_string(),
                s.projected[1].to_string(),
            ])?;
        }
        w.flush()?;
        Ok(())
    })
}
