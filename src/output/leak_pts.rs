//! `leak.pts`: when the model leaks, the first leak's path from an interior cell to the
//! outside, one `x y z` point per line — qbsp's pointfile, which TrenchBroom loads to show
//! where the model is open. Written by `run` (it passes the cell complex); a run without a
//! leak writes none, and its set replaces an earlier run's pointfile as a whole.

use super::{ExportContext, Exporter, OutputError, write_atomic};
use std::path::PathBuf;

/// The pointfile's name in the output directory.
pub const LEAK_FILE: &str = "leak.pts";

/// Writes `leak.pts` when the complex has a leak.
pub struct LeakPts;

impl Exporter for LeakPts {
    fn name(&self) -> &'static str {
        "leak pointfile"
    }

    fn files(&self, ctx: &ExportContext<'_>) -> Vec<String> {
        if ctx.cx.is_some_and(|c| !c.leaks.is_empty()) {
            vec![LEAK_FILE.into()]
        } else {
            Vec::new()
        }
    }

    fn owns(&self, file_name: &str) -> bool {
        file_name == LEAK_FILE
    }

    fn write(&self, ctx: &ExportContext<'_>) -> Result<Vec<PathBuf>, OutputError> {
        let Some(cx) = ctx.cx else { return Ok(Vec::new()) };
        let Some(leak) = cx.leaks.first() else {
            return Ok(Vec::new());
        };
        let text: String = cx
            .leak_pointfile(leak)
            .into_iter()
            .map(|p| ctx.model.to_user(p))
            .map(|p| format!("{} {} {}\n", p[0], p[1], p[2]))
            .collect();
        let path = ctx.dir.join(LEAK_FILE);
        write_atomic(&path, |tmp| std::fs::write(tmp, text))?;
        Ok(vec![path])
    }
}
