//! `cells.svg`: the final cells seen from above, in the style of the thesis figures.
//!
//! Each final cell is filled with a colour of its own (the union of its convex pieces'
//! projections; larger cells first, so a small cell on top of a large one stays visible),
//! labelled with its id; the model's walls are drawn over the cells (thin, dark grey;
//! floors as a faint fill), the final portals on top (bold red). A legend lists the largest
//! cells by share of the volume (and, with a ground truth, which rooms' samples each holds,
//! so a run that leaves one giant cell and spikes reads as such), and a scale bar gives
//! model units. With a ground truth the rooms' sample points (labelled circles) and the
//! doorways (dashed) are overlaid. When the model's floors lie at several heights (a
//! multi-storey level such as e1m1) a side view (x right, z up) follows the top view, so
//! storeys that overlap from above are apart there.
//!
//! Written by hand (no fonts or backends needed); [`cells_svg`] is the plain entry point,
//! [`cells_svg_with`] adds the annotations.

use super::{Locator, Notes, ResultDoc};
use crate::ids::PolygonId;
use crate::model::Model;
use crate::predicates::P3;
use rayon::prelude::*;
use std::fmt::Write;
use std::path::PathBuf;

const WIDTH: f64 = 1200.0;
const MARGIN: f64 = 20.0;
const LEGEND: f64 = 290.0;
const HEADER: f64 = 74.0;
/// Cells with ids drawn on them at most (labels of more would cover the picture).
const MAX_LABELS: usize = 150;
/// Cells listed in the legend at most.
const LEGEND_ROWS: usize = 14;
/// Portal colour.
const PORTAL: &str = "#d0101c";

/// A distinct colour for cell index `i` (golden-angle hues, alternating lightness).
fn cell_colour(i: usize) -> String {
    let h = (i as f64 * 137.507_764) % 360.0;
    let l = if i.is_multiple_of(2) { 58 } else { 46 };
    format!("hsl({h:.1},70%,{l}%)")
}

/// The 2D convex hull (counter-clockwise, Andrew's monotone chain) of `pts`.
fn hull2(mut pts: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    pts.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    pts.dedup();
    if pts.len() < 3 {
        return pts;
    }
    let cross = |o: (f64, f64), a: (f64, f64), b: (f64, f64)| (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0);
    let mut h: Vec<(f64, f64)> = Vec::with_capacity(2 * pts.len());
    for pass in 0..2 {
        let start = h.len();
        let it: Box<dyn Iterator<Item = &(f64, f64)>> = if pass == 0 {
            Box::new(pts.iter())
        } else {
            Box::new(pts.iter().rev())
        };
        for &p in it {
            while h.len() >= start + 2 && cross(h[h.len() - 2], h[h.len() - 1], p) <= 0.0 {
                h.pop();
            }
            h.push(p);
        }
        h.pop();
    }
    h
}

/// A "nice" length (1, 2 or 5 × 10^k) close to `x`, at most `x`.
fn nice_length(x: f64) -> f64 {
    if x <= 0.0 || !x.is_finite() {
        return 1.0;
    }
    let k = 10f64.powf(x.log10().floor());
    [5.0, 2.0, 1.0]
        .into_iter()
        .map(|m| m * k)
        .find(|&v| v <= x)
        .unwrap_or(k)
}

/// A height for captions: four significant digits.
fn fmt_height(z: f64) -> String {
    let a = z.abs();
    if a == 0.0 || !z.is_finite() {
        return format!("{z}");
    }
    let decimals = (3 - a.log10().floor() as i32).clamp(0, 6) as usize;
    format!("{z:.decimals$}")
}

fn fmt_len(x: f64) -> String {
    if x >= 1.0 { format!("{x:.0}") } else { format!("{x}") }
}

/// Whether the model's floors (polygons facing up) lie at clearly different heights:
/// the 10th and 90th percentiles of their area-weighted heights differ by more than a
/// quarter of the model's height.
pub fn multi_storey(model: &Model) -> bool {
    let (lo, hi) = model.bbox();
    let zext = hi[2] - lo[2];
    if zext.is_nan() || zext <= 0.0 {
        return false;
    }
    let mut floors: Vec<(f64, f64)> = Vec::new();
    for (i, p) in model.polygons.iter().enumerate() {
        let n = model.polygon_normal(PolygonId(i as u32));
        let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        if l.is_nan() || l <= 0.0 || n[2] / l < 0.7 {
            continue;
        }
        let z = p.verts.iter().map(|v| model.vertices[v.idx()][2]).sum::<f64>() / p.verts.len() as f64;
        floors.push((z, l));
    }
    let total: f64 = floors.iter().map(|f| f.1).sum();
    if floors.is_empty() || total <= 0.0 {
        return false;
    }
    floors.sort_by(|a, b| a.0.total_cmp(&b.0));
    let quantile = |q: f64| {
        let mut acc = 0.0;
        for &(z, a) in &floors {
            acc += a;
            if acc >= q * total {
                return z;
            }
        }
        floors[floors.len() - 1].0
    };
    quantile(0.9) - quantile(0.1) > 0.25 * zext
}

/// A storey gap: cells' floor heights further apart than this share of their height range
/// start a new storey (a run of empty bins of a histogram with bins this wide). Relative,
/// so it does not depend on the model's units.
pub const STOREY_GAP: f64 = 0.125;
/// Storey panels drawn at most (the smallest gaps are closed first).
pub const MAX_STOREYS: usize = 6;

/// One storey of [`storeys`]: the cells whose floor (lowest point) lies in `[floor, next)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Storey {
    /// The lowest floor height of its cells.
    pub floor: f64,
    /// The next storey's floor (the top of the cells' height range for the highest).
    pub next: f64,
    /// Its cells, as indices into `doc.cells`.
    pub cells: Vec<usize>,
}

/// The storeys of a run's cells, from their floor heights (each cell's lowest vertex): sorted
/// by height, a gap wider than [`STOREY_GAP`] of the cells' height range (lowest floor to
/// highest point) separates two storeys; at most [`MAX_STOREYS`] (the widest gaps win).
/// One storey when there is no such gap.
pub fn storeys(doc: &ResultDoc) -> Vec<Storey> {
    let mut floors: Vec<(f64, usize)> = Vec::new();
    let mut top = f64::NEG_INFINITY;
    for (i, c) in doc.cells.iter().enumerate() {
        let zs = c.pieces.iter().flat_map(|p| p.vertices.iter().map(|v| v[2]));
        let (lo, hi) = zs.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), z| (a.min(z), b.max(z)));
        if lo.is_finite() && hi.is_finite() {
            floors.push((lo, i));
            top = top.max(hi);
        }
    }
    floors.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let Some(&(lowest, _)) = floors.first() else {
        return Vec::new();
    };
    let range = top - lowest;
    // Gaps (index of the first cell above, width), widest first.
    let mut gaps: Vec<(usize, f64)> = floors
        .windows(2)
        .enumerate()
        .map(|(k, w)| (k + 1, w[1].0 - w[0].0))
        .filter(|&(_, g)| range > 0.0 && g > STOREY_GAP * range)
        .collect();
    gaps.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    gaps.truncate(MAX_STOREYS - 1);
    let mut starts: Vec<usize> = std::iter::once(0).chain(gaps.iter().map(|g| g.0)).collect();
    starts.sort_unstable();
    starts
        .iter()
        .enumerate()
        .map(|(k, &s)| {
            let end = starts.get(k + 1).copied().unwrap_or(floors.len());
            let mut cells: Vec<usize> = floors[s..end].iter().map(|f| f.1).collect();
            cells.sort_unstable();
            Storey {
                floor: floors[s].0,
                next: floors.get(end).map_or(top, |f| f.0),
                cells,
            }
        })
        .collect()
}

/// One projection of the model into a panel: `axis` 1 is the top view (x, y), 2 the side
/// view (x, z); `origin` is the panel's top-left corner on the page.
struct View {
    lo: [f64; 2],
    hi_v: f64,
    s: f64,
    origin: (f64, f64),
    axis: usize,
}

impl View {
    fn pt(&self, p: &P3) -> (f64, f64) {
        (
            self.origin.0 + (p[0] - self.lo[0]) * self.s,
            self.origin.1 + (self.hi_v - p[self.axis]) * self.s,
        )
    }
}

fn path_d(out: &mut String, pts: &[(f64, f64)]) {
    for (k, &(x, y)) in pts.iter().enumerate() {
        out.push(if k == 0 { 'M' } else { 'L' });
        push_fixed2(out, x);
        out.push(',');
        push_fixed2(out, y);
        out.push(' ');
    }
    out.push_str("Z ");
}

/// Appends `format!("{x:.2}")` to `out`, the same bytes, without the formatting machinery
/// for the common case (a top view of a million-triangle run writes ~20 million numbers).
///
/// `y = x * 100` is within half an ulp of the exact `100 x` (one rounding), so its nearest
/// integer is the exact value's whenever `y` is farther than that from a half-integer;
/// near a half-integer (where the standard formatter's exact tie rule decides), for
/// negative values that round to zero (printed `-0.00`), and beyond 2^52 the standard
/// formatter is called.
fn push_fixed2(out: &mut String, x: f64) {
    let y = x * 100.0;
    let r = y.round();
    let margin = y.abs() * f64::EPSILON + f64::MIN_POSITIVE;
    if !y.is_finite()
        || y.abs() >= 4.0e15
        || ((y - r).abs() - 0.5).abs() <= margin
        || (r == 0.0 && x.is_sign_negative())
    {
        let _ = write!(out, "{x:.2}");
        return;
    }
    let n = r as i64;
    if n < 0 {
        out.push('-');
    }
    let a = n.unsigned_abs();
    let (int, frac) = (a / 100, a % 100);
    let _ = write!(out, "{int}.");
    out.push(char::from(b'0' + (frac / 10) as u8));
    out.push(char::from(b'0' + (frac % 10) as u8));
}

/// The SVG document of `doc`'s cells over `model` (no annotations).
pub fn cells_svg(model: &Model, doc: &ResultDoc) -> String {
    cells_svg_with(model, doc, &Notes::default())
}

/// The SVG document, with the ground truth of `notes` overlaid when there is one.
pub fn cells_svg_with(model: &Model, doc: &ResultDoc, notes: &Notes<'_>) -> String {
    let (lo, hi) = model.bbox();
    let ext = |k: usize| (hi[k] - lo[k]).max(1e-12);
    let map_w = WIDTH - 3.0 * MARGIN - LEGEND;
    let s = map_w / ext(0);
    let side = multi_storey(model);
    // Per-storey slices: only for multi-storey models whose cells' floors have gaps.
    let slices: Vec<Storey> = if side {
        storeys(doc).into_iter().filter(|s| !s.cells.is_empty()).collect()
    } else {
        Vec::new()
    };
    let slices = if slices.len() >= 2 { slices } else { Vec::new() };
    let top = View {
        lo: [lo[0], lo[1]],
        hi_v: hi[1],
        s,
        origin: (MARGIN, HEADER),
        axis: 1,
    };
    let top_h = ext(1) * s;
    let slice_view = |k: usize| View {
        origin: (MARGIN, HEADER + (k + 1) as f64 * (top_h + 50.0)),
        ..top
    };
    let slices_h = slices.len() as f64 * (top_h + 50.0);
    let side_view = View {
        lo: [lo[0], lo[2]],
        hi_v: hi[2],
        s,
        origin: (MARGIN, HEADER + top_h + slices_h + 50.0),
        axis: 2,
    };
    let side_h = if side { ext(2) * s + 50.0 } else { 0.0 };
    let legend_rows = doc.cells.len().min(LEGEND_ROWS) + 10;
    let height = (HEADER + top_h + slices_h + side_h + 70.0).max(HEADER + legend_rows as f64 * 18.0 + 40.0);

    // Which rooms' samples each cell holds.
    let mut holds: Vec<Vec<usize>> = vec![Vec::new(); doc.cells.len()];
    if let Some(t) = notes.truth {
        let loc = Locator::new(doc);
        for (r, room) in t.rooms.iter().enumerate() {
            for p in &room.samples {
                if let Some(id) = loc.locate(p)
                    && let Ok(i) = doc.cells.binary_search_by_key(&id.0, |c| c.id)
                    && !holds[i].contains(&r)
                {
                    holds[i].push(r);
                }
            }
        }
    }
    let total_volume: f64 = doc.cells.iter().map(|c| c.volume).sum();
    let mut by_volume: Vec<usize> = (0..doc.cells.len()).collect();
    by_volume.sort_by(|&a, &b| doc.cells[b].volume.total_cmp(&doc.cells[a].volume).then(a.cmp(&b)));
    let share = |i: usize| {
        if total_volume > 0.0 {
            100.0 * doc.cells[i].volume / total_volume
        } else {
            0.0
        }
    };
    let pct = |i: usize| {
        let p = share(i);
        if p > 0.0 && p < 0.1 {
            "<0.1%".to_string()
        } else {
            format!("{p:.1}%")
        }
    };

    let mut out = String::new();
    let _ = writeln!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH:.0}" height="{height:.0}" viewBox="0 0 {WIDTH:.0} {height:.0}" font-family="DejaVu Sans, Verdana, sans-serif">"#
    );
    let _ = writeln!(out, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let title = format!(
        "{} — {} / {}, stop {}",
        doc.model.name, doc.settings.heuristic, doc.settings.estimator, doc.settings.stop
    );
    let _ = writeln!(
        out,
        r#"<text x="{MARGIN}" y="22" font-size="16" font-weight="bold">{}</text>"#,
        escape(&title)
    );
    let mut sub = format!("{} cells, {} portal pairs", doc.cells.len(), doc.portals.len());
    if let Some(&big) = by_volume.first() {
        let _ = write!(
            sub,
            "; largest cell {} holds {:.1}% of the volume",
            doc.cells[big].id,
            share(big)
        );
    }
    if let Some(t) = notes.truth {
        let empty = holds.iter().filter(|h| h.is_empty()).count();
        let _ = write!(
            sub,
            "; {} rooms in the ground truth, {empty} cells hold none of their samples",
            t.rooms.len()
        );
    }
    let _ = writeln!(
        out,
        r##"<text x="{MARGIN}" y="42" font-size="12" fill="#333">{}</text>"##,
        escape(&sub)
    );

    draw_view(
        &mut out,
        model,
        doc,
        notes,
        &top,
        &by_volume,
        None,
        "top view (x right, y up)",
    );
    for (k, st) in slices.iter().enumerate() {
        let caption = format!(
            "storey {} of {} (top view): the {} whose floor lies in [{}, {}), walls of that height",
            k + 1,
            slices.len(),
            if st.cells.len() == 1 {
                "1 cell".to_string()
            } else {
                format!("{} cells", st.cells.len())
            },
            // Heights in the input's frame.
            fmt_height(model.to_user([0.0, 0.0, st.floor])[2]),
            fmt_height(model.to_user([0.0, 0.0, st.next])[2])
        );
        draw_view(
            &mut out,
            model,
            doc,
            notes,
            &slice_view(k),
            &by_volume,
            Some(st),
            &caption,
        );
    }
    if side {
        draw_view(
            &mut out,
            model,
            doc,
            notes,
            &side_view,
            &by_volume,
            None,
            "side view (x right, z up): storeys apart",
        );
    }
    // Scale bar under the last panel.
    let bar = nice_length(ext(0) / 5.0);
    let y = if side {
        side_view.origin.1 + ext(2) * s + 30.0
    } else {
        HEADER + top_h + slices_h + 30.0
    };
    let x0 = MARGIN;
    let x1 = MARGIN + bar * s;
    let _ = writeln!(
        out,
        r##"<g stroke="#000" stroke-width="2"><line x1="{x0:.2}" y1="{y:.2}" x2="{x1:.2}" y2="{y:.2}"/><line x1="{x0:.2}" y1="{:.2}" x2="{x0:.2}" y2="{:.2}"/><line x1="{x1:.2}" y1="{:.2}" x2="{x1:.2}" y2="{:.2}"/></g><text x="{:.2}" y="{:.2}" font-size="12">{} model units</text>"##,
        y - 5.0,
        y + 5.0,
        y - 5.0,
        y + 5.0,
        x1 + 8.0,
        y + 4.0,
        fmt_len(bar)
    );

    // Legend.
    let lx = WIDTH - MARGIN - LEGEND + 10.0;
    let mut ly = HEADER + 4.0;
    let _ = writeln!(
        out,
        r#"<text x="{lx:.1}" y="{ly:.1}" font-size="13" font-weight="bold">cells by volume</text>"#
    );
    ly += 18.0;
    for &i in by_volume.iter().take(LEGEND_ROWS) {
        let c = &doc.cells[i];
        let mut label = format!("cell {}: {}", c.id, pct(i));
        if let Some(t) = notes.truth {
            if holds[i].is_empty() {
                label += ", no room (spike)";
            } else {
                // Room names shortened to their first word ("A (south-west)" becomes "A").
                let names: Vec<&str> = holds[i]
                    .iter()
                    .map(|&r| t.rooms[r].name.split_whitespace().next().unwrap_or(""))
                    .collect();
                let _ = write!(
                    label,
                    ", {} {}",
                    if names.len() == 1 { "room" } else { "rooms" },
                    names.join("+")
                );
            }
        }
        if label.chars().count() > 42 {
            label = label.chars().take(41).collect::<String>() + "…";
        }
        let _ = writeln!(
            out,
            r##"<rect x="{lx:.1}" y="{:.1}" width="14" height="12" fill="{}" fill-opacity="0.8" stroke="#333" stroke-width="0.5"/><text x="{:.1}" y="{:.1}" font-size="12">{}</text>"##,
            ly - 10.0,
            cell_colour(i),
            lx + 20.0,
            ly,
            escape(&label)
        );
        ly += 17.0;
    }
    if doc.cells.len() > LEGEND_ROWS {
        let rest: f64 = by_volume[LEGEND_ROWS..].iter().map(|&i| share(i)).sum();
        let _ = writeln!(
            out,
            r##"<text x="{lx:.1}" y="{ly:.1}" font-size="12" fill="#333">+ {} smaller cells: {rest:.1}%</text>"##,
            doc.cells.len() - LEGEND_ROWS
        );
        ly += 17.0;
    }
    ly += 8.0;
    let _ = writeln!(
        out,
        r##"<line x1="{lx:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="{PORTAL}" stroke-width="3"/><text x="{:.1}" y="{ly:.1}" font-size="12">portal</text>"##,
        ly - 4.0,
        lx + 14.0,
        ly - 4.0,
        lx + 20.0
    );
    ly += 17.0;
    let _ = writeln!(
        out,
        r##"<line x1="{lx:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="#444" stroke-width="1"/><text x="{:.1}" y="{ly:.1}" font-size="12">wall (model polygon)</text>"##,
        ly - 4.0,
        lx + 14.0,
        ly - 4.0,
        lx + 20.0
    );
    ly += 17.0;
    if notes.truth.is_some() {
        let _ = writeln!(
            out,
            r##"<circle cx="{:.1}" cy="{:.1}" r="3.5" fill="white" stroke="#000" stroke-width="1.2"/><text x="{:.1}" y="{ly:.1}" font-size="12">room sample point (truth)</text>"##,
            lx + 7.0,
            ly - 4.0,
            lx + 20.0
        );
        ly += 17.0;
        let _ = writeln!(
            out,
            r##"<line x1="{lx:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="#000" stroke-width="1.5" stroke-dasharray="4 3"/><text x="{:.1}" y="{ly:.1}" font-size="12">doorway (truth)</text>"##,
            ly - 4.0,
            lx + 14.0,
            ly - 4.0,
            lx + 20.0
        );
    }
    out.push_str("</svg>\n");
    out
}

/// Appends cell `i`'s filled path `d` (skipped when empty) with its title.
fn draw_cell(out: &mut String, doc: &ResultDoc, i: usize, d: &str, total: f64) {
    let c = &doc.cells[i];
    if d.is_empty() {
        return;
    }
    // Cells under 1% of the volume are outlined too, so a spike stays visible.
    let outline = if c.volume < 0.01 * total {
        r##" stroke="#000" stroke-width="1.2""##
    } else {
        ""
    };
    let _ = writeln!(
        out,
        r#"<path d="{d}" fill="{}" fill-opacity="0.6" fill-rule="nonzero"{outline}><title>cell {}, volume {:.4}, {} pieces</title></path>"#,
        cell_colour(i),
        c.id,
        c.volume,
        c.pieces.len()
    );
}

/// Draws one panel: cells, walls, portals, truth, labels.
// The run, its notes and the panel's projection, filter and caption: a struct would only
// regroup them for this one private function.
#[allow(clippy::too_many_arguments)]
fn draw_view(
    out: &mut String,
    model: &Model,
    doc: &ResultDoc,
    notes: &Notes<'_>,
    v: &View,
    by_volume: &[usize],
    only: Option<&Storey>,
    caption: &str,
) {
    // A storey panel draws its cells, the portals touching them, and the model polygons,
    // truth points and doorways of its height band (floor, next).
    let tol = model.tolerances.coplanar_abs();
    let in_band = |zlo: f64, zhi: f64| {
        only.is_none_or(|st| {
            if zhi - zlo <= 2.0 * tol {
                // Level (a floor, a point): from the floor up to below the next floor.
                zlo > st.floor - tol && zlo < st.next - tol
            } else {
                zlo < st.next - tol && zhi > st.floor + tol
            }
        })
    };
    let z_range = |pts: &mut dyn Iterator<Item = &P3>| {
        pts.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p[2]), b.max(p[2]))
        })
    };
    let shown_cell = |i: usize| only.is_none_or(|st| st.cells.binary_search(&i).is_ok());
    let shown_id = |id: u32| doc.cells.binary_search_by_key(&id, |c| c.id).is_ok_and(&shown_cell);
    let _ = writeln!(
        out,
        r##"<text x="{:.1}" y="{:.1}" font-size="12" fill="#555">{}</text>"##,
        v.origin.0,
        v.origin.1 - 6.0,
        escape(caption)
    );
    let total: f64 = doc.cells.iter().map(|c| c.volume).sum();
    let _ = writeln!(out, r#"<g class="cells" stroke="none">"#);
    // Each cell's path on every core, a batch at a time (the batch's paths are held until
    // appended in order, so the memory stays a batch's).
    let path_of = |i: usize| {
        let mut d = String::new();
        for p in &doc.cells[i].pieces {
            let h = hull2(p.vertices.iter().map(|q| v.pt(q)).collect());
            if h.len() >= 3 {
                path_d(&mut d, &h);
            }
        }
        d
    };
    let shown: Vec<usize> = by_volume.iter().copied().filter(|&i| shown_cell(i)).collect();
    for batch in shown.chunks(64) {
        let paths: Vec<String> = batch.par_iter().with_max_len(1).map(|&i| path_of(i)).collect();
        for (&i, d) in batch.iter().zip(paths) {
            draw_cell(out, doc, i, &d, total);
        }
    }
    out.push_str("</g>\n");
    // Walls: polygons seen edge-on in this view as lines; those facing the viewer (floors
    // in the top view) as a faint fill. Only one facing, so the fill's subpaths all turn
    // the same way and their union is filled once (a ceiling over a floor would cancel it).
    let mut faint = String::new();
    let mut walls = String::new();
    for (i, p) in model.polygons.iter().enumerate() {
        let n = model.polygon_normal(PolygonId(i as u32));
        let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        if l.is_nan() || l <= 0.0 {
            continue;
        }
        let (zlo, zhi) = z_range(&mut p.verts.iter().map(|q| &model.vertices[q.idx()]));
        if !in_band(zlo, zhi) {
            continue;
        }
        let pts: Vec<(f64, f64)> = p.verts.iter().map(|q| v.pt(&model.vertices[q.idx()])).collect();
        // The top view looks down (-z), the side view along +y.
        let toward = if v.axis == 1 { n[2] } else { -n[1] };
        if toward / l > 0.5 {
            path_d(&mut faint, &pts);
        } else if v.axis == 1 && n[2].abs() / l <= 0.5 {
            path_d(&mut walls, &pts);
        }
    }
    let _ = writeln!(
        out,
        r##"<path d="{faint}" fill="#000" fill-opacity="0.04" stroke="none"/>"##
    );
    if !walls.is_empty() {
        let _ = writeln!(
            out,
            r##"<path d="{walls}" fill="none" stroke="#444" stroke-width="0.6" stroke-linejoin="round"/>"##
        );
    }
    for p in &doc.portals {
        if !(shown_id(p.cells[0]) || shown_id(p.cells[1])) {
            continue;
        }
        let mut d = String::new();
        for poly in &p.polygons {
            let pts: Vec<(f64, f64)> = poly.iter().map(|q| v.pt(q)).collect();
            path_d(&mut d, &pts);
        }
        let _ = writeln!(
            out,
            r#"<path d="{d}" fill="{PORTAL}" fill-opacity="0.3" stroke="{PORTAL}" stroke-width="2.5" stroke-linejoin="round"><title>portal between cells {} and {}, area {:.4}</title></path>"#,
            p.cells[0], p.cells[1], p.area
        );
    }
    if let Some(t) = notes.truth {
        for dw in &t.doorways {
            let (zlo, zhi) = z_range(&mut dw.polygon.iter());
            if !in_band(zlo, zhi) {
                continue;
            }
            let pts: Vec<(f64, f64)> = dw.polygon.iter().map(|q| v.pt(q)).collect();
            let mut d = String::new();
            path_d(&mut d, &pts);
            let _ = writeln!(
                out,
                r##"<path d="{d}" fill="none" stroke="#000" stroke-width="1.5" stroke-dasharray="4 3"/>"##
            );
        }
        for r in &t.rooms {
            let samples: Vec<&P3> = r.samples.iter().filter(|q| in_band(q[2], q[2])).collect();
            for q in &samples {
                let (x, y) = v.pt(q);
                let _ = writeln!(
                    out,
                    r##"<circle cx="{x:.2}" cy="{y:.2}" r="3.5" fill="white" stroke="#000" stroke-width="1.2"/>"##
                );
            }
            if let Some(q) = samples.first() {
                let (x, y) = v.pt(q);
                let _ = writeln!(
                    out,
                    r##"<text x="{:.2}" y="{:.2}" font-size="13" font-weight="bold" stroke="white" stroke-width="3" paint-order="stroke">{}</text>"##,
                    x + 6.0,
                    y - 6.0,
                    escape(&r.name)
                );
            }
        }
    }
    // Cell ids at the volume-weighted centre of their pieces.
    if doc.cells.len() <= MAX_LABELS {
        for (i, c) in doc.cells.iter().enumerate() {
            if !shown_cell(i) {
                continue;
            }
            let mut acc = [0.0; 3];
            let mut w = 0.0;
            for p in &c.pieces {
                if p.vertices.is_empty() {
                    continue;
                }
                let k = p.vertices.len() as f64;
                for (a, x) in acc.iter_mut().enumerate() {
                    *x += p.volume * p.vertices.iter().map(|q| q[a]).sum::<f64>() / k;
                }
                w += p.volume;
            }
            if w <= 0.0 {
                continue;
            }
            let (x, y) = v.pt(&[acc[0] / w, acc[1] / w, acc[2] / w]);
            let _ = writeln!(
                out,
                r##"<text x="{x:.2}" y="{y:.2}" font-size="11" text-anchor="middle" fill="#111" stroke="white" stroke-width="2.5" paint-order="stroke">{}</text>"##,
                c.id
            );
        }
    }
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

const FILE: &str = "cells.svg";

/// Writes the top view of the final cells, `cells.svg`.
pub struct CellsSvg;

impl super::Exporter for CellsSvg {
    fn name(&self) -> &'static str {
        "top view"
    }

    fn files(&self, _: &super::ExportContext<'_>) -> Vec<String> {
        vec![FILE.into()]
    }

    fn owns(&self, file_name: &str) -> bool {
        file_name == FILE
    }

    fn write(&self, ctx: &super::ExportContext<'_>) -> Result<Vec<PathBuf>, super::OutputError> {
        let path = ctx.dir.join(FILE);
        let svg = cells_svg_with(ctx.model, ctx.doc, &ctx.notes);
        super::write_atomic(&path, |tmp| std::fs::write(tmp, svg))?;
        Ok(vec![path])
    }
}

/// Writes the top view of each snapshot, `cells_<N>.svg`.
pub struct Snapshots;

impl super::Exporter for Snapshots {
    fn name(&self) -> &'static str {
        "snapshot top views"
    }

    fn files(&self, ctx: &super::ExportContext<'_>) -> Vec<String> {
        ctx.snapshots.iter().map(|(s, _)| s.file.clone()).collect()
    }

    fn owns(&self, file_name: &str) -> bool {
        file_name.starts_with("cells_") && file_name.ends_with(".svg")
    }

    fn write(&self, ctx: &super::ExportContext<'_>) -> Result<Vec<PathBuf>, super::OutputError> {
        let mut written = Vec::new();
        for (snap, sdoc) in ctx.snapshots {
            let path = ctx.dir.join(&snap.file);
            let svg = cells_svg_with(ctx.model, sdoc, &ctx.notes);
            if let Err(e) = super::write_atomic(&path, |tmp| std::fs::write(tmp, svg)) {
                for p in &written {
                    let _ = std::fs::remove_file(p);
                }
                return Err(e);
            }
            written.push(path);
        }
        Ok(written)
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn fixed2_has_the_bytes_of_the_standard_formatter() {
        let mut rng = crate::base::rng::SplitMix64(7);
        let mut xs: Vec<f64> = vec![
            0.0,
            -0.0,
            0.005,
            -0.005,
            0.015,
            0.125,
            -0.125,
            2.675,
            1.005,
            1e-9,
            -1e-9,
            -0.004,
            -0.006,
            99.995,
            1e15,
            -1e15,
            4.5e13,
            1e300,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        for _ in 0..200_000 {
            let u = rng.next_u64();
            let mag = 10f64.powi((u % 12) as i32 - 4);
            let f = (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
            let x = (f - 0.5) * 2.0 * mag;
            xs.push(x);
            // Exact and near half-hundredths.
            let h = ((u >> 8) % 100_000) as f64 / 200.0 * if u & 1 == 0 { 1.0 } else { -1.0 };
            xs.extend([
                h,
                f64::from_bits(h.to_bits() + 1),
                f64::from_bits(h.to_bits().saturating_sub(1)),
            ]);
            xs.push(f64::from_bits(u));
        }
        for x in xs {
            let mut s = String::new();
            super::push_fixed2(&mut s, x);
            assert_eq!(s, format!("{x:.2}"), "{x:e} ({:#x})", x.to_bits());
        }
    }

    use super::*;

    #[test]
    fn hull_of_a_square_with_an_inner_point() {
        let h = hull2(vec![
            (0.0, 0.0),
            (1.0, 0.0),
            (0.5, 0.5),
            (1.0, 1.0),
            (0.0, 1.0),
            (1.0, 0.0),
        ]);
        assert_eq!(h, vec![(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]);
    }

    #[test]
    fn nice_lengths() {
        assert_eq!(nice_length(3.7), 2.0);
        assert_eq!(nice_length(0.6), 0.5);
        assert_eq!(nice_length(120.0), 100.0);
        assert_eq!(nice_length(55.0), 50.0);
    }
}
