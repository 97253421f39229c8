//! `weight_curve.csv`: one row per collapse.

use super::{ExportContext, Exporter, OutputError, write_atomic};
use crate::decimate::{Decimation, Step};
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

/// The header row of `weight_curve.csv`.
const HEADER: &str = "step,weight,cells_remaining,cell_a,cell_b,portal_area,projected_a,projected_b\n";

/// Rows of `weight_curve.csv`, written to `path`.
///
/// Every field is an integer or an `f64` in its `Display` form (digits, `-`, `.`, `inf`,
/// `NaN`: nothing a CSV reader needs quoted), so the rows are formatted directly, on
/// every core in blocks that are written in order (the bytes do not depend on the thread
/// count; held in memory a block group at a time).
pub fn write_weight_csv(path: &Path, dec: &Decimation) -> Result<(), OutputError> {
    write_rows(path, &dec.steps)
}

fn write_rows(path: &Path, steps: &[Step]) -> Result<(), OutputError> {
    use rayon::prelude::*;
    use std::fmt::Write as _;
    use std::io::Write as _;
    const BLOCK: usize = 4096;
    write_atomic(path, |tmp| -> Result<(), std::io::Error> {
        let mut w = std::io::BufWriter::new(std::fs::File::create(tmp)?);
        w.write_all(HEADER.as_bytes())?;
        let rows = |first: usize, steps: &[Step]| {
            let mut s = String::with_capacity(steps.len() * 64);
            for (k, st) in steps.iter().enumerate() {
                let _ = writeln!(
                    s,
                    "{},{},{},{},{},{},{},{}",
                    first + k + 1,
                    st.weight,
                    st.cells_remaining,
                    st.a.0,
                    st.b.0,
                    st.portal_area,
                    st.projected[0],
                    st.projected[1]
                );
            }
            s
        };
        for (g, group) in steps.chunks(BLOCK * 16).enumerate() {
            let blocks: Vec<String> = group
                .par_chunks(BLOCK)
                .enumerate()
                .map(|(b, steps)| rows(g * BLOCK * 16 + b * BLOCK, steps))
                .collect();
            for b in blocks {
                w.write_all(b.as_bytes())?;
            }
        }
        w.flush()?;
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ids::CellId;

    /// The direct rows are the bytes the `csv` crate wrote from the fields' `to_string()`.
    #[test]
    fn rows_equal_the_csv_crates() {
        let mut rng = crate::base::rng::SplitMix64(3);
        let mut steps = Vec::new();
        for i in 0..(3 * 4096 * 16 + 77) {
            let mut f = || f64::from_bits(rng.next_u64() >> (rng.next_u64() % 3));
            let (w, area, pa, pb) = (f(), f() * 1e-3, 1.0 / 3.0, -f());
            steps.push(Step {
                a: CellId(i as u32),
                b: CellId(7 * i as u32 + 1),
                weight: if i % 97 == 0 { f64::INFINITY } else { w },
                cells_remaining: 1_000_000 - i,
                portal_area: if i % 89 == 0 { f64::NAN } else { area },
                projected: [pa, pb],
            });
        }
        let dir = std::env::temp_dir().join(format!("portalfind-wcsv-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (a, b) = (dir.join("a.csv"), dir.join("b.csv"));
        write_rows(&a, &steps).unwrap();
        let mut w = csv::Writer::from_path(&b).unwrap();
        w.write_record(HEADER.trim_end().split(',')).unwrap();
        for (i, s) in steps.iter().enumerate() {
            w.write_record([
                (i + 1).to_string(),
                s.weight.to_string(),
                s.cells_remaining.to_string(),
                s.a.0.to_string(),
                s.b.0.to_string(),
                s.portal_area.to_string(),
                s.projected[0].to_string(),
                s.projected[1].to_string(),
            ])
            .unwrap();
        }
        w.flush().unwrap();
        drop(w);
        assert!(std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
