//! Cell-to-cell PVS by portal flow (Quake's `vis`, after Teller & Séquin 1991).
//!
//! Every portal piece between cells `a` and `b` gives two *directed* portals (`a → b` with
//! its plane's normal pointing into `b`, and the reverse). For each directed portal `s` (the
//! *source*) the flow finds the cells some line through `s` may reach: it walks the portal
//! graph depth-first from the cell `s` leads into, and for each next portal `t` keeps only
//! the part of it that such a line can still reach:
//!
//! 1. `t` is chopped to the front of the source's plane, and the source to the back of
//!    `t`'s plane (a line crosses each plane once, in the direction of the normals);
//! 2. from the third portal on, `t` is chopped to the front of the previous portal's plane
//!    and clipped by the *separating planes* through an edge of the source and a vertex of
//!    the previous portal (the pass), in both roles (vis's `ClipToSeperators`): the planes
//!    that put the source on one side and the pass on the other bound the antipenumbra.
//!
//! 3. (with [`PvsSettings::clip_source`], the default) the source is clipped by the same
//!    kind of separating planes between the previous pass and the new one, keeping the part
//!    from which a line can still cross both (ericw-tools' `vis` at its default level).
//!
//! A branch ends when the clipped portal (or source) is empty. The set of cells is a superset of the
//! exact answer (Teller's stabbing lines), since only the source and the pass clip the
//! target. Pruning as in vis: a *base* visibility per directed portal first (a flood fill
//! through the portals that lie partly in front of the source and that the source lies
//! partly behind), then portals in order of increasing base visibility, each branch cut when
//! what it could still see (the intersection of the base or final visibilities along the
//! chain) holds no cell not already found, and each source stops once every cell of its
//! base visibility is found.
//!
//! **A chain never enters a cell twice**, on merged (non-convex) cells too. A sight line
//! from a point of cell `c` crosses portal pieces `q1, q2, …` in order. Where it passes a
//! cell twice (`… X → … → X → Y …`), dropping the pieces between its first entry into `X`
//! and its last exit from `X` leaves a shorter walk of the portal graph that the same line
//! still crosses in order; repeating this (and starting at the last exit from `c`) gives a
//! walk with distinct cells. Every clipping step below only assumes that a line crosses the
//! chain's pieces in order, each from back to front, so the flow keeps that walk, and the
//! cells the line reaches are found. Without the rule a line may zig-zag between two merged
//! cells through their many pieces, and the number of chains explodes (e1m1 at 1000 cells:
//! minutes instead of seconds). [`PvsSettings::revisit_cells`] restores the old rule.
//!
//! Conservative in doubt: points within `epsilon` of a plane count as on it and are kept;
//! planes that do not separate strictly (source or pass coplanar with them) are not used;
//! pieces of (nearly) zero area do not pass the flow but their neighbour is still visible.
//! A cell's interior sees all its own portals (see the [module docs](super)).

use super::{BitSet, PortalGraph};
use crate::base::vec::{P3, cross, dot, norm, sub};
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// PVS settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PvsSettings {
    /// On-plane tolerance relative to the portal graph's bounding-box diagonal (Quake's
    /// `ON_EPSILON` is 0.1 units, about 2.5e-5 of a level's diagonal).
    pub epsilon_rel: f64,
    /// Stop after the base visibility (the flood fill); the result is a coarser PVS.
    pub base_only: bool,
    /// Work bound per source portal, in flow steps. Once a source's flow has taken this
    /// many steps, each further branch that passes the clipping is not followed: every cell
    /// it could still see (the intersection of the bounds along its chain) is marked
    /// visible instead. Conservative, and it bounds the cost of dense graphs (the complex's
    /// own tetrahedral cells), where the number of portal sequences explodes.
    pub max_steps_per_source: u64,
    /// Let a chain re-enter a cell it already passed through (the rule before the flow
    /// learnt that it never needs to; kept to compare against). Off: a chain never enters
    /// a cell twice, on any graph. Conservative for merged (non-convex) cells too: a sight
    /// line that passes cells `… X … X …` also stabs the shorter portal sequence that
    /// leaves `X` through the piece it last left it by, and every cell it reaches is still
    /// found through that sequence (see the module docs).
    pub revisit_cells: bool,
    /// Also clip the *source* by the separating planes between the pass and the new portal
    /// (both roles), as ericw-tools' `vis` does at its default test level: the part of the
    /// source from which a line can still pass both. A smaller source narrows every later
    /// separator, so branches die sooner. Off: only the target is clipped (the rule before,
    /// kept to compare against).
    #[serde(default = "yes")]
    pub clip_source: bool,
    /// Keep `b` in the PVS of `a` only if `a` is also in the PVS of `b`. Sight is
    /// symmetric (a segment from a point of `a` to a point of `b` is one from `b` to `a`),
    /// and each set contains every cell its cell truly sees, so the intersection of a set
    /// with the transposed sets still does: conservative. ericw-tools' `vis` uses the same
    /// symmetry during its flow (`PortalCompleted` / `UpdateMightsee`: once no portal of a
    /// leaf can see leaf X, X's pending portals drop that leaf from their might-see sets).
    /// Off: each cell's flow alone (the rule before, kept to compare against).
    #[serde(default = "yes")]
    pub symmetric: bool,
}

fn yes() -> bool {
    true
}

impl Default for PvsSettings {
    fn default() -> Self {
        PvsSettings {
            epsilon_rel: 1e-6,
            base_only: false,
            max_steps_per_source: 5_000,
            revisit_cells: false,
            clip_source: true,
            symmetric: true,
        }
    }
}

/// Counters and timings of a PVS computation.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PvsStats {
    /// Cells.
    pub cells: usize,
    /// Undirected portals (cell pairs).
    pub portals: usize,
    /// Directed portal pieces (twice the convex pieces).
    pub directed_portals: usize,
    /// Pieces of (nearly) zero area left out of the flow.
    pub degenerate_pieces: usize,
    /// Mean base visibility (cells) per directed portal.
    pub mean_base_vis: f64,
    /// Recursive flow steps (cells entered).
    pub chains: u64,
    /// Source portals whose flow reached [`PvsSettings::max_steps_per_source`].
    pub sources_truncated: usize,
    /// Branches not followed because of it (their bounds marked visible instead).
    pub branches_truncated: u64,
    /// Cell pairs `(a, b)` dropped from `a`'s set because `b`'s set lacks `a`
    /// ([`PvsSettings::symmetric`]).
    #[serde(default)]
    pub asymmetric_dropped: u64,
    /// Seconds for the base visibility.
    pub base_seconds: f64,
    /// Seconds for the portal flow.
    pub flow_seconds: f64,
}

/// Potentially visible sets, one per cell (a cell is always in its own).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pvs {
    /// `sets[c]`: the cells cell `c` may see.
    pub sets: Vec<BitSet>,
    /// Counters and timings.
    pub stats: PvsStats,
}

impl Pvs {
    /// Mean PVS size in cells.
    pub fn mean_size(&self) -> f64 {
        if self.sets.is_empty() {
            return 0.0;
        }
        self.sets.iter().map(|s| s.count()).sum::<usize>() as f64 / self.sets.len() as f64
    }
    /// Largest PVS size in cells.
    pub fn max_size(&self) -> usize {
        self.sets.iter().map(|s| s.count()).max().unwrap_or(0)
    }
    /// Whether `a` may see `b`.
    pub fn sees(&self, a: usize, b: usize) -> bool {
        self.sets[a].contains(b)
    }
}

#[derive(Clone, Debug)]
struct DPortal {
    to: u32,
    piece: u32,
    poly: Vec<P3>,
    n: P3,
    d: f64,
}

/// Chops `w` to the front of `n·x = d` (points within `eps` count as on it and are kept).
/// `None` when nothing is strictly in front.
fn chop(w: &[P3], n: &P3, d: f64, eps: f64) -> Option<Vec<P3>> {
    let mut dist = [0.0f64; 64];
    let mut big = Vec::new();
    let ds: &mut [f64] = if w.len() <= 64 {
        &mut dist[..w.len()]
    } else {
        big.resize(w.len(), 0.0);
        &mut big
    };
    let (mut front, mut back) = (false, false);
    for (k, p) in w.iter().enumerate() {
        let s = dot(n, p) - d;
        ds[k] = s;
        front |= s > eps;
        back |= s < -eps;
    }
    if !back {
        return Some(w.to_vec());
    }
    if !front {
        return None;
    }
    let mut out = Vec::with_capacity(w.len() + 2);
    for i in 0..w.len() {
        let j = (i + 1) % w.len();
        let (a, b) = (ds[i], ds[j]);
        if a >= -eps {
            out.push(w[i]);
        }
        if (a > eps && b < -eps) || (a < -eps && b > eps) {
            let t = a / (a - b);
            let (p, q) = (&w[i], &w[j]);
            out.push([
                p[0] + t * (q[0] - p[0]),
                p[1] + t * (q[1] - p[1]),
                p[2] + t * (q[2] - p[2]),
            ]);
        }
    }
    (out.len() >= 3).then_some(out)
}

/// Clips `target` by the planes through an edge of `source` and a vertex of `pass` that
/// have all of `source` on one side and all of `pass` on the other, keeping the pass side
/// (or, with `flip`, the source side). vis's `ClipToSeperators`.
fn clip_to_separators(source: &[P3], pass: &[P3], mut target: Vec<P3>, flip: bool, eps: f64) -> Option<Vec<P3>> {
    let ns = source.len();
    for i in 0..ns {
        let l = (i + 1) % ns;
        let v1 = sub(&source[l], &source[i]);
        for (j, pj) in pass.iter().enumerate() {
            let v2 = sub(pj, &source[i]);
            let mut n = cross(&v1, &v2);
            let len = norm(&n);
            // Not a valid plane (pass vertex on the source edge's line): skip.
            if len <= eps * (norm(&v1) + norm(&v2)).max(f64::MIN_POSITIVE) {
                continue;
            }
            n = [n[0] / len, n[1] / len, n[2] / len];
            let mut d = dot(&n, pj);
            // Which side is the source on?
            let mut flip_test = None;
            for (k, sk) in source.iter().enumerate() {
                if k == i || k == l {
                    continue;
                }
                let s = dot(&n, sk) - d;
                if s < -eps {
                    flip_test = Some(false);
                    break;
                } else if s > eps {
                    flip_test = Some(true);
                    break;
                }
            }
            let Some(flip_test) = flip_test else { continue }; // coplanar with the source
            if flip_test {
                n = [-n[0], -n[1], -n[2]];
                d = -d;
            }
            // All of the pass on the positive side (some strictly)?
            let mut strict = false;
            let mut ok = true;
            for (k, pk) in pass.iter().enumerate() {
                if k == j {
                    continue;
                }
                let s = dot(&n, pk) - d;
                if s < -eps {
                    ok = false;
                    break;
                }
                strict |= s > eps;
            }
            if !ok || !strict {
                continue;
            }
            if flip {
                n = [-n[0], -n[1], -n[2]];
                d = -d;
            }
            target = chop(&target, &n, d, eps)?;
        }
    }
    Some(target)
}

struct Frame<'a> {
    source: Vec<P3>,
    pass: Option<Vec<P3>>,
    n: P3,
    d: f64,
    /// Depth of this frame's `might` words in [`Flow::mights`].
    depth: usize,
    _p: std::marker::PhantomData<&'a ()>,
}

struct Flow<'a> {
    dp: &'a [DPortal],
    out: &'a [Vec<u32>],
    /// Per directed portal, `words` words: its final visibility once computed, else its
    /// base visibility (one array: the flow reads these at every step).
    bounds: &'a [u64],
    on_stack: Vec<bool>,
    vis: BitSet,
    /// The root's base visibility: once `vis` holds all of it, the source is done.
    root_might: &'a [u64],
    done: bool,
    /// `might` bitsets by chain depth, `words` each (grown on demand, never freed).
    mights: Vec<u64>,
    words: usize,
    eps: f64,
    root_n: P3,
    root_d: f64,
    chains: u64,
    budget: u64,
    truncated: u64,
    /// Never re-enter a cell of the current chain (see [`PvsSettings::revisit_cells`]).
    no_reentry: bool,
    /// [`PvsSettings::clip_source`].
    clip_source: bool,
    cell_on_stack: Vec<bool>,
}

impl Flow<'_> {
    fn mark(&mut self, cell: u32) {
        if self.vis.insert(cell as usize) {
            self.done = self.root_might.iter().zip(self.vis.words()).all(|(m, v)| m & !v == 0);
        }
    }

    fn flow(&mut self, cell: u32, prev: &Frame) {
        self.chains += 1;
        self.mark(cell);
        let words = self.words;
        let (lo, hi) = ((prev.depth + 1) * words, (prev.depth + 2) * words);
        if self.mights.len() < hi {
            self.mights.resize(hi, 0);
        }
        for &pi in &self.out[cell as usize] {
            if self.done {
                return;
            }
            let p = &self.dp[pi as usize];
            let prev_might = &self.mights[prev.depth * words..lo];
            if self.on_stack[p.piece as usize]
                || (self.no_reentry && self.cell_on_stack[p.to as usize])
                || prev_might[p.to as usize / 64] & (1 << (p.to % 64)) == 0
            {
                continue;
            }
            let test = &self.bounds[pi as usize * words..(pi as usize + 1) * words];
            let vw = self.vis.words();
            if !(0..words).any(|k| prev_might[k] & test[k] & !vw[k] != 0) {
                continue;
            }
            // A line cannot leave through a plane facing back the way it came.
            if dot(&prev.n, &p.n) < -1.0 + 1e-12 {
                continue;
            }
            let Some(pass) = chop(&p.poly, &self.root_n, self.root_d, self.eps) else {
                continue;
            };
            let Some(source) = chop(&prev.source, &[-p.n[0], -p.n[1], -p.n[2]], -p.d, self.eps) else {
                continue;
            };
            let pass = match &prev.pass {
                None => pass,
                Some(prev_pass) => {
                    let Some(pass) = chop(&pass, &prev.n, prev.d, self.eps) else {
                        continue;
                    };
                    let Some(pass) = clip_to_separators(&source, prev_pass, pass, false, self.eps) else {
                        continue;
                    };
                    let Some(pass) = clip_to_separators(prev_pass, &source, pass, true, self.eps) else {
                        continue;
                    };
                    pass
                }
            };
            // The part of the source that still sees the new pass through the previous one.
            let source = match (&prev.pass, self.clip_source) {
                (Some(prev_pass), true) => {
                    let Some(source) = clip_to_separators(&pass, prev_pass, source, false, self.eps) else {
                        continue;
                    };
                    let Some(source) = clip_to_separators(prev_pass, &pass, source, true, self.eps) else {
                        continue;
                    };
                    source
                }
                _ => source,
            };
            {
                let (prev_might, might) = self.mights.split_at_mut(lo);
                let prev_might = &prev_might[prev.depth * words..];
                for k in 0..words {
                    might[k] = prev_might[k] & test[k];
                }
            }
            if self.chains >= self.budget {
                // Out of budget: everything this branch could still see is visible.
                self.truncated += 1;
                let m = &self.mights[lo..hi];
                for (v, m) in self.vis.words_mut().iter_mut().zip(m) {
                    *v |= m;
                }
                self.done = self.root_might.iter().zip(self.vis.words()).all(|(m, v)| m & !v == 0);
                continue;
            }
            let frame = Frame {
                source,
                pass: Some(pass),
                n: p.n,
                d: p.d,
                depth: prev.depth + 1,
                _p: std::marker::PhantomData,
            };
            let (to, piece) = (p.to, p.piece as usize);
            self.on_stack[piece] = true;
            self.cell_on_stack[to as usize] = true;
            self.flow(to, &frame);
            self.cell_on_stack[to as usize] = false;
            self.on_stack[piece] = false;
        }
    }
}

/// Computes the PVS of every cell of `graph`.
pub fn compute(graph: &PortalGraph, settings: &PvsSettings) -> Pvs {
    // Deep chains recurse deeply: run on a thread with a large stack.
    std::thread::scope(|s| {
        std::thread::Builder::new()
            .stack_size(512 << 20)
            .spawn_scoped(s, || compute_inner(graph, settings))
            .expect("cannot spawn the PVS thread")
            .join()
            .expect("PVS thread panicked")
    })
}

fn compute_inner(graph: &PortalGraph, settings: &PvsSettings) -> Pvs {
    let n = graph.cells;
    let eps = settings.epsilon_rel * graph.diagonal();
    let area_min = (eps * eps).max(f64::MIN_POSITIVE);
    let mut stats = PvsStats {
        cells: n,
        portals: graph.portals.len(),
        ..Default::default()
    };
    let mut sets: Vec<BitSet> = (0..n)
        .map(|c| {
            let mut b = BitSet::new(n);
            b.insert(c);
            b
        })
        .collect();
    // Directed portals.
    let mut dp = Vec::new();
    let mut out: Vec<Vec<u32>> = vec![Vec::new(); n];
    let mut piece = 0u32;
    for gp in &graph.portals {
        let [a, b] = gp.cells;
        sets[a as usize].insert(b as usize);
        sets[b as usize].insert(a as usize);
        for q in &gp.pieces {
            let nv = crate::base::vec::fan_normal(q);
            let len = norm(&nv);
            if q.len() < 3 || !len.is_finite() || 0.5 * len <= area_min {
                stats.degenerate_pieces += 1;
                continue;
            }
            let nn = [nv[0] / len, nv[1] / len, nv[2] / len];
            let c = crate::base::vec::mean(q);
            let d = dot(&nn, &c);
            out[a as usize].push(dp.len() as u32);
            dp.push(DPortal {
                to: b,
                piece,
                poly: q.clone(),
                n: nn,
                d,
            });
            let mut r = q.clone();
            r[1..].reverse();
            out[b as usize].push(dp.len() as u32);
            dp.push(DPortal {
                to: a,
                piece,
                poly: r,
                n: [-nn[0], -nn[1], -nn[2]],
                d: -d,
            });
            piece += 1;
        }
    }
    stats.directed_portals = dp.len();
    // Largest pieces first: they find most, so their siblings are cut sooner.
    let area = |p: &DPortal| norm(&crate::base::vec::fan_normal(&p.poly));
    for o in &mut out {
        o.sort_by(|&a, &b| area(&dp[b as usize]).total_cmp(&area(&dp[a as usize])).then(a.cmp(&b)));
    }
    // Base visibility: flood through portals partly in front of the source that the source
    // lies partly behind.
    let t0 = Instant::now();
    // Conservative in doubt, as `chop` is: a portal within `eps` of the source's plane (or a
    // source within `eps` of the target's) is kept. With strict `> eps` / `< -eps`, two
    // nearly coplanar overlapping portals (a crack cell on a folded wall of e1m1, refined /
    // bbox at cells:300) dropped the room behind: 418 false invisibles of 307,200 rays.
    let front_of = |p: &DPortal, t: &DPortal| -> bool {
        t.poly.iter().any(|v| dot(&p.n, v) - p.d > -eps) && p.poly.iter().any(|v| dot(&t.n, v) - t.d < eps)
    };
    let mut base = Vec::with_capacity(dp.len());
    let mut stack = Vec::new();
    for p in &dp {
        let mut seen = BitSet::new(n);
        seen.insert(p.to as usize);
        stack.clear();
        stack.push(p.to);
        while let Some(c) = stack.pop() {
            for &ti in &out[c as usize] {
                let t = &dp[ti as usize];
                if t.piece != p.piece && !seen.contains(t.to as usize) && front_of(p, t) {
                    seen.insert(t.to as usize);
                    stack.push(t.to);
                }
            }
        }
        base.push(seen);
    }
    stats.base_seconds = t0.elapsed().as_secs_f64();
    if !dp.is_empty() {
        stats.mean_base_vis = base.iter().map(|b| b.count()).sum::<usize>() as f64 / dp.len() as f64;
    }
    let from: Vec<u32> = {
        let mut f = vec![0u32; dp.len()];
        for (c, ps) in out.iter().enumerate() {
            for &p in ps {
                f[p as usize] = c as u32;
            }
        }
        f
    };
    if settings.base_only {
        for (k, b) in base.iter().enumerate() {
            sets[from[k] as usize].union_with(b);
        }
        if settings.symmetric {
            stats.asymmetric_dropped = symmetrize(&mut sets);
        }
        return Pvs { sets, stats };
    }
    // Portal flow, fewest base-visible cells first.
    let t0 = Instant::now();
    let mut order: Vec<usize> = (0..dp.len()).collect();
    order.sort_by_key(|&k| (base[k].count(), k));
    let words = n.div_ceil(64);
    let mut bounds = vec![0u64; dp.len() * words];
    for (k, b) in base.iter().enumerate() {
        bounds[k * words..(k + 1) * words].copy_from_slice(b.words());
    }
    let mut on_stack = vec![false; piece as usize];
    let mut cell_on_stack = vec![false; n];
    let mut mights: Vec<u64> = Vec::new();
    for &k in &order {
        let s = &dp[k];
        let mut flow = Flow {
            dp: &dp,
            out: &out,
            bounds: &bounds,
            on_stack: std::mem::take(&mut on_stack),
            vis: BitSet::new(n),
            root_might: base[k].words(),
            done: false,
            mights: std::mem::take(&mut mights),
            words,
            eps,
            root_n: s.n,
            root_d: s.d,
            chains: 0,
            budget: settings.max_steps_per_source,
            truncated: 0,
            no_reentry: graph.convex_cells || !settings.revisit_cells,
            clip_source: settings.clip_source,
            cell_on_stack: std::mem::take(&mut cell_on_stack),
        };
        if flow.mights.len() < words {
            flow.mights.resize(words, 0);
        }
        flow.mights[..words].copy_from_slice(base[k].words());
        let root = Frame {
            source: s.poly.clone(),
            pass: None,
            n: s.n,
            d: s.d,
            depth: 0,
            _p: std::marker::PhantomData,
        };
        flow.on_stack[s.piece as usize] = true;
        flow.cell_on_stack[from[k] as usize] = true;
        flow.cell_on_stack[s.to as usize] = true;
        flow.done = flow.root_might.iter().zip(flow.vis.words()).all(|(m, v)| m & !v == 0);
        if !flow.done {
            flow.flow(s.to, &root);
        }
        flow.cell_on_stack[s.to as usize] = false;
        flow.cell_on_stack[from[k] as usize] = false;
        flow.on_stack[s.piece as usize] = false;
        mights = std::mem::take(&mut flow.mights);
        stats.chains += flow.chains;
        stats.sources_truncated += (flow.truncated > 0) as usize;
        stats.branches_truncated += flow.truncated;
        on_stack = flow.on_stack;
        cell_on_stack = flow.cell_on_stack;
        let vis = flow.vis;
        bounds[k * words..(k + 1) * words].copy_from_slice(vis.words());
        sets[from[k] as usize].union_with(&vis);
    }
    if settings.symmetric {
        stats.asymmetric_dropped = symmetrize(&mut sets);
    }
    stats.flow_seconds = t0.elapsed().as_secs_f64();
    Pvs { sets, stats }
}

/// Drops `b` from `sets[a]` when `a` is not in `sets[b]`; returns how many pairs it dropped.
fn symmetrize(sets: &mut [BitSet]) -> u64 {
    let drop: Vec<(usize, usize)> = (0..sets.len())
        .flat_map(|a| {
            let sets = &*sets;
            sets[a]
                .iter()
                .filter(move |&b| !sets[b].contains(a))
                .map(move |b| (a, b))
        })
        .collect();
    for &(a, b) in &drop {
        sets[a].words_mut()[b / 64] &= !(1u64 << (b % 64));
    }
    drop.len() as u64
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::visibility::GraphPortal;

    fn square(x: f64, y0: f64, y1: f64, z0: f64, z1: f64) -> Vec<P3> {
        // Normal +x: counter-clockwise seen from +x.
        vec![[x, y0, z0], [x, y1, z0], [x, y1, z1], [x, y0, z1]]
    }

    #[test]
    fn chop_keeps_front() {
        let w = square(0.0, 0.0, 1.0, 0.0, 1.0);
        let c = chop(&w, &[0.0, 1.0, 0.0], 0.5, 1e-9).unwrap();
        assert!(c.iter().all(|p| p[1] >= 0.5 - 1e-12));
        assert!(chop(&w, &[0.0, 1.0, 0.0], 2.0, 1e-9).is_none());
        assert_eq!(chop(&w, &[0.0, 1.0, 0.0], -1.0, 1e-9).unwrap(), w);
    }

    /// Cells 0..4 in a row along x, separated by unit square portals at x = 1, 2, 3; the
    /// last portal is shifted in y so far that no line passes all three.
    #[test]
    fn row_of_portals() {
        let mk = |shift: f64| PortalGraph {
            cells: 4,
            convex_cells: true,
            portals: vec![
                GraphPortal {
                    cells: [0, 1],
                    pieces: vec![square(1.0, 0.0, 1.0, 0.0, 1.0)],
                },
                GraphPortal {
                    cells: [1, 2],
                    pieces: vec![square(2.0, 0.0, 1.0, 0.0, 1.0)],
                },
                GraphPortal {
                    cells: [2, 3],
                    pieces: vec![square(3.0, shift, shift + 1.0, 0.0, 1.0)],
                },
            ],
        };
        let pvs = compute(&mk(0.0), &PvsSettings::default());
        assert!(pvs.sees(0, 3) && pvs.sees(3, 0));
        // Lines through y in [0,1] at x = 1 and at x = 2 reach y in [-1, 2] at x = 3.
        let pvs = compute(&mk(1.5), &PvsSettings::default());
        assert!(pvs.sees(0, 3), "shift 1.5 is still visible");
        let pvs = compute(&mk(2.5), &PvsSettings::default());
        assert!(!pvs.sees(0, 3) && !pvs.sees(3, 0));
        assert!(pvs.sees(0, 2) && pvs.sees(1, 3));
    }

    /// The symmetric rule: `b` stays in `a`'s set only if `a` is in `b`'s.
    #[test]
    fn symmetrize_keeps_mutual_pairs_only() {
        let mut sets: Vec<BitSet> = (0..3).map(|_| BitSet::new(3)).collect();
        for (a, b) in [(0, 0), (1, 1), (2, 2), (0, 1), (1, 0), (0, 2)] {
            sets[a].insert(b);
        }
        assert_eq!(symmetrize(&mut sets), 1);
        assert!(sets[0].contains(1) && sets[1].contains(0) && !sets[0].contains(2));
        assert_eq!(sets.iter().map(|s| s.count()).sum::<usize>(), 5);
        // A second pass finds nothing.
        assert_eq!(symmetrize(&mut sets), 0);
    }

    /// Regression (5194a07): two overlapping portals closer than the on-plane tolerance —
    /// a crack cell between them, as on e1m1's folded walls. Cells 0 | 1 | 2 along x, the
    /// unit square portals at x = 1 and x = 1 + δ with δ below `epsilon_rel` × diagonal.
    /// The sight line from (0, 0.5, 0.5) along (1, 0.1, 0) crosses x = 1 at y = 0.6 and
    /// x = 1 + δ at y ≈ 0.6, inside both squares: cell 0 sees cell 2. The old base
    /// visibility asked for a vertex of the next portal *more* than ε in front of the
    /// source (and of the source more than ε behind the next), so the second portal, all
    /// within ε of the first's plane, was dropped with cell 2 behind it.
    #[test]
    fn stacked_portals_closer_than_the_tolerance_stay_visible() {
        let s = PvsSettings::default();
        for delta in [0.0, 1e-9, 1e-7] {
            for shift in [0.0, 0.3] {
                let g = PortalGraph {
                    cells: 3,
                    convex_cells: false,
                    portals: vec![
                        GraphPortal {
                            cells: [0, 1],
                            pieces: vec![square(1.0, 0.0, 1.0, 0.0, 1.0)],
                        },
                        GraphPortal {
                            cells: [1, 2],
                            pieces: vec![square(1.0 + delta, shift, 1.0 + shift, 0.0, 1.0)],
                        },
                    ],
                };
                // The gap is below the tolerance.
                assert!(delta < s.epsilon_rel * g.diagonal());
                let pvs = compute(&g, &s);
                assert!(pvs.sees(0, 2) && pvs.sees(2, 0), "delta {delta}, shift {shift}");
                let base = compute(&g, &PvsSettings { base_only: true, ..s });
                assert!(base.sees(0, 2) && base.sees(2, 0), "base: delta {delta}, shift {shift}");
            }
        }
    }
}
