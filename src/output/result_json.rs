//! `result.json`: the [`super::ResultDoc`] (schema in `docs/result-schema.md`).

use super::{ExportContext, Exporter, OutputError, RESULT_FILE, write_atomic};
use std::path::PathBuf;

/// Writes `result.json`, last.
pub struct ResultJson;

impl Exporter for ResultJson {
    fn name(&self) -> &'static str {
        "result document"
    }

    fn files(&self, _: &ExportContext<'_>) -> Vec<String> {
        vec![RESULT_FILE.into()]
    }

    fn owns(&self, file_name: &str) -> bool {
        file_name == RESULT_FILE
    }

    fn last(&self) -> bool {
        true
    }

    fn write(&self, ctx: &ExportContext<'_>) -> Result<Vec<PathBuf>, OutputError> {
        let path = ctx.dir.join(RESULT_FILE);
        write_atomic(&path, |tmp| -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
            let f = std::io::BufWriter::new(std::fs::File::create(tmp)?);
            serde_json::to_writer(f, ctx.doc)?;
            Ok(())
        })?;
        Ok(vec![path])
    }
}
