//! `result.json`: the [`super::ResultDoc`] (schema in `docs/result-schema.md`).

use super::{ExportContext, Exporter, HashingWriter, OutputError, RESULT_FILE, write_atomic};
use std::path::PathBuf;

/// Removes machine-dependent figures from a JSON document in place: every object member
/// named `stages` or `timings`, or whose name ends in `seconds`, at any depth. What
/// `result.json` and `evaluation.json` hold without them reproduces bit for bit.
pub fn strip_timings_json(v: &mut serde_json::Value) {
    match v {
        serde_json::Value::Object(m) => {
            m.retain(|k, _| k != "stages" && k != "timings" && !k.ends_with("seconds"));
            for x in m.values_mut() {
                strip_timings_json(x);
            }
        }
        serde_json::Value::Array(a) => a.iter_mut().for_each(strip_timings_json),
        _ => {}
    }
}

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
        let mut entry = None;
        write_atomic(&path, |tmp| -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
            // Hashed on the way out (the file is ~500 MB at a million triangles).
            let mut f = std::io::BufWriter::with_capacity(1 << 20, HashingWriter::new(std::fs::File::create(tmp)?));
            // Coordinates in the input's frame (the model's recentring added back).
            let doc = ctx.doc.in_user_frame();
            if ctx.strip_timings {
                let mut v = serde_json::to_value(&*doc)?;
                strip_timings_json(&mut v);
                serde_json::to_writer(&mut f, &v)?;
            } else {
                serde_json::to_writer(&mut f, &*doc)?;
            }
            let hw = f.into_inner().map_err(|e| e.into_error())?;
            entry = Some(hw.finish(RESULT_FILE).0);
            Ok(())
        })?;
        if let Some(e) = entry {
            ctx.hashed
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .push((path.clone(), e));
        }
        Ok(vec![path])
    }
}
