//! glTF 2.0 binary of the cells and portals (`cells.glb`, opt-in: `run --export gltf`),
//! named so that Godot 3.5's Rooms and Portals conversion turns it into rooms and portals
//! without hand-work. Written by hand: a GLB header, a JSON chunk (padded with spaces) and
//! a BIN chunk (padded with zeros), both 4-byte aligned.
//!
//! Scene tree:
//!
//! ```text
//! RoomList                          rotation: the model's +z up becomes glTF's +y up
//! ├── Room_<a>-room                 an empty: Godot makes the Room "Room_<a>"
//! │   ├── Cell_<a>                  mesh: the cell's boundary faces (its room bound)
//! │   └── Room_<b>*Portal_<a>_<b>_<k>-portal
//! │                                 mesh: convex piece k of the portal between a and b
//! └── Room_<b>-room ...
//! ```
//!
//! Godot 3.5 names by **postfix** (`-room`, `-portal`; the `Room_`/`Portal_` prefixes of
//! its pre-release were replaced before 3.4): a portal's name before `-portal` names the
//! room it leads to, and everything from `*` on is ignored (so several portals may lead to
//! one room). Each portal is a child of the room it leads *from* (the one with the smaller
//! id), its front face (counter-clockwise) facing out of that room, and Godot links it both
//! ways. Point the RoomManager's `roomlist` at `RoomList` and convert. Godot bounds each
//! room by the convex hull of its meshes, while merged cells need not be convex.
//!
//! A second root, `Portals` (same rotation; not under `RoomList`, so Godot's conversion
//! ignores it), holds per merged portal `Portal_<a>_<b>_surface` (all its pieces as one
//! mesh, possibly non-planar) and `Portal_<a>_<b>_hull` (one convex planar polygon standing
//! in for it, [`crate::visibility::merged::convex_portal`]; extras `{cells, pieces, normal,
//! thickness}`, thickness = the pieces' largest distance from its plane).
//!
//! `extras` carry the data: rooms `{cell_id, volume, pieces}`, portals
//! `{portal, cells, piece, area, pair_area}`, the root `{generator, model, cells, portals}`.
//! Positions are `f32` (accessors with exact `min`/`max`); faces are fans of the convex
//! polygons; no normals (viewers compute flat ones); cells opaque and double-sided,
//! portals translucent.

use super::OutputError;
use super::cells_obj::{PORTAL_COLOUR, PORTAL_HULL_COLOUR, boundary_faces, cell_colour};
use super::export::{ExportContext, Exporter, write_atomic};
use crate::predicates::P3;
use serde_json::{Value, json};
use std::collections::HashMap;
use std::path::PathBuf;

const FILE: &str = "cells.glb";

/// Buffer, views, accessors and meshes being built.
#[derive(Default)]
struct Builder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
    meshes: Vec<Value>,
}

impl Builder {
    fn view(&mut self, bytes: &[u8], target: u32) -> usize {
        debug_assert!(self.bin.len().is_multiple_of(4));
        self.views.push(json!({
            "buffer": 0,
            "byteOffset": self.bin.len(),
            "byteLength": bytes.len(),
            "target": target,
        }));
        self.bin.extend_from_slice(bytes);
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        self.views.len() - 1
    }

    /// A mesh of convex polygons (fans), with `material`; `None` if it has no triangle.
    fn mesh(&mut self, name: &str, faces: &[&[P3]], material: usize) -> Option<usize> {
        let mut index: HashMap<[u32; 3], u32> = HashMap::new();
        let mut pos: Vec<[f32; 3]> = Vec::new();
        let mut tris: Vec<u32> = Vec::new();
        for f in faces {
            let ids: Vec<u32> = f
                .iter()
                .map(|v| {
                    let p = v.map(|x| x as f32);
                    *index.entry(p.map(f32::to_bits)).or_insert_with(|| {
                        pos.push(p);
                        (pos.len() - 1) as u32
                    })
                })
                .collect();
            for i in 1..ids.len().saturating_sub(1) {
                let t = [ids[0], ids[i], ids[i + 1]];
                // Faces thinner than f32 resolution collapse; drop their degenerate triangles.
                if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                    tris.extend(t);
                }
            }
        }
        if tris.is_empty() {
            return None;
        }
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for p in &pos {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let pbytes: Vec<u8> = pos.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
        let ibytes: Vec<u8> = tris.iter().flat_map(|x| x.to_le_bytes()).collect();
        let pv = self.view(&pbytes, 34962);
        let iv = self.view(&ibytes, 34963);
        self.accessors.push(json!({
            "bufferView": pv, "componentType": 5126, "count": pos.len(), "type": "VEC3",
            "min": lo, "max": hi,
        }));
        self.accessors.push(json!({
            "bufferView": iv, "componentType": 5125, "count": tris.len(), "type": "SCALAR",
        }));
        let n = self.accessors.len();
        self.meshes.push(json!({
            "name": name,
            "primitives": [{ "attributes": { "POSITION": n - 2 }, "indices": n - 1, "material": material }],
        }));
        Some(self.meshes.len() - 1)
    }
}

/// The GLB bytes of a JSON document and its binary buffer.
fn glb(json_doc: &Value, bin: &[u8]) -> Vec<u8> {
    let mut js = json_doc.to_string().into_bytes();
    while !js.len().is_multiple_of(4) {
        js.push(b' ');
    }
    let mut bin = bin.to_vec();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + js.len() + if bin.is_empty() { 0 } else { 8 + bin.len() };
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(js.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&js);
    if !bin.is_empty() {
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
    }
    out
}

/// The `cells.glb` bytes for an export context (needs the complex).
pub fn cells_glb(ctx: &ExportContext<'_>) -> Result<Vec<u8>, OutputError> {
    let cx = ctx.complex(FILE)?;
    let partition = &ctx.dec.partition;
    let mut b = Builder::default();
    let mut materials: Vec<Value> = Vec::new();
    let mut nodes: Vec<Value> = vec![Value::Null]; // the root, filled in last
    let mut room_node: HashMap<u32, usize> = HashMap::new();
    let mut rooms = Vec::new();
    for (i, c) in partition.cells.iter().enumerate() {
        let [r, g, bl] = cell_colour(i);
        materials.push(json!({
            "name": format!("cell_{}", c.id.0),
            "pbrMetallicRoughness": { "baseColorFactor": [r, g, bl, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0 },
            "doubleSided": true,
        }));
        let boundary = boundary_faces(cx, partition, c);
        let faces: Vec<&[P3]> = boundary.iter().map(|f| &f.verts[..]).collect();
        let mut children = Vec::new();
        if let Some(m) = b.mesh(&format!("Cell_{}", c.id.0), &faces, i) {
            nodes.push(json!({ "name": format!("Cell_{}", c.id.0), "mesh": m }));
            children.push(nodes.len() - 1);
        }
        nodes.push(json!({
            "name": format!("Room_{}-room", c.id.0),
            "children": children,
            "extras": { "cell_id": c.id.0, "volume": c.volume, "pieces": c.pieces.len() },
        }));
        room_node.insert(c.id.0, nodes.len() - 1);
        rooms.push(nodes.len() - 1);
    }
    let [r, g, bl, a] = PORTAL_COLOUR;
    let portal_material = materials.len();
    materials.push(json!({
        "name": "portal",
        "pbrMetallicRoughness": { "baseColorFactor": [r, g, bl, a], "metallicFactor": 0.0, "roughnessFactor": 1.0 },
        "alphaMode": "BLEND",
        "doubleSided": true,
    }));
    let portals = partition.portals(cx);
    let mut portal_nodes = 0;
    for p in &portals {
        let (ida, idb) = (p.cells[0].0, p.cells[1].0);
        for (k, q) in p.pieces.iter().enumerate() {
            let label = format!("Portal_{ida}_{idb}_{k}");
            let Some(m) = b.mesh(&label, &[&q.verts[..]], portal_material) else {
                continue;
            };
            nodes.push(json!({
                "name": format!("Room_{idb}*{label}-portal"),
                "mesh": m,
                "extras": {
                    "portal": format!("Portal_{ida}_{idb}"),
                    "cells": [ida, idb],
                    "piece": k,
                    "area": q.area(),
                    "pair_area": p.area,
                },
            }));
            let child = nodes.len() - 1;
            let parent = room_node[&ida];
            if let Some(ch) = nodes[parent]["children"].as_array_mut() {
                ch.push(json!(child));
            }
            portal_nodes += 1;
        }
    }
    // The merged surfaces and their convex stand-ins, under their own root.
    let [r, g, bl, a] = PORTAL_HULL_COLOUR;
    let hull_material = materials.len();
    materials.push(json!({
        "name": "portal_hull",
        "pbrMetallicRoughness": { "baseColorFactor": [r, g, bl, a], "metallicFactor": 0.0, "roughnessFactor": 1.0 },
        "alphaMode": "BLEND",
        "doubleSided": true,
    }));
    let mut merged_children = Vec::new();
    for p in &portals {
        let (ida, idb) = (p.cells[0].0, p.cells[1].0);
        let faces: Vec<&[P3]> = p.pieces.iter().map(|q| &q.verts[..]).collect();
        let label = format!("Portal_{ida}_{idb}_surface");
        if let Some(m) = b.mesh(&label, &faces, portal_material) {
            nodes.push(json!({
                "name": label,
                "mesh": m,
                "extras": { "cells": [ida, idb], "pieces": p.pieces.len(), "pair_area": p.area },
            }));
            merged_children.push(nodes.len() - 1);
        }
        let pieces: Vec<Vec<P3>> = p.pieces.iter().map(|q| q.verts.to_vec()).collect();
        if let Some(h) = crate::visibility::merged::convex_portal(&pieces) {
            let label = format!("Portal_{ida}_{idb}_hull");
            if let Some(m) = b.mesh(&label, &[&h.verts[..]], hull_material) {
                nodes.push(json!({
                    "name": label,
                    "mesh": m,
                    "extras": { "cells": [ida, idb], "pieces": p.pieces.len(), "normal": h.normal, "thickness": h.thickness },
                }));
                merged_children.push(nodes.len() - 1);
            }
        }
    }
    // Rooms without children must not carry an empty `children` array (glTF forbids it).
    for &rn in &rooms {
        if nodes[rn]["children"].as_array().is_some_and(|c| c.is_empty())
            && let Some(o) = nodes[rn].as_object_mut()
        {
            o.remove("children");
        }
    }
    let h = std::f64::consts::FRAC_1_SQRT_2;
    // A recentred model (`Model::origin`) keeps its f32 positions near zero, where they
    // are precise; the roots' translation puts it back in the input's frame: the model's
    // `o` turned by the roots' rotation (x, y, z) -> (x, z, -y).
    let o = ctx.model.origin;
    let translation = (o != [0.0; 3]).then(|| json!([o[0], o[2], -o[1]]));
    nodes[0] = json!({
        "name": "RoomList",
        "rotation": [-h, 0.0, 0.0, h],
        "children": rooms,
        "extras": {
            "generator": format!("portalfind {}", env!("CARGO_PKG_VERSION")),
            "model": ctx.doc.model.name,
            "cells": partition.cells.len(),
            "portal_pairs": portals.len(),
            "portal_nodes": portal_nodes,
            "up": "the model's +z, turned to glTF's +y by this node's rotation",
        },
    });
    if rooms.is_empty()
        && let Some(o) = nodes[0].as_object_mut()
    {
        o.remove("children");
    }
    if let Some(t) = &translation
        && let Some(o) = nodes[0].as_object_mut()
    {
        o.insert("translation".into(), t.clone());
    }
    let mut roots = vec![0];
    if !merged_children.is_empty() {
        nodes.push(json!({
            "name": "Portals",
            "rotation": [-h, 0.0, 0.0, h],
            "children": merged_children,
            "extras": { "what": "per merged portal: Portal_<a>_<b>_surface (its pieces) and Portal_<a>_<b>_hull (a convex stand-in)" },
        }));
        if let Some(t) = &translation
            && let Some(n) = nodes.last_mut().and_then(|n| n.as_object_mut())
        {
            n.insert("translation".into(), t.clone());
        }
        roots.push(nodes.len() - 1);
    }
    let mut doc = json!({
        "asset": { "version": "2.0", "generator": format!("portalfind {}", env!("CARGO_PKG_VERSION")) },
        "scene": 0,
        "scenes": [{ "name": ctx.doc.model.name, "nodes": roots }],
        "nodes": nodes,
        "materials": materials,
    });
    if !b.meshes.is_empty() {
        doc["meshes"] = json!(b.meshes);
        doc["accessors"] = json!(b.accessors);
        doc["bufferViews"] = json!(b.views);
        doc["buffers"] = json!([{ "byteLength": b.bin.len() }]);
    }
    Ok(glb(&doc, &b.bin))
}

/// `cells.glb`.
pub struct Glb;

impl Exporter for Glb {
    fn name(&self) -> &'static str {
        "cells and portals as glTF"
    }

    fn files(&self, _ctx: &ExportContext<'_>) -> Vec<String> {
        vec![FILE.into()]
    }

    fn owns(&self, file_name: &str) -> bool {
        file_name == FILE
    }

    fn opt_in(&self) -> Option<&'static str> {
        Some("gltf")
    }

    fn write(&self, ctx: &ExportContext<'_>) -> Result<Vec<PathBuf>, OutputError> {
        let bytes = cells_glb(ctx)?;
        let path = ctx.dir.join(FILE);
        write_atomic(&path, |tmp| std::fs::write(tmp, &bytes))?;
        Ok(vec![path])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn glb_layout_is_aligned_with_correct_lengths() {
        let g = glb(&json!({"asset": {"version": "2.0"}}), &[1, 2, 3, 4, 5]);
        assert_eq!(&g[0..4], b"glTF");
        assert_eq!(u32::from_le_bytes(g[8..12].try_into().unwrap()) as usize, g.len());
        let jl = u32::from_le_bytes(g[12..16].try_into().unwrap()) as usize;
        assert_eq!(jl % 4, 0);
        assert_eq!(&g[16..20], b"JSON");
        let b0 = 20 + jl;
        assert_eq!(u32::from_le_bytes(g[b0..b0 + 4].try_into().unwrap()), 8);
        assert_eq!(&g[b0 + 4..b0 + 8], b"BIN\0");
        assert_eq!(g.len() % 4, 0);
    }
}
