//! Helpers shared by the integration tests (`mod common;` in each test file that uses
//! them; not every test binary uses every helper).
#![allow(dead_code)]

use portalfind::complex::CellComplex;
use portalfind::decimate::Partition;

/// The final cell (index into `part.cells`) holding point `p`: the lowest-id active complex
/// cell containing it, mapped through the partition.
pub fn locate(cx: &CellComplex, part: &Partition, p: &[f64; 3]) -> Option<usize> {
    cx.active_cells()
        .find(|(_, c)| c.contains(p, &cx.tol))
        .and_then(|(id, _)| part.cell_of(id))
}
