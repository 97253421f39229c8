//! Walkthroughs as Aliaga & Lastra measured them: a deterministic camera path through the
//! cells and, per frame, the triangles rendered under
//!
//! - **view-frustum culling** only: every model triangle that meets the view frustum;
//! - **portal culling** (Luebke & Georges 1995): the camera's cell is drawn with the view
//!   frustum; each of its portal pieces that the frustum sees narrows it, and the cell
//!   behind is drawn with the narrowed frustum, recursively;
//! - **portal textures** (Aliaga & Lastra): as portal culling up to portal depth `k`; a
//!   portal one deeper is drawn as one textured quad, 2 triangles, instead of what lies
//!   behind it (each portal — cell pair — counted once per frame).
//!
//! How a narrowed frustum is represented is a [`Window`]: [`ExactWindow`] (the portal
//! clipped to the frustum, exactly, as a convex polygon of planes through the eye) and
//! [`RectWindow`] (Luebke & Georges's screen-space bounding rectangle). Both are
//! conservative (a triangle seen through the portal sequence is drawn); other
//! representations (k-gons, per-pixel masks) implement the same trait.
//!
//! Counting: a triangle is counted once per frame however many windows see it (a renderer
//! marks what it drew). A triangle is drawn when it meets the frustum (clipped, not just
//! its bounding box); no back-face or occlusion culling. The camera never looks through a
//! portal piece whose plane it is in front of; when it stands on a piece (it passes through
//! portal centres), that piece passes the frustum unchanged. A chain never re-enters a
//! cell it already passed (as in [`super::pvs`]).
//!
//! **Path.** From the largest cell, a depth-first tour of the portal graph (neighbours by
//! index, each cell entered once, and back the same way). Each crossing goes through the
//! centre of the largest portal piece between the two cells; inside a cell the path runs
//! between the centroids of its convex pieces (complex cells) through the centres of the
//! faces they share, so every point lies inside the cell. The camera moves along it at a
//! fixed step and looks at the point `lookahead` further along the path (no roll: `up` is
//! the model's up axis).

use super::PortalGraph;
use super::cost::CellPolygons;
use super::kgon::{HullWindow, KgonWindow};
use super::mask::MaskWindow;
use crate::CellId;
use crate::base::vec::{P3, cross, dot, norm, sub};
use crate::complex::CellComplex;
use crate::model::Model;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;
use std::time::Instant;

/// Walkthrough settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct WalkSettings {
    /// Distance between frames, relative to the model's bounding-box diagonal.
    pub step_rel: f64,
    /// At most this many frames (the step grows to fit).
    pub max_frames: usize,
    /// The camera looks at the path point this far ahead (relative to the diagonal).
    pub lookahead_rel: f64,
    /// Horizontal field of view, degrees.
    pub fov_deg: f64,
    /// Height / width of the image.
    pub aspect: f64,
    /// Up axis (0, 1, 2 = x, y, z).
    pub up_axis: usize,
    /// Portal depths `k` of the portal-texture runs (portals deeper than `k` are quads).
    pub texture_depths: [usize; 2],
    /// Camera roll about the view direction, degrees (0: level; the tilted walkthrough of
    /// the thesis's figure 2.13 case rolls it so axis-aligned doors are not screen-aligned).
    #[serde(default)]
    pub roll_deg: f64,
    /// Roll of the second, tilted walkthrough that evaluations add (0: none).
    #[serde(default)]
    pub tilted_roll_deg: f64,
    /// Width in pixels of the per-pixel portal masks ([`super::mask`]); the height follows
    /// the aspect.
    #[serde(default = "default_mask_width")]
    pub mask_width: usize,
}

fn default_mask_width() -> usize {
    256
}

impl Default for WalkSettings {
    fn default() -> Self {
        WalkSettings {
            step_rel: 0.002,
            max_frames: 2000,
            lookahead_rel: 0.02,
            fov_deg: 90.0,
            aspect: 0.75,
            up_axis: 2,
            texture_depths: [0, 1],
            roll_deg: 0.0,
            tilted_roll_deg: 30.0,
            mask_width: default_mask_width(),
        }
    }
}

/// A pinhole camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye.
    pub eye: P3,
    /// Unit view direction.
    pub forward: P3,
    /// Unit right vector.
    pub right: P3,
    /// Unit up vector (orthogonal to both).
    pub up: P3,
    /// tan(horizontal half-angle).
    pub tan_x: f64,
    /// tan(vertical half-angle).
    pub tan_y: f64,
    /// Near distance (points closer along `forward` are not drawn).
    pub near: f64,
    /// Contact tolerance (world units, `near / 1000`): a triangle or portal that meets the
    /// exact window only within this distance of its boundary (a wall sharing a door's
    /// edge) is not drawn; a conservative window counts what comes within it.
    pub tol: f64,
    /// Resolution `[width, height]` of the per-pixel portal masks ([`super::mask`]).
    pub mask_px: [usize; 2],
}

impl Camera {
    /// A camera at `eye` looking along `dir` (any length), with the world axis `up_axis`
    /// as up where possible.
    pub fn looking(eye: P3, dir: P3, up_axis: usize, fov_deg: f64, aspect: f64, near: f64) -> Self {
        let f = unit(dir).unwrap_or([1.0, 0.0, 0.0]);
        let mut upw = [0.0; 3];
        upw[up_axis.min(2)] = 1.0;
        let r = unit(cross(&f, &upw))
            .or_else(|| unit(cross(&f, &[1.0, 0.0, 0.0])))
            .or_else(|| unit(cross(&f, &[0.0, 1.0, 0.0])))
            .expect("some axis is not parallel");
        let u = cross(&r, &f);
        let tan_x = (fov_deg.to_radians() / 2.0).tan();
        Camera {
            eye,
            forward: f,
            right: r,
            up: u,
            tan_x,
            tan_y: tan_x * aspect,
            near,
            tol: near * 1e-3,
            mask_px: [256, mask_height(256, aspect)],
        }
    }

    /// The same camera with masks `width` pixels wide (at least 1).
    pub fn with_mask_width(mut self, width: usize) -> Self {
        let aspect = self.tan_y / self.tan_x;
        let w = width.max(1);
        self.mask_px = [w, mask_height(w, aspect)];
        self
    }

    /// The same camera rolled by `deg` degrees about its view direction.
    pub fn rolled(mut self, deg: f64) -> Self {
        if deg != 0.0 {
            let (s, c) = deg.to_radians().sin_cos();
            let (r, u) = (self.right, self.up);
            self.right = std::array::from_fn(|i| c * r[i] + s * u[i]);
            self.up = std::array::from_fn(|i| -s * r[i] + c * u[i]);
        }
        self
    }

    /// The ray direction through screen point `s` (tangent coordinates).
    pub fn dir(&self, s: &[f64; 2]) -> P3 {
        std::array::from_fn(|i| self.forward[i] + s[0] * self.right[i] + s[1] * self.up[i])
    }

    /// Depth of `p` along the view direction.
    pub fn depth(&self, p: &P3) -> f64 {
        dot(&sub(p, &self.eye), &self.forward)
    }

    /// Screen coordinates (tangent space: x/z, y/z) of a point in front of the camera.
    pub fn screen(&self, p: &P3) -> [f64; 2] {
        let v = sub(p, &self.eye);
        let z = dot(&v, &self.forward);
        [dot(&v, &self.right) / z, dot(&v, &self.up) / z]
    }

    /// The near plane (inside: `n·x ≥ d`).
    pub fn near_plane(&self) -> Plane {
        Plane {
            n: self.forward,
            d: dot(&self.forward, &self.eye) + self.near,
        }
    }

    /// The plane through the eye whose inside is `x_s ≥ a` (`axis` 0) or `y_s ≥ a` (1),
    /// flipped (`≤`) with `below`.
    fn screen_plane(&self, axis: usize, a: f64, below: bool) -> Plane {
        let e = if axis == 0 { self.right } else { self.up };
        let mut n = [
            e[0] - a * self.forward[0],
            e[1] - a * self.forward[1],
            e[2] - a * self.forward[2],
        ];
        if below {
            n = [-n[0], -n[1], -n[2]];
        }
        Plane {
            n,
            d: dot(&n, &self.eye),
        }
    }
}

fn mask_height(width: usize, aspect: f64) -> usize {
    let h = (width as f64 * aspect).round();
    if h.is_finite() && h >= 1.0 { h as usize } else { 1 }
}

fn unit(v: P3) -> Option<P3> {
    let l = norm(&v);
    (l > 1e-12 && l.is_finite()).then(|| [v[0] / l, v[1] / l, v[2] / l])
}

/// A half-space `n·x ≥ d`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// Normal (pointing inside; any length).
    pub n: P3,
    /// Offset.
    pub d: f64,
}

/// Operation counts of the culling itself (for comparing representations).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Ops {
    /// Polygon–plane clips.
    pub plane_clips: u64,
    /// Windows narrowed through a portal.
    pub narrows: u64,
    /// Triangle tests.
    pub triangle_tests: u64,
    /// Vertices processed by the clips (3D polygon–plane and 2D screen clips).
    pub vertices: u64,
    /// Bounding-sphere pre-rejections (k-gon windows: portals and triangles rejected
    /// without clipping).
    pub sphere_rejects: u64,
    /// 2D work of the screen-polygon windows: hull, intersection and edge-removal steps.
    pub screen_ops: u64,
    /// Mask windows: pixels spanned by the conservative rasters (portals and triangles).
    pub mask_pixels: u64,
    /// Mask windows: 64-pixel words read or combined (triangle tests, mask intersections).
    pub mask_words: u64,
}

/// Keeps the part of `poly` inside every plane (`None` when nothing is left).
pub fn clip(poly: &[P3], planes: &[Plane], ops: &mut Ops) -> Option<Vec<P3>> {
    clip_tol(poly, planes, 0.0, ops)
}

/// [`clip`] with a contact tolerance: `None` as soon as no vertex lies more than `tol`
/// inside a plane. `tol > 0` is strict (what only touches a plane within `tol` is gone);
/// `tol < 0` is lenient (what lies within `-tol` outside a plane is kept, unclipped).
/// Between a strict test on a window and a lenient one on a window containing it, rounding
/// cannot make the smaller window see what the larger one does not.
pub fn clip_tol(poly: &[P3], planes: &[Plane], tol: f64, ops: &mut Ops) -> Option<Vec<P3>> {
    let mut cur = poly.to_vec();
    let mut next = Vec::with_capacity(poly.len() + 4);
    for pl in planes {
        ops.plane_clips += 1;
        ops.vertices += cur.len() as u64;
        let nl = norm(&pl.n).max(f64::MIN_POSITIVE);
        let dist: Vec<f64> = cur.iter().map(|p| (dot(&pl.n, p) - pl.d) / nl).collect();
        let max = dist.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if max <= tol {
            return None;
        }
        if max <= 0.0 || dist.iter().all(|&s| s >= 0.0) {
            continue;
        }
        next.clear();
        for i in 0..cur.len() {
            let j = (i + 1) % cur.len();
            let (a, b) = (dist[i], dist[j]);
            if a >= 0.0 {
                next.push(cur[i]);
            }
            if (a > 0.0 && b < 0.0) || (a < 0.0 && b > 0.0) {
                let t = a / (a - b);
                let (p, q) = (&cur[i], &cur[j]);
                next.push([
                    p[0] + t * (q[0] - p[0]),
                    p[1] + t * (q[1] - p[1]),
                    p[2] + t * (q[2] - p[2]),
                ]);
            }
        }
        if next.len() < 3 {
            return None;
        }
        std::mem::swap(&mut cur, &mut next);
    }
    Some(cur)
}

/// How a frustum narrowed through portals is represented.
pub trait Window: Clone {
    /// Name in tables and CSV headers.
    const NAME: &'static str;
    /// Whether the renderer narrows through a merged portal's pieces together, once per
    /// portal ([`Window::narrow_portal`]), instead of piece by piece ([`Window::narrow`]).
    const MERGED: bool = false;
    /// The whole view frustum.
    fn view(cam: &Camera) -> Self;
    /// The window narrowed through the portal polygon `portal` (world coordinates, already
    /// known to face away from the eye); `None` when the window does not see it.
    fn narrow(&self, cam: &Camera, portal: &[P3], ops: &mut Ops) -> Option<Self>;
    /// The window narrowed through a whole merged portal: its pieces that face away from
    /// the eye (at least one), as one surface. The default keeps the window unchanged for
    /// several pieces (conservative); merged representations override it.
    fn narrow_portal(&self, cam: &Camera, pieces: &[&[P3]], ops: &mut Ops) -> Option<Self> {
        match pieces {
            [one] => self.narrow(cam, one, ops),
            _ => Some(self.clone()),
        }
    }
    /// Whether a triangle meets the window.
    fn sees(&self, cam: &Camera, tri: &[P3; 3], ops: &mut Ops) -> bool;
}

/// The exact window: the convex region of planes through the eye and the edges of the
/// portal polygons clipped along the chain (plus the near plane).
#[derive(Clone, Debug, PartialEq)]
pub struct ExactWindow {
    /// Inside = all planes.
    pub planes: Vec<Plane>,
}

impl Window for ExactWindow {
    const NAME: &'static str = "exact";

    fn view(cam: &Camera) -> Self {
        ExactWindow {
            planes: vec![
                cam.near_plane(),
                cam.screen_plane(0, -cam.tan_x, false),
                cam.screen_plane(0, cam.tan_x, true),
                cam.screen_plane(1, -cam.tan_y, false),
                cam.screen_plane(1, cam.tan_y, true),
            ],
        }
    }

    fn narrow(&self, cam: &Camera, portal: &[P3], ops: &mut Ops) -> Option<Self> {
        ops.narrows += 1;
        let q = clip_tol(portal, &self.planes, cam.tol, ops)?;
        let mut planes = vec![cam.near_plane()];
        // The portal is counter-clockwise around its normal and the eye is behind it, so
        // (q_i − e) × (q_{i+1} − e) points into the window for every edge (the sign of
        // det[q_i − e, q_{i+1} − e, c − e] for an interior point c is that of the eye's
        // depth behind the plane); no per-edge orientation test, which fails edge-on.
        for i in 0..q.len() {
            let j = (i + 1) % q.len();
            let n = cross(&sub(&q[i], &cam.eye), &sub(&q[j], &cam.eye));
            if norm(&n) <= 1e-300 {
                continue;
            }
            planes.push(Plane {
                n,
                d: dot(&n, &cam.eye),
            });
        }
        Some(ExactWindow { planes })
    }

    fn sees(&self, cam: &Camera, tri: &[P3; 3], ops: &mut Ops) -> bool {
        ops.triangle_tests += 1;
        clip_tol(tri, &self.planes, cam.tol, ops).is_some()
    }
}

/// Luebke & Georges's window: an axis-aligned screen rectangle (tangent coordinates),
/// intersected along the chain with each portal's screen bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RectWindow {
    /// `[x0, x1, y0, y1]`.
    pub rect: [f64; 4],
}

impl RectWindow {
    fn planes(&self, cam: &Camera) -> [Plane; 5] {
        let [x0, x1, y0, y1] = self.rect;
        [
            cam.near_plane(),
            cam.screen_plane(0, x0, false),
            cam.screen_plane(0, x1, true),
            cam.screen_plane(1, y0, false),
            cam.screen_plane(1, y1, true),
        ]
    }
}

impl Window for RectWindow {
    const NAME: &'static str = "rect";

    fn view(cam: &Camera) -> Self {
        RectWindow {
            rect: [-cam.tan_x, cam.tan_x, -cam.tan_y, cam.tan_y],
        }
    }

    fn narrow(&self, cam: &Camera, portal: &[P3], ops: &mut Ops) -> Option<Self> {
        ops.narrows += 1;
        let q = clip_tol(portal, &self.planes(cam), -cam.tol, ops)?;
        let mut r = [f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY];
        // A portal kept by the lenient clip may touch the near plane from behind: only
        // vertices in front project; with fewer than one the window stays as it is.
        let front: Vec<&P3> = q.iter().filter(|p| cam.depth(p) >= 0.5 * cam.near).collect();
        if front.len() < q.len() {
            return Some(*self);
        }
        for p in front {
            let s = cam.screen(p);
            r[0] = r[0].min(s[0]);
            r[1] = r[1].max(s[0]);
            r[2] = r[2].min(s[1]);
            r[3] = r[3].max(s[1]);
        }
        let [x0, x1, y0, y1] = self.rect;
        let rect = [r[0].max(x0), r[1].min(x1), r[2].max(y0), r[3].min(y1)];
        Some(RectWindow {
            rect: [rect[0], rect[1].max(rect[0]), rect[2], rect[3].max(rect[2])],
        })
    }

    fn sees(&self, cam: &Camera, tri: &[P3; 3], ops: &mut Ops) -> bool {
        ops.triangle_tests += 1;
        clip_tol(tri, &self.planes(cam), -cam.tol, ops).is_some()
    }
}

/// What the walkthrough needs of a partition: its portal graph, its polygons per cell, and
/// per cell the complex cells it is made of (for the path).
pub struct Scene<'a> {
    /// The model (triangles).
    pub model: &'a Model,
    /// The complex (convex pieces of the cells, for the path).
    pub cx: &'a CellComplex,
    /// Portal graph of the cells.
    pub graph: &'a PortalGraph,
    /// Polygons per cell.
    pub polygons: &'a CellPolygons,
    /// Complex cells of each graph cell.
    pub pieces: &'a [Vec<CellId>],
}

/// One point of the camera path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathPoint {
    /// Position.
    pub p: P3,
    /// Graph cell the segment from this point to the next lies in.
    pub cell: u32,
}

/// The tour's waypoints (see the module docs).
pub fn camera_path(scene: &Scene) -> Vec<PathPoint> {
    let cx = scene.cx;
    let g = scene.graph;
    let n = g.cells;
    if n == 0 {
        return Vec::new();
    }
    // Graph cell of each complex cell.
    let mut of = vec![u32::MAX; cx.cells.len()];
    for (i, ps) in scene.pieces.iter().enumerate() {
        for c in ps {
            of[c.idx()] = i as u32;
        }
    }
    // Complex adjacency: (neighbour, portal centre, portal area).
    let mut adj: Vec<Vec<(u32, P3, f64)>> = vec![Vec::new(); cx.cells.len()];
    for p in &cx.portals {
        let [a, b] = p.cells;
        if of[a.idx()] == u32::MAX || of[b.idx()] == u32::MAX {
            continue;
        }
        for q in &p.pieces {
            if q.verts.len() < 3 {
                continue;
            }
            let c = crate::base::vec::mean(&q.verts);
            let area = 0.5 * norm(&crate::base::vec::fan_normal(&q.verts));
            adj[a.idx()].push((b.0, c, area));
            adj[b.idx()].push((a.0, c, area));
        }
    }
    let centroid = |c: u32| cx.cells[c as usize].centroid();
    // Largest cell first.
    let vol = |i: usize| -> f64 { scene.pieces[i].iter().map(|c| cx.cells[c.idx()].volume()).sum() };
    let start = (0..n)
        .max_by(|&a, &b| vol(a).total_cmp(&vol(b)).then(b.cmp(&a)))
        .unwrap_or(0);
    let Some(&first) = scene.pieces[start].first() else {
        return Vec::new();
    };
    let mut path = vec![PathPoint {
        p: centroid(first.0),
        cell: start as u32,
    }];
    // Moves from complex cell `from` to `to` (same graph cell) through shared faces.
    let walk_inside = |from: u32, to: u32, path: &mut Vec<PathPoint>| {
        if from == to {
            return;
        }
        let cell = of[from as usize];
        let mut prev: std::collections::HashMap<u32, (u32, P3)> = Default::default();
        let mut q = VecDeque::from([from]);
        prev.insert(from, (from, [0.0; 3]));
        while let Some(c) = q.pop_front() {
            if c == to {
                break;
            }
            for &(d, m, _) in &adj[c as usize] {
                if of[d as usize] == cell && !prev.contains_key(&d) {
                    prev.insert(d, (c, m));
                    q.push_back(d);
                }
            }
        }
        if !prev.contains_key(&to) {
            // Not connected inside (membranes): jump.
            path.push(PathPoint { p: centroid(to), cell });
            return;
        }
        let mut chain = vec![to];
        let mut mids = Vec::new();
        let mut c = to;
        while c != from {
            let (p, m) = prev[&c];
            mids.push(m);
            chain.push(p);
            c = p;
        }
        chain.reverse();
        mids.reverse();
        for (k, m) in mids.iter().enumerate() {
            path.push(PathPoint { p: *m, cell });
            path.push(PathPoint {
                p: centroid(chain[k + 1]),
                cell,
            });
        }
    };
    // The crossing between graph cells a and b: the largest complex face.
    let crossing = |a: usize, b: usize| -> Option<(u32, u32, P3)> {
        let mut best: Option<(u32, u32, P3, f64)> = None;
        for &x in &scene.pieces[a] {
            for &(y, m, area) in &adj[x.idx()] {
                if of[y as usize] == b as u32 && best.is_none_or(|bb| area > bb.3) {
                    best = Some((x.0, y, m, area));
                }
            }
        }
        best.map(|(x, y, m, _)| (x, y, m))
    };
    let mut nbrs: Vec<Vec<u32>> = vec![Vec::new(); n];
    for p in &g.portals {
        let [a, b] = p.cells;
        nbrs[a as usize].push(b);
        nbrs[b as usize].push(a);
    }
    for v in &mut nbrs {
        v.sort_unstable();
        v.dedup();
    }
    let mut seen = vec![false; n];
    seen[start] = true;
    // Iterative DFS: (cell, complex cell we entered at, next neighbour index).
    let mut stack: Vec<(usize, u32, usize)> = vec![(start, first.0, 0)];
    let mut here = first.0;
    while let Some(top) = stack.last_mut() {
        let (cell, entry, k) = *top;
        if k < nbrs[cell].len() {
            top.2 += 1;
            let b = nbrs[cell][k] as usize;
            if seen[b] {
                continue;
            }
            let Some((x, y, m)) = crossing(cell, b) else { continue };
            seen[b] = true;
            walk_inside(here, x, &mut path);
            path.push(PathPoint { p: m, cell: b as u32 });
            path.push(PathPoint {
                p: centroid(y),
                cell: b as u32,
            });
            here = y;
            stack.push((b, y, 0));
        } else {
            // Back the way we came.
            stack.pop();
            if let Some(&(parent, _, _)) = stack.last() {
                walk_inside(here, entry, &mut path);
                if let Some((x, y, m)) = crossing(cell, parent) {
                    let _ = x;
                    path.push(PathPoint {
                        p: m,
                        cell: parent as u32,
                    });
                    path.push(PathPoint {
                        p: centroid(y),
                        cell: parent as u32,
                    });
                    here = y;
                }
            }
        }
    }
    path
}

/// One frame's figures.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Frame {
    /// Frame number.
    pub frame: usize,
    /// Eye.
    pub eye: P3,
    /// The camera's cell.
    pub cell: u32,
    /// Triangles drawn with view-frustum culling only.
    pub frustum: u64,
    /// Triangles drawn with portal culling (exact window).
    pub portal: u64,
    /// Triangles drawn with portal culling (screen rectangles).
    pub portal_rect: u64,
    /// Triangles drawn with portal textures at the first texture depth (incl. 2 per quad).
    pub textured_a: u64,
    /// The same at the second texture depth.
    pub textured_b: u64,
    /// Portal pieces passed by the exact window.
    pub portals_traversed: u64,
    /// Cells drawn (entries, with repetitions through different portals).
    pub cells_drawn: u64,
    /// Textured quads at the first texture depth.
    pub quads_a: u64,
    /// Per window representation ([`REPS`]): triangles drawn.
    #[serde(default)]
    pub rep_tris: [u64; NREPS],
    /// Windows passed: portal pieces (piece-by-piece representations) or merged portals.
    #[serde(default)]
    pub rep_portals: [u64; NREPS],
    /// Cells drawn (entries, with repetitions through different windows).
    #[serde(default)]
    pub rep_cells: [u64; NREPS],
    /// Clip operations (polygon–plane clips, 3D and 2D).
    #[serde(default)]
    pub rep_clips: [u64; NREPS],
    /// Vertices processed by those clips.
    #[serde(default)]
    pub rep_vertices: [u64; NREPS],
}

/// Number of window representations compared per frame.
pub const NREPS: usize = 9;

/// Their names, in the order of [`Frame::rep_tris`]: exact polygon, screen rectangle, the
/// k-gon simplifications (k = 4, 6, 8) — all piece by piece — then the convex screen hull
/// piece by piece and per merged portal, and the per-pixel mask piece by piece and per
/// merged portal (the arbitrary portals of Lowe & Datta).
pub const REPS: [&str; NREPS] = [
    ExactWindow::NAME,
    RectWindow::NAME,
    KgonWindow::<4>::NAME,
    KgonWindow::<6>::NAME,
    KgonWindow::<8>::NAME,
    HullWindow::<false>::NAME,
    HullWindow::<true>::NAME,
    MaskWindow::<false>::NAME,
    MaskWindow::<true>::NAME,
];

/// One representation's summary over a walkthrough.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RepSummary {
    /// Name (see [`REPS`]).
    pub name: String,
    /// Mean triangles drawn per frame.
    pub mean_triangles: f64,
    /// Largest per frame.
    pub max_triangles: u64,
    /// Mean windows passed per frame (portal pieces, or merged portals for the merged
    /// representations).
    pub mean_portals: f64,
    /// Largest per frame.
    #[serde(default)]
    pub max_portals: u64,
    /// Mean cells drawn per frame (with repetitions).
    #[serde(default)]
    pub mean_cells: f64,
    /// Mean triangles beyond the exact window's per frame (overdraw against it).
    pub mean_overdraw: f64,
    /// Largest per frame.
    pub max_overdraw: u64,
    /// Frames where it drew fewer triangles than the exact window (0 for a conservative
    /// representation).
    pub frames_below_exact: usize,
    /// Operation counts, all frames.
    pub ops: Ops,
    /// Seconds of culling, all frames.
    pub seconds: f64,
}

/// Summary of a walkthrough.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct WalkReport {
    /// Settings.
    pub settings: Option<WalkSettings>,
    /// Frames.
    pub frames: usize,
    /// Path length.
    pub path_length: f64,
    /// Model triangles.
    pub total_triangles: u64,
    /// Mean triangles per frame: frustum, portal (exact), portal (rect), textures (k_a),
    /// textures (k_b).
    pub mean: [f64; 5],
    /// Largest per frame, same order.
    pub max: [u64; 5],
    /// Speedups in triangles: mean frustum / mean of each (1 for the first).
    pub speedup: [f64; 5],
    /// Operation counts of the exact and the rect windows (all frames).
    pub ops: [Ops; 2],
    /// Seconds of culling, all frames: frustum, exact, rect, textures a, textures b.
    pub seconds: [f64; 5],
    /// Every window representation ([`REPS`]).
    #[serde(default)]
    pub reps: Vec<RepSummary>,
}

/// Column names of [`WalkReport::mean`] (with the texture depths).
pub fn columns(settings: &WalkSettings) -> [String; 5] {
    [
        "frustum".into(),
        "portal".into(),
        "portal_rect".into(),
        format!("textures_k{}", settings.texture_depths[0]),
        format!("textures_k{}", settings.texture_depths[1]),
    ]
}

struct Renderer<'s, 'a> {
    scene: &'s Scene<'a>,
    /// Directed portal pieces out of each cell: (to, portal index, polygon facing `to`).
    out: Vec<Vec<(u32, u32, Vec<P3>)>>,
    tris: Vec<Vec<[P3; 3]>>,
    stamp: Vec<u32>,
    quad_stamp: Vec<u32>,
    mark: u32,
    on_chain: Vec<bool>,
    eps: f64,
}

#[derive(Clone, Copy, Default)]
struct Count {
    tris: u64,
    portals: u64,
    cells: u64,
    quads: u64,
}

impl Renderer<'_, '_> {
    fn new<'s, 'a>(scene: &'s Scene<'a>) -> Renderer<'s, 'a> {
        let g = scene.graph;
        let mut out: Vec<Vec<(u32, u32, Vec<P3>)>> = vec![Vec::new(); g.cells];
        for (i, p) in g.portals.iter().enumerate() {
            let [a, b] = p.cells;
            for q in &p.pieces {
                if q.len() < 3 {
                    continue;
                }
                out[a as usize].push((b, i as u32, q.clone()));
                let mut r = q.clone();
                r[1..].reverse();
                out[b as usize].push((a, i as u32, r));
            }
        }
        let m = scene.model;
        let tris = m
            .polygons
            .iter()
            .map(|p| {
                let v: Vec<P3> = p.verts.iter().map(|v| m.vertices[v.idx()]).collect();
                (1..v.len().saturating_sub(1)).map(|k| [v[0], v[k], v[k + 1]]).collect()
            })
            .collect();
        Renderer {
            scene,
            out,
            tris,
            stamp: vec![u32::MAX; total_tris(m)],
            quad_stamp: vec![u32::MAX; g.portals.len()],
            mark: 0,
            on_chain: vec![false; g.cells],
            eps: 1e-9 * g.diagonal().max(1e-300),
        }
    }

    fn tri_base(&self) -> Vec<usize> {
        let mut b = Vec::with_capacity(self.tris.len());
        let mut s = 0;
        for t in &self.tris {
            b.push(s);
            s += t.len();
        }
        b
    }

    fn frustum_only(&mut self, cam: &Camera, ops: &mut Ops) -> u64 {
        // Lenient, as the conservative windows (see [`clip_tol`]).
        let w = RectWindow::view(cam);
        let mut n = 0;
        for ts in &self.tris {
            for t in ts {
                n += w.sees(cam, t, ops) as u64;
            }
        }
        n
    }

    #[allow(clippy::too_many_arguments)]
    fn render<W: Window>(
        &mut self,
        base: &[usize],
        cam: &Camera,
        cell: u32,
        w: &W,
        depth: usize,
        tex: Option<usize>,
        ops: &mut Ops,
        count: &mut Count,
    ) {
        count.cells += 1;
        let polys = &self.scene.polygons.polygons[cell as usize];
        for &p in polys {
            for (k, t) in self.tris[p as usize].iter().enumerate() {
                let id = base[p as usize] + k;
                if self.stamp[id] != self.mark && w.sees(cam, t, ops) {
                    self.stamp[id] = self.mark;
                    count.tris += 1;
                }
            }
        }
        self.on_chain[cell as usize] = true;
        let n_out = self.out[cell as usize].len();
        let mut k = 0;
        while k < n_out {
            let (to, portal) = (self.out[cell as usize][k].0, self.out[cell as usize][k].1);
            // A merged window takes all pieces of the portal (they are consecutive).
            let mut end = k + 1;
            if W::MERGED {
                while end < n_out && self.out[cell as usize][end].1 == portal {
                    end += 1;
                }
            }
            let range = k..end;
            k = end;
            if self.on_chain[to as usize] {
                continue;
            }
            let next = {
                let mut open = false;
                let mut away: Vec<&[P3]> = Vec::new();
                for (_, _, q) in &self.out[cell as usize][range] {
                    let nrm = crate::base::vec::fan_normal(q);
                    let nl = norm(&nrm);
                    let s = (dot(&nrm, &cam.eye) - dot(&nrm, &q[0])) / nl;
                    if s > self.eps {
                        // The eye is in front: it sees the piece's back.
                    } else if s >= -self.eps {
                        // The eye stands on the piece's plane: open if it stands on the piece.
                        open |= on_polygon(q, &cam.eye, &nrm, self.eps);
                    } else {
                        away.push(q);
                    }
                }
                if open {
                    Some(w.clone())
                } else if away.is_empty() {
                    None
                } else if W::MERGED {
                    w.narrow_portal(cam, &away, ops)
                } else {
                    w.narrow(cam, away[0], ops)
                }
            };
            let Some(next) = next else { continue };
            count.portals += 1;
            if tex.is_some_and(|k| depth >= k) {
                if self.quad_stamp[portal as usize] != self.mark {
                    self.quad_stamp[portal as usize] = self.mark;
                    count.quads += 1;
                    count.tris += 2;
                }
                continue;
            }
            if depth < 256 {
                self.render(base, cam, to, &next, depth + 1, tex, ops, count);
            }
        }
        self.on_chain[cell as usize] = false;
    }

    fn run<W: Window>(&mut self, base: &[usize], cam: &Camera, cell: u32, tex: Option<usize>, ops: &mut Ops) -> Count {
        self.mark = self.mark.wrapping_add(1);
        let mut c = Count::default();
        let w = W::view(cam);
        self.render(base, cam, cell, &w, 0, tex, ops, &mut c);
        c
    }
}

fn add_ops(a: &mut Ops, b: &Ops) {
    a.plane_clips += b.plane_clips;
    a.narrows += b.narrows;
    a.triangle_tests += b.triangle_tests;
    a.vertices += b.vertices;
    a.sphere_rejects += b.sphere_rejects;
    a.screen_ops += b.screen_ops;
    a.mask_pixels += b.mask_pixels;
    a.mask_words += b.mask_words;
}

fn total_tris(m: &Model) -> usize {
    m.polygons.iter().map(|p| p.verts.len().saturating_sub(2)).sum()
}

/// Whether `p` (on the polygon's plane) lies inside the convex polygon (within `eps`).
fn on_polygon(q: &[P3], p: &P3, n: &P3, eps: f64) -> bool {
    let nl = norm(n).max(f64::MIN_POSITIVE);
    (0..q.len()).all(|i| {
        let j = (i + 1) % q.len();
        let e = sub(&q[j], &q[i]);
        let side = dot(&cross(&e, &sub(p, &q[i])), n) / nl / norm(&e).max(f64::MIN_POSITIVE);
        side >= -eps
    })
}

/// The frames' cameras along [`camera_path`] (with the camera's cell) and the path length.
pub fn cameras(scene: &Scene, settings: &WalkSettings) -> (Vec<(Camera, u32)>, f64) {
    let path = camera_path(scene);
    let diag = scene.graph.diagonal().max(scene.model_diagonal());
    let mut len = 0.0;
    for w in path.windows(2) {
        len += norm(&sub(&w[1].p, &w[0].p));
    }
    let mut step = settings.step_rel * diag;
    if step <= 0.0 || len / step > settings.max_frames as f64 {
        step = len / settings.max_frames.max(1) as f64;
    }
    let look = settings.lookahead_rel * diag;
    let near = 1e-6 * diag;
    // Frame positions: every `step` along the path.
    let mut cams: Vec<(Camera, u32)> = Vec::new();
    if path.len() >= 2 && step > 0.0 {
        let cum: Vec<f64> = std::iter::once(0.0)
            .chain(path.windows(2).scan(0.0, |s, w| {
                *s += norm(&sub(&w[1].p, &w[0].p));
                Some(*s)
            }))
            .collect();
        let at = |t: f64| -> (P3, usize) {
            let t = t.clamp(0.0, len);
            let i = cum.partition_point(|&c| c <= t).clamp(1, path.len() - 1) - 1;
            let seg = cum[i + 1] - cum[i];
            let u = if seg > 0.0 { (t - cum[i]) / seg } else { 0.0 };
            let (a, b) = (path[i].p, path[i + 1].p);
            (
                [
                    a[0] + u * (b[0] - a[0]),
                    a[1] + u * (b[1] - a[1]),
                    a[2] + u * (b[2] - a[2]),
                ],
                i,
            )
        };
        let frames = (len / step).floor() as usize + 1;
        let mut last_dir = [1.0, 0.0, 0.0];
        for f in 0..frames {
            let t = f as f64 * step;
            let (eye, i) = at(t);
            let (ahead, _) = at(t + look);
            let mut dir = sub(&ahead, &eye);
            if norm(&dir) < 1e-9 * diag {
                dir = last_dir;
            }
            last_dir = dir;
            let cam = Camera::looking(eye, dir, settings.up_axis, settings.fov_deg, settings.aspect, near)
                .rolled(settings.roll_deg)
                .with_mask_width(settings.mask_width);
            cams.push((cam, path[i].cell));
        }
    }
    (cams, len)
}

/// Which triangles (numbered as the model's polygons fanned, in order) one frame draws with
/// the window `W` from `cam` in `cell`.
pub fn drawn<W: Window>(scene: &Scene, cam: &Camera, cell: u32) -> Vec<bool> {
    let mut r = Renderer::new(scene);
    let base = r.tri_base();
    let mut ops = Ops::default();
    r.run::<W>(&base, cam, cell, None, &mut ops);
    r.stamp.iter().map(|&s| s == r.mark).collect()
}

/// One frame rendered with the window `W`: counts, operations, seconds.
fn timed<W: Window>(r: &mut Renderer, base: &[usize], cam: &Camera, cell: u32) -> (Count, Ops, f64) {
    let t = Instant::now();
    let mut o = Ops::default();
    let c = r.run::<W>(base, cam, cell, None, &mut o);
    (c, o, t.elapsed().as_secs_f64())
}

/// Runs the walkthrough: frames along [`camera_path`], each rendered five ways.
pub fn walkthrough(scene: &Scene, settings: &WalkSettings) -> (WalkReport, Vec<Frame>) {
    let (cams, len) = cameras(scene, settings);
    let mut r = Renderer::new(scene);
    let base = r.tri_base();
    let mut frames = Vec::with_capacity(cams.len());
    let mut rep = WalkReport {
        settings: Some(*settings),
        frames: cams.len(),
        path_length: len,
        total_triangles: total_tris(scene.model) as u64,
        ..Default::default()
    };
    let mut scratch = Ops::default();
    let mut sums = [(Ops::default(), 0.0); NREPS];
    for (i, (cam, cell)) in cams.iter().enumerate() {
        let t0 = Instant::now();
        let frustum = r.frustum_only(cam, &mut scratch);
        let t1 = Instant::now();
        let mut ops_exact = Ops::default();
        let exact = r.run::<ExactWindow>(&base, cam, *cell, None, &mut ops_exact);
        let t2 = Instant::now();
        let mut ops_rect = Ops::default();
        let rect = r.run::<RectWindow>(&base, cam, *cell, None, &mut ops_rect);
        add_ops(&mut rep.ops[0], &ops_exact);
        add_ops(&mut rep.ops[1], &ops_rect);
        let t3 = Instant::now();
        let ta = r.run::<ExactWindow>(&base, cam, *cell, Some(settings.texture_depths[0]), &mut scratch);
        let t4 = Instant::now();
        let tb = r.run::<ExactWindow>(&base, cam, *cell, Some(settings.texture_depths[1]), &mut scratch);
        let t5 = Instant::now();
        for (k, (a, b)) in [(t0, t1), (t1, t2), (t2, t3), (t3, t4), (t4, t5)].iter().enumerate() {
            rep.seconds[k] += (*b - *a).as_secs_f64();
        }
        let mut rt = [0u64; NREPS];
        let mut rp = [0u64; NREPS];
        let mut rc = [0u64; NREPS];
        let mut rv = [0u64; NREPS];
        let mut rn = [0u64; NREPS];
        let mut one = |k: usize, c: Count, o: Ops, secs: f64, sums: &mut [(Ops, f64); NREPS]| {
            rt[k] = c.tris;
            rp[k] = c.portals;
            rn[k] = c.cells;
            rc[k] = o.plane_clips;
            rv[k] = o.vertices;
            add_ops(&mut sums[k].0, &o);
            sums[k].1 += secs;
        };
        one(0, exact, ops_exact, (t2 - t1).as_secs_f64(), &mut sums);
        one(1, rect, ops_rect, (t3 - t2).as_secs_f64(), &mut sums);
        let (c, o, t) = timed::<KgonWindow<4>>(&mut r, &base, cam, *cell);
        one(2, c, o, t, &mut sums);
        let (c, o, t) = timed::<KgonWindow<6>>(&mut r, &base, cam, *cell);
        one(3, c, o, t, &mut sums);
        let (c, o, t) = timed::<KgonWindow<8>>(&mut r, &base, cam, *cell);
        one(4, c, o, t, &mut sums);
        let (c, o, t) = timed::<HullWindow<false>>(&mut r, &base, cam, *cell);
        one(5, c, o, t, &mut sums);
        let (c, o, t) = timed::<HullWindow<true>>(&mut r, &base, cam, *cell);
        one(6, c, o, t, &mut sums);
        let (c, o, t) = timed::<MaskWindow<false>>(&mut r, &base, cam, *cell);
        one(7, c, o, t, &mut sums);
        let (c, o, t) = timed::<MaskWindow<true>>(&mut r, &base, cam, *cell);
        one(8, c, o, t, &mut sums);
        frames.push(Frame {
            frame: i,
            eye: cam.eye,
            cell: *cell,
            frustum,
            portal: exact.tris,
            portal_rect: rect.tris,
            textured_a: ta.tris,
            textured_b: tb.tris,
            portals_traversed: exact.portals,
            cells_drawn: exact.cells,
            quads_a: ta.quads,
            rep_tris: rt,
            rep_portals: rp,
            rep_clips: rc,
            rep_vertices: rv,
            rep_cells: rn,
        });
    }
    let nf = frames.len().max(1) as f64;
    for f in &frames {
        let v = [f.frustum, f.portal, f.portal_rect, f.textured_a, f.textured_b];
        for k in 0..5 {
            rep.mean[k] += v[k] as f64 / nf;
            rep.max[k] = rep.max[k].max(v[k]);
        }
    }
    rep.reps = (0..NREPS)
        .map(|k| {
            let mut s = RepSummary {
                name: REPS[k].into(),
                ops: sums[k].0,
                seconds: sums[k].1,
                ..Default::default()
            };
            for f in &frames {
                let over = f.rep_tris[k].saturating_sub(f.rep_tris[0]);
                s.mean_triangles += f.rep_tris[k] as f64 / nf;
                s.max_triangles = s.max_triangles.max(f.rep_tris[k]);
                s.mean_portals += f.rep_portals[k] as f64 / nf;
                s.max_portals = s.max_portals.max(f.rep_portals[k]);
                s.mean_cells += f.rep_cells[k] as f64 / nf;
                s.mean_overdraw += over as f64 / nf;
                s.max_overdraw = s.max_overdraw.max(over);
                s.frames_below_exact += (f.rep_tris[k] < f.rep_tris[0]) as usize;
            }
            s
        })
        .collect();
    for k in 0..5 {
        rep.speedup[k] = if rep.mean[k] > 0.0 {
            rep.mean[0] / rep.mean[k]
        } else {
            0.0
        };
    }
    (rep, frames)
}

/// Renders one frame with representation `k` of [`REPS`].
fn run_rep(r: &mut Renderer, base: &[usize], cam: &Camera, cell: u32, k: usize, ops: &mut Ops) -> Count {
    match k {
        0 => r.run::<ExactWindow>(base, cam, cell, None, ops),
        1 => r.run::<RectWindow>(base, cam, cell, None, ops),
        2 => r.run::<KgonWindow<4>>(base, cam, cell, None, ops),
        3 => r.run::<KgonWindow<6>>(base, cam, cell, None, ops),
        4 => r.run::<KgonWindow<8>>(base, cam, cell, None, ops),
        5 => r.run::<HullWindow<false>>(base, cam, cell, None, ops),
        6 => r.run::<HullWindow<true>>(base, cam, cell, None, ops),
        7 => r.run::<MaskWindow<false>>(base, cam, cell, None, ops),
        _ => r.run::<MaskWindow<true>>(base, cam, cell, None, ops),
    }
}

/// Culling time of every window representation ([`REPS`]) along a walkthrough's frames,
/// and the check that each is conservative triangle by triangle.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CullTiming {
    /// Repetitions: every frame was culled this many times by every representation.
    pub repeat: usize,
    /// Frames.
    pub frames: usize,
    /// Per frame and representation: the fastest of the repetitions, wall-clock seconds.
    pub frame_seconds: Vec<[f64; NREPS]>,
    /// Per repetition and representation: wall-clock seconds summed over all frames.
    pub run_seconds: Vec<[f64; NREPS]>,
    /// The same as `frame_seconds` in CPU seconds of the culling thread ([`thread_cpu`];
    /// empty where the clock is not available). Less sensitive than wall-clock time to the
    /// other processes of a shared machine (they still share its caches).
    pub frame_cpu_seconds: Vec<[f64; NREPS]>,
    /// The same as `run_seconds` in CPU seconds of the culling thread.
    pub run_cpu_seconds: Vec<[f64; NREPS]>,
    /// Per representation: frames where it did not draw some triangle the exact window
    /// draws (0 for a conservative representation).
    pub frames_missing: [usize; NREPS],
    /// Per representation: such triangles, summed over frames.
    pub triangles_missing: [u64; NREPS],
}

impl CullTiming {
    /// Per representation: mean wall-clock seconds per frame of the fastest repetition (the
    /// sum over frames of one whole repetition, divided by the frames).
    pub fn per_frame_best(&self) -> [f64; NREPS] {
        best(&self.run_seconds, self.frames)
    }

    /// Per representation: median over repetitions of the mean wall-clock seconds per frame.
    pub fn per_frame_median(&self) -> [f64; NREPS] {
        median(&self.run_seconds, self.frames)
    }

    /// [`CullTiming::per_frame_best`] in thread CPU seconds (`None` without the clock).
    pub fn cpu_per_frame_best(&self) -> Option<[f64; NREPS]> {
        (!self.run_cpu_seconds.is_empty()).then(|| best(&self.run_cpu_seconds, self.frames))
    }

    /// [`CullTiming::per_frame_median`] in thread CPU seconds (`None` without the clock).
    pub fn cpu_per_frame_median(&self) -> Option<[f64; NREPS]> {
        (!self.run_cpu_seconds.is_empty()).then(|| median(&self.run_cpu_seconds, self.frames))
    }
}

fn best(runs: &[[f64; NREPS]], frames: usize) -> [f64; NREPS] {
    let nf = frames.max(1) as f64;
    std::array::from_fn(|k| runs.iter().map(|r| r[k]).fold(f64::INFINITY, f64::min) / nf)
}

fn median(runs: &[[f64; NREPS]], frames: usize) -> [f64; NREPS] {
    let nf = frames.max(1) as f64;
    std::array::from_fn(|k| {
        let mut v: Vec<f64> = runs.iter().map(|r| r[k]).collect();
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(0.0) / nf
    })
}

/// CPU seconds consumed so far by the calling thread (`CLOCK_THREAD_CPUTIME_ID`; `None`
/// where it is not available).
pub fn thread_cpu() -> Option<f64> {
    #[cfg(unix)]
    {
        let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
        // SAFETY: `ts` is a valid, writable timespec; the call only writes into it.
        let r = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
        (r == 0).then_some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
    }
    #[cfg(not(unix))]
    {
        None
    }
}

/// Culls every frame of `cams` with every representation, `repeat` times (at least once):
/// the wall-clock and the thread CPU seconds of the culling itself (the window narrowing through the portal
/// chain and the triangle tests; counting included, nothing drawn), interleaved — in each
/// frame the representations run back to back, starting at a different one each frame and
/// repetition, so a change of the machine's load spreads over all of them. The first
/// repetition also checks, triangle by triangle, that each representation draws every
/// triangle the exact window draws (an extra untimed exact run per frame).
pub fn time_culling(scene: &Scene, cams: &[(Camera, u32)], repeat: usize) -> CullTiming {
    let repeat = repeat.max(1);
    let mut r = Renderer::new(scene);
    let base = r.tri_base();
    let mut t = CullTiming {
        repeat,
        frames: cams.len(),
        frame_seconds: vec![[f64::INFINITY; NREPS]; cams.len()],
        run_seconds: vec![[0.0; NREPS]; repeat],
        ..Default::default()
    };
    let cpu = thread_cpu().is_some();
    if cpu {
        t.frame_cpu_seconds = vec![[f64::INFINITY; NREPS]; cams.len()];
        t.run_cpu_seconds = vec![[0.0; NREPS]; repeat];
    }
    let mut exact_set: Vec<usize> = Vec::new();
    let mut ops = Ops::default();
    for round in 0..repeat {
        for (f, &(cam, cell)) in cams.iter().enumerate() {
            if round == 0 {
                run_rep(&mut r, &base, &cam, cell, 0, &mut ops);
                exact_set.clear();
                exact_set.extend((0..r.stamp.len()).filter(|&i| r.stamp[i] == r.mark));
            }
            for j in 0..NREPS {
                let k = (j + f + round) % NREPS;
                let c0 = if cpu { thread_cpu() } else { None };
                let t0 = Instant::now();
                run_rep(&mut r, &base, &cam, cell, k, &mut ops);
                let secs = t0.elapsed().as_secs_f64();
                t.run_seconds[round][k] += secs;
                t.frame_seconds[f][k] = t.frame_seconds[f][k].min(secs);
                if let (Some(a), Some(b)) = (c0, thread_cpu()) {
                    let c = (b - a).max(0.0);
                    t.run_cpu_seconds[round][k] += c;
                    t.frame_cpu_seconds[f][k] = t.frame_cpu_seconds[f][k].min(c);
                }
                if round == 0 {
                    let missing = exact_set.iter().filter(|&&i| r.stamp[i] != r.mark).count() as u64;
                    t.frames_missing[k] += (missing > 0) as usize;
                    t.triangles_missing[k] += missing;
                }
            }
        }
    }
    t
}

impl Scene<'_> {
    fn model_diagonal(&self) -> f64 {
        self.cx.tol.scale
    }
}
