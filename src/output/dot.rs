//! Graphviz DOT of the portal graph (`portals.dot`, opt-in: `run --export dot`;
//! render with `dot -Tsvg portals.dot -o portals.svg`).
//!
//! An undirected graph: one node `c<id>` per final cell (label: id and volume; attributes
//! `cell` and `volume`), one edge per pair of cells with portals (label: summed area;
//! attributes `area` and `portals`, the number of convex pieces), and one cluster
//! `cluster_region_<k>` per connected region (cells joined by portals), the largest region
//! (by volume) first. Reads only `result.json`'s content.

use super::export::{ExportContext, Exporter, write_atomic};
use super::{OutputError, ResultDoc};
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::PathBuf;

const FILE: &str = "portals.dot";

/// A number with about four significant digits, without exponent for ordinary sizes.
fn num(x: f64) -> String {
    let a = x.abs();
    if a == 0.0 {
        "0".into()
    } else if (1e-3..1e6).contains(&a) {
        let decimals = (3 - a.log10().floor() as i32).clamp(0, 6) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.3e}")
    }
}

/// The connected regions of the portal graph: for each cell (in `doc.cells` order) its
/// region, regions numbered by decreasing volume (ties: smallest cell id first).
pub(super) fn regions(doc: &ResultDoc) -> Vec<usize> {
    let at: HashMap<u32, usize> = doc.cells.iter().enumerate().map(|(i, c)| (c.id, i)).collect();
    let mut parent: Vec<usize> = (0..doc.cells.len()).collect();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    for p in &doc.portals {
        if let (Some(&a), Some(&b)) = (at.get(&p.cells[0]), at.get(&p.cells[1])) {
            let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
            parent[ra.max(rb)] = ra.min(rb);
        }
    }
    let roots: Vec<usize> = (0..doc.cells.len()).map(|i| find(&mut parent, i)).collect();
    let mut volume: HashMap<usize, f64> = HashMap::new();
    for (i, &r) in roots.iter().enumerate() {
        *volume.entry(r).or_default() += doc.cells[i].volume;
    }
    let mut order: Vec<usize> = volume.keys().copied().collect();
    // A root is its region's first cell, so the smallest id breaks ties.
    order.sort_by(|a, b| volume[b].total_cmp(&volume[a]).then(a.cmp(b)));
    let rank: HashMap<usize, usize> = order.iter().enumerate().map(|(k, &r)| (r, k)).collect();
    roots.iter().map(|r| rank[r]).collect()
}

/// The text of `portals.dot`.
pub fn portals_dot(doc: &ResultDoc) -> String {
    let region = regions(doc);
    let n_regions = region.iter().max().map_or(0, |m| m + 1);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "// portalfind {}: the portal graph of {}",
        env!("CARGO_PKG_VERSION"),
        doc.model.name
    );
    let _ = writeln!(s, "graph portals {{");
    let _ = writeln!(
        s,
        "  graph [label=\"{}: {} cells, {} portal pairs, {} regions\", labelloc=t, fontname=\"Helvetica\"];",
        doc.model.name.replace('"', "'"),
        doc.cells.len(),
        doc.portals.len(),
        n_regions
    );
    let _ = writeln!(
        s,
        "  node [shape=box, style=\"rounded,filled\", fillcolor=\"#e8eef8\", fontname=\"Helvetica\"];"
    );
    let _ = writeln!(s, "  edge [fontname=\"Helvetica\", fontsize=10];");
    for k in 0..n_regions {
        let cells: Vec<usize> = (0..doc.cells.len()).filter(|&i| region[i] == k).collect();
        let vol: f64 = cells.iter().map(|&i| doc.cells[i].volume).sum();
        let _ = writeln!(s, "  subgraph cluster_region_{k} {{");
        let _ = writeln!(
            s,
            "    label=\"region {k}: {} cells, volume {}\"; style=dashed;",
            cells.len(),
            num(vol)
        );
        for i in cells {
            let c = &doc.cells[i];
            let _ = writeln!(
                s,
                "    c{id} [label=\"cell {id}\\nV = {v}\", cell={id}, volume={vr}];",
                id = c.id,
                v = num(c.volume),
                vr = c.volume
            );
        }
        let _ = writeln!(s, "  }}");
    }
    for p in &doc.portals {
        let _ = writeln!(
            s,
            "  c{} -- c{} [label=\"A = {}\", area={}, portals={}];",
            p.cells[0],
            p.cells[1],
            num(p.area),
            p.area,
            p.polygons.len()
        );
    }
    s.push_str("}\n");
    s
}

/// `portals.dot`.
pub struct Dot;

impl Exporter for Dot {
    fn name(&self) -> &'static str {
        "portal graph as Graphviz DOT"
    }

    fn files(&self, _ctx: &ExportContext<'_>) -> Vec<String> {
        vec![FILE.into()]
    }

    fn owns(&self, file_name: &str) -> bool {
        file_name == FILE
    }

    fn opt_in(&self) -> Option<&'static str> {
        Some("dot")
    }

    fn write(&self, ctx: &ExportContext<'_>) -> Result<Vec<PathBuf>, OutputError> {
        let path = ctx.dir.join(FILE);
        write_atomic(&path, |tmp| std::fs::write(tmp, portals_dot(ctx.doc)))?;
        Ok(vec![path])
    }
}

#[cfg(test)]
mod tests {
    use super::num;

    #[test]
    fn numbers_are_short() {
        assert_eq!(num(0.0), "0");
        assert_eq!(num(12.34567), "12.35");
        assert_eq!(num(1234.4), "1234");
        assert_eq!(num(0.012345), "0.01235");
        assert_eq!(num(2.5e7), "2.500e7");
    }
}
