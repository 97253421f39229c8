//! `viewer.html` (opt-in: `run --export html`, `export DIR --to html`): one self-contained
//! HTML file per run, a 3D viewer that works offline from disk.
//!
//! - **Engine.** three.js 0.170.0 (MIT; `assets/three/`, vendored by
//!   `scripts/vendor-three.sh`) is compiled into the binary with `include_str!` and inlined:
//!   its ES module's closing `export{a as B,…}` is rewritten to `globalThis.THREE={B:a,…}`
//!   ([`three_global`]), so the page needs no import map, server or network.
//! - **Data.** Stored once, for the *initial* cells (the active cells of the complex, before
//!   any collapse): every patch bordering one (its polygon and its two sides, a side that is
//!   not an active cell being -1), every initial portal piece, the model's polygons (the
//!   walls), and the merge sequence. Typed arrays go into one JSON block as base64
//!   (little-endian; positions as `f32` relative to the bounding-box centre; volumes and
//!   weights as `f64`). The replay is done in the page: the state after `k` collapses is a
//!   union-find over the first `k` steps (each step merges cell `b` into `a`, `a < b`, so a
//!   root is its cell's smallest piece id, the id `result.json` uses); a patch face is drawn
//!   for a side iff the other side is not in the same cell, a portal iff its two cells differ.
//! - **Steps.** The full merge sequence when the caller knows it ([`super::Notes::full_steps`],
//!   whose prefix is the run's), else the run's own; the slider goes from step 0 (every
//!   initial cell) to the last collapse and starts at the run's stop.
//! - **Per portal,** the step that removes it (its two sides join), so a click shows the
//!   weight at removal; computed here by small-to-large merging over the steps.
//!
//! Invariants: the HTML contains no `</script` or `<!--` inside its script elements (the JSON
//! escapes `<`; the vendored module is checked by a test); a side index is below the number
//! of initial cells; step cells are indices of initial cells, `a < b` as cell ids.

use super::OutputError;
use super::export::{ExportContext, Exporter, write_atomic};
use crate::complex::CellComplex;
use crate::decimate::Step;
use crate::ids::CellId;
use crate::model::Model;
use std::collections::HashMap;
use std::path::PathBuf;

/// The file name.
pub const VIEWER_FILE: &str = "viewer.html";

/// three.js's minified ES module build (see the module docs).
const THREE_MODULE: &str = include_str!("../../assets/three/three.module.min.js");
/// The page (HTML, CSS and the viewer's script) with the placeholders `__TITLE__`,
/// `__THREE__` and `__DATA__`.
const TEMPLATE: &str = include_str!("../../assets/viewer/viewer.html");

/// The three.js module with its `export{…}` statement turned into an assignment to
/// `globalThis.THREE`, so it runs as an inline module script; `None` if the build has not
/// exactly one such statement at its end.
pub fn three_global(module: &str) -> Option<String> {
    let start = module.rfind("export{")?;
    let tail = module[start..].trim_end();
    let body = tail.strip_prefix("export{")?.strip_suffix("};")?;
    if body.contains(['{', '}', ';']) || module[..start].contains("export{") {
        return None;
    }
    let mut out = String::with_capacity(module.len());
    out.push_str(&module[..start]);
    out.push_str("globalThis.THREE={");
    for (i, item) in body.split(',').enumerate() {
        let mut parts = item.split(" as ");
        let local = parts.next()?.trim();
        let exported = parts.next().unwrap_or(local).trim();
        if local.is_empty() || exported.is_empty() || parts.next().is_some() {
            return None;
        }
        if i > 0 {
            out.push(',');
        }
        out.push_str(exported);
        out.push(':');
        out.push_str(local);
    }
    out.push_str("};\n");
    Some(out)
}

/// Standard base64 (RFC 4648, with padding).
pub fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16 | (*c.get(1).unwrap_or(&0) as u32) << 8 | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            if k <= c.len() {
                s.push(A[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

fn b64_u32(v: &[u32]) -> String {
    base64(&v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>())
}
fn b64_i32(v: &[i32]) -> String {
    base64(&v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>())
}
fn b64_f32(v: &[f32]) -> String {
    base64(&v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>())
}
fn b64_f64(v: &[f64]) -> String {
    base64(&v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>())
}
fn b64_u8(v: &[u8]) -> String {
    base64(v)
}

/// Polygons in one vertex pool: per polygon its vertex count, then the indices.
#[derive(Default)]
struct Polys {
    verts: Vec<f32>,
    at: HashMap<[u64; 3], u32>,
    counts: Vec<u8>,
    idx: Vec<u32>,
}

impl Polys {
    fn vertex(&mut self, p: &[f64; 3], centre: &[f64; 3]) -> u32 {
        let key = [p[0].to_bits(), p[1].to_bits(), p[2].to_bits()];
        let n = self.at.len() as u32;
        *self.at.entry(key).or_insert_with(|| {
            for k in 0..3 {
                self.verts.push((p[k] - centre[k]) as f32);
            }
            n
        })
    }
    /// Adds a polygon (fanned in the page); polygons of more than 255 vertices are split
    /// into fans of at most 255. Returns how many polygons were added.
    fn push(&mut self, pts: &[[f64; 3]], centre: &[f64; 3]) -> usize {
        if pts.len() < 3 {
            return 0;
        }
        let ids: Vec<u32> = pts.iter().map(|p| self.vertex(p, centre)).collect();
        let mut added = 0;
        let mut start = 1;
        while start + 1 < ids.len() {
            let end = (start + 253).min(ids.len() - 1);
            self.counts.push((end - start + 2) as u8);
            self.idx.push(ids[0]);
            self.idx.extend_from_slice(&ids[start..=end]);
            added += 1;
            start = end;
        }
        added
    }
}

/// The step (1-based) at which each initial portal's two cells join (0: never), by
/// merging the smaller group into the larger one per step; `sides[k]` are initial cell
/// indices, `steps` pairs of initial cell indices.
pub(crate) fn removal_steps(n: usize, sides: &[[u32; 2]], steps: &[[u32; 2]]) -> Vec<u32> {
    let mut group: Vec<u32> = (0..n as u32).collect();
    let mut members: Vec<Vec<u32>> = (0..n as u32).map(|i| vec![i]).collect();
    let mut touching: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (k, s) in sides.iter().enumerate() {
        touching[s[0] as usize].push(k as u32);
        touching[s[1] as usize].push(k as u32);
    }
    let mut removed = vec![0u32; sides.len()];
    for (i, st) in steps.iter().enumerate() {
        let (ga, gb) = (group[st[0] as usize], group[st[1] as usize]);
        if ga == gb {
            continue;
        }
        let (big, small) = if members[ga as usize].len() >= members[gb as usize].len() {
            (ga, gb)
        } else {
            (gb, ga)
        };
        let moved = std::mem::take(&mut members[small as usize]);
        for &c in &moved {
            for &k in &touching[c as usize] {
                let other = if sides[k as usize][0] == c {
                    sides[k as usize][1]
                } else {
                    sides[k as usize][0]
                };
                if removed[k as usize] == 0 && group[other as usize] == big {
                    removed[k as usize] = (i + 1) as u32;
                }
            }
        }
        for &c in &moved {
            group[c as usize] = big;
        }
        members[big as usize].extend(moved);
    }
    removed
}

/// The viewer's data (the JSON the page reads), from the model, the complex and a merge
/// sequence of which the first `stop` steps are the run's.
pub fn viewer_json(
    model: &Model,
    cx: &CellComplex,
    steps: &[Step],
    stop: usize,
    settings: &serde_json::Value,
) -> Result<String, OutputError> {
    let (lo, hi) = model.bbox();
    let centre = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0, (lo[2] + hi[2]) / 2.0];
    let size = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    let fail = |what: String| OutputError::Write {
        file: VIEWER_FILE.into(),
        source: what.into(),
    };
    // Initial cells: dense indices.
    let mut dense: HashMap<CellId, u32> = HashMap::new();
    let mut ids = Vec::new();
    let mut volumes = Vec::new();
    for (id, c) in cx.active_cells() {
        dense.insert(id, ids.len() as u32);
        ids.push(id.0);
        volumes.push(c.volume());
    }
    let side = |c: CellId| dense.get(&c).map_or(-1, |&i| i as i32);
    // Patches bordering an initial cell, each once.
    let mut patches = Polys::default();
    let mut patch_sides: Vec<i32> = Vec::new();
    let mut seen = vec![false; cx.patches.len()];
    for (_, c) in cx.active_cells() {
        for &tag in c.tags() {
            let t = tag as usize;
            if t >= cx.patches.len() || seen[t] {
                continue;
            }
            seen[t] = true;
            let p = &cx.patches[t];
            let n = patches.push(&p.polygon.verts, &centre);
            for _ in 0..n {
                patch_sides.extend([side(p.cells[0]), side(p.cells[1])]);
            }
        }
    }
    // Initial portal pieces.
    let mut portals = Polys::default();
    let mut portal_sides: Vec<[u32; 2]> = Vec::new();
    let mut portal_area: Vec<f64> = Vec::new();
    for p in &cx.portals {
        let (Some(&a), Some(&b)) = (dense.get(&p.cells[0]), dense.get(&p.cells[1])) else {
            continue;
        };
        for q in &p.pieces {
            let n = portals.push(&q.verts, &centre);
            for i in 0..n {
                portal_sides.push([a, b]);
                // The area counts once per piece (a split piece's parts after the first add 0).
                portal_area.push(if i == 0 { q.area() } else { 0.0 });
            }
        }
    }
    // Walls: the model's polygons.
    let mut walls = Polys::default();
    for poly in &model.polygons {
        let pts: Vec<[f64; 3]> = poly.verts.iter().map(|v| model.vertices[v.idx()]).collect();
        walls.push(&pts, &centre);
    }
    // The merge sequence.
    let mut step_cells: Vec<[u32; 2]> = Vec::with_capacity(steps.len());
    for (i, s) in steps.iter().enumerate() {
        match (dense.get(&s.a), dense.get(&s.b)) {
            (Some(&a), Some(&b)) => step_cells.push([a, b]),
            _ => {
                return Err(fail(format!(
                    "step {}: cells {} and {} are not initial cells of the complex",
                    i + 1,
                    s.a,
                    s.b
                )));
            }
        }
    }
    let removed = removal_steps(ids.len(), &portal_sides, &step_cells);
    let flat = |v: &[[u32; 2]]| v.iter().flatten().copied().collect::<Vec<u32>>();
    let doc = serde_json::json!({
        "format": "portalfind-viewer",
        "version": 1,
        "generator": format!("portalfind {}", env!("CARGO_PKG_VERSION")),
        "model": model.name,
        "settings": settings,
        // In the input's frame; the vertices are relative to it (f32 near zero).
        "centre": model.to_user(centre),
        "size": size,
        "stop": stop,
        "cells": {
            "n": ids.len(),
            "ids": b64_u32(&ids),
            "volume": b64_f64(&volumes),
        },
        "patches": {
            "verts": b64_f32(&patches.verts),
            "counts": b64_u8(&patches.counts),
            "idx": b64_u32(&patches.idx),
            "sides": b64_i32(&patch_sides),
        },
        "portals": {
            "verts": b64_f32(&portals.verts),
            "counts": b64_u8(&portals.counts),
            "idx": b64_u32(&portals.idx),
            "sides": b64_u32(&flat(&portal_sides)),
            "area": b64_f64(&portal_area),
            "removed": b64_u32(&removed),
        },
        "walls": {
            "verts": b64_f32(&walls.verts),
            "counts": b64_u8(&walls.counts),
            "idx": b64_u32(&walls.idx),
        },
        "steps": {
            "n": steps.len(),
            "cells": b64_u32(&flat(&step_cells)),
            "weight": b64_f64(&steps.iter().map(|s| s.weight).collect::<Vec<_>>()),
            "remaining": b64_u32(&steps.iter().map(|s| s.cells_remaining as u32).collect::<Vec<_>>()),
        },
    });
    let text = serde_json::to_string(&doc).map_err(|source| OutputError::Serialize {
        what: "the viewer data",
        source,
    })?;
    // `<` only occurs inside JSON strings, where \u003c is the same character.
    Ok(text.replace('<', "\\u003c"))
}

/// The whole page: the template with three.js and the data inlined.
pub fn viewer_html(title: &str, data_json: &str) -> Result<String, OutputError> {
    let three = three_global(THREE_MODULE).ok_or_else(|| OutputError::Write {
        file: VIEWER_FILE.into(),
        source: "the vendored three.js build has no single closing export statement".into(),
    })?;
    let title: String = title
        .chars()
        .map(|c| match c {
            '<' => "&lt;".to_string(),
            '>' => "&gt;".to_string(),
            '&' => "&amp;".to_string(),
            '"' => "&quot;".to_string(),
            c => c.to_string(),
        })
        .collect();
    // Replace the data last, so nothing inside it is taken for a placeholder.
    let (head, rest) = TEMPLATE.split_once("__DATA__").ok_or_else(|| OutputError::Write {
        file: VIEWER_FILE.into(),
        source: "the viewer template has no data placeholder".into(),
    })?;
    let head = head.replace("__TITLE__", &title).replace("__THREE__", &three);
    let rest = rest.replace("__TITLE__", &title).replace("__THREE__", &three);
    Ok(format!("{head}{data_json}{rest}"))
}

/// `viewer.html`.
pub struct Viewer;

impl Exporter for Viewer {
    fn name(&self) -> &'static str {
        "3D viewer (HTML)"
    }

    fn files(&self, _ctx: &ExportContext<'_>) -> Vec<String> {
        vec![VIEWER_FILE.into()]
    }

    fn owns(&self, file_name: &str) -> bool {
        file_name == VIEWER_FILE
    }

    fn opt_in(&self) -> Option<&'static str> {
        Some("html")
    }

    fn write(&self, ctx: &ExportContext<'_>) -> Result<Vec<PathBuf>, OutputError> {
        let cx = ctx.complex(VIEWER_FILE)?;
        let dec = ctx.dec;
        let steps = ctx
            .notes
            .full_steps
            .filter(|f| f.len() >= dec.steps.len() && f[..dec.steps.len()] == dec.steps[..])
            .unwrap_or(&dec.steps);
        let settings = serde_json::json!({
            "heuristic": dec.settings.heuristic.to_string(),
            "estimator": dec.settings.estimator.to_string(),
            "stop": dec.settings.stop.to_string(),
            "subdivision": ctx.doc.settings.subdivision,
        });
        let data = viewer_json(ctx.model, cx, steps, dec.steps.len(), &settings)?;
        let html = viewer_html(&format!("{}: portalfind viewer", ctx.model.name), &data)?;
        let path = ctx.dir.join(VIEWER_FILE);
        write_atomic(&path, |tmp| std::fs::write(tmp, html))?;
        Ok(vec![path])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc4648_vectors() {
        for (i, o) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(i.as_bytes()), o);
        }
        assert_eq!(base64(&[0xff, 0xfe, 0x00]), "//4A");
    }

    #[test]
    fn the_vendored_module_becomes_a_global_and_is_safe_inside_a_script_element() {
        let g = three_global(THREE_MODULE).expect("one export statement");
        assert!(!g.contains("export{"));
        assert!(g.trim_end().ends_with("};"));
        for name in [
            "WebGLRenderer:",
            "PerspectiveCamera:",
            "BufferGeometry:",
            "Raycaster:",
            "Scene:",
        ] {
            assert!(g.contains(name), "{name}");
        }
        let lower = THREE_MODULE.to_ascii_lowercase();
        assert!(!lower.contains("</script") && !lower.contains("<!--"));
        let t = TEMPLATE.to_ascii_lowercase();
        assert!(!t.contains("<!--"));
        assert_eq!(TEMPLATE.matches("__DATA__").count(), 1);
        assert_eq!(TEMPLATE.matches("__THREE__").count(), 1);
    }

    #[test]
    fn three_global_refuses_other_shapes() {
        assert_eq!(
            three_global("const a=1,b=2;export{a as A,b};").as_deref(),
            Some("const a=1,b=2;globalThis.THREE={A:a,b:b};\n")
        );
        assert_eq!(three_global("const a=1;"), None);
        assert_eq!(three_global("export{a};export{b};"), None);
        assert_eq!(three_global("export{a as b as c};"), None);
    }

    #[test]
    fn polygons_are_pooled_and_long_ones_split_into_fans() {
        let mut p = Polys::default();
        let c = [0.0; 3];
        let sq = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
        assert_eq!(p.push(&sq, &c), 1);
        assert_eq!(p.push(&sq[..3], &c), 1);
        assert_eq!(p.verts.len(), 12);
        assert_eq!(p.counts, [4, 3]);
        assert_eq!(p.idx, [0, 1, 2, 3, 0, 1, 2]);
        // A 600-gon: fans of at most 255 vertices covering all 598 triangles.
        let ring: Vec<[f64; 3]> = (0..600)
            .map(|i| {
                let t = i as f64 / 600.0 * std::f64::consts::TAU;
                [t.cos(), t.sin(), 0.0]
            })
            .collect();
        let mut q = Polys::default();
        let n = q.push(&ring, &c);
        assert!(n >= 3);
        assert!(q.counts.iter().all(|&k| (3..=255).contains(&k)));
        let triangles: usize = q.counts.iter().map(|&k| k as usize - 2).sum();
        assert_eq!(triangles, 598);
        assert_eq!(q.counts.len(), n);
    }

    #[test]
    fn portals_are_removed_when_their_cells_join() {
        // Cells 0-1-2-3 in a row, portals between neighbours and one 0-3; merges (0,1),
        // (2,3), (0,2).
        let sides = [[0, 1], [1, 2], [2, 3], [0, 3]];
        let steps = [[0, 1], [2, 3], [0, 2]];
        assert_eq!(removal_steps(4, &sides, &steps), [1, 3, 2, 3]);
        assert_eq!(removal_steps(4, &sides, &steps[..1]), [1, 0, 0, 0]);
    }
}
