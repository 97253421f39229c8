//! Wavefront OBJ reader (positions, faces and `usemtl` only; see the module docs of
//! [`crate::model`]).

use super::SourceRef;
use super::clean::{RawPolygon, Soup};
use super::error::ModelError;

const CONVENTION: &str = "OBJ indices are 1-based, negative ones count back from the last \
                          vertex defined so far";

/// Strips a `#` comment.
pub(crate) fn strip_comment(line: &str) -> &str {
    match line.find('#') {
        Some(i) => &line[..i],
        None => line,
    }
}

/// Shortened copy of a line for error messages.
pub(crate) fn excerpt(line: &str) -> String {
    let t = line.trim();
    if t.chars().count() > 80 {
        let s: String = t.chars().take(77).collect();
        format!("{s}...")
    } else {
        t.to_string()
    }
}

/// Parses OBJ text into a polygon soup. Indices are validated: the soup is ready for cleaning.
pub(crate) fn parse_obj(file: &str, text: &str) -> Result<Soup, ModelError> {
    let mut vertices: Vec<[f64; 3]> = Vec::new();
    let mut polygons: Vec<RawPolygon> = Vec::new();
    // Positive indices may refer forward; checked at the end. (polygon, line, raw index).
    let mut forward: Vec<(usize, usize, i64)> = Vec::new();
    let mut material: Option<String> = None;
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);

    for (lineno0, raw_line) in text.lines().enumerate() {
        let line_no = lineno0 + 1;
        let line = strip_comment(raw_line);
        let mut toks = line.split_whitespace();
        let Some(kw) = toks.next() else { continue };
        match kw {
            "v" => {
                let vi = vertices.len();
                let malformed = || ModelError::Malformed {
                    file: file.to_string(),
                    line: line_no,
                    element: format!("vertex {vi} (0-based)"),
                    expected: "`v x y z` with three numbers".to_string(),
                    found: excerpt(raw_line),
                };
                let mut p = [0.0f64; 3];
                for c in &mut p {
                    let t = toks.next().ok_or_else(malformed)?;
                    *c = t.parse::<f64>().map_err(|_| malformed())?;
                }
                if p.iter().any(|c| !c.is_finite()) {
                    return Err(ModelError::NonFinite {
                        file: file.to_string(),
                        line: Some(line_no),
                        vertex: vi,
                        coords: p,
                    });
                }
                vertices.push(p);
            }
            "f" => {
                let pi = polygons.len();
                let mut verts = Vec::new();
                for t in toks {
                    let first = t.split('/').next().unwrap_or("");
                    let idx: i64 = first.parse().map_err(|_| ModelError::Malformed {
                        file: file.to_string(),
                        line: line_no,
                        element: format!("polygon {pi} (0-based)"),
                        expected: "`f` followed by vertex references `i`, `i/j`, `i/j/k` or \
                                   `i//k` with integer `i`"
                            .to_string(),
                        found: excerpt(raw_line),
                    })?;
                    let out_of_range = |count: usize| ModelError::IndexOutOfRange {
                        file: file.to_string(),
                        line: Some(line_no),
                        polygon: pi,
                        index: idx,
                        vertex_count: count,
                        convention: CONVENTION,
                    };
                    let resolved: i64 = if idx < 0 {
                        let r = vertices.len() as i64 + idx;
                        if r < 0 {
                            return Err(out_of_range(vertices.len()));
                        }
                        r
                    } else if idx == 0 {
                        return Err(out_of_range(vertices.len()));
                    } else {
                        forward.push((pi, line_no, idx));
                        idx - 1
                    };
                    let r = u32::try_from(resolved).map_err(|_| out_of_range(vertices.len()))?;
                    verts.push(r);
                }
                if verts.len() < 3 {
                    return Err(ModelError::TooFewVertices {
                        file: file.to_string(),
                        line: Some(line_no),
                        polygon: pi,
                        count: verts.len(),
                    });
                }
                polygons.push(RawPolygon {
                    verts,
                    source: SourceRef {
                        line: Some(line_no),
                        element: pi,
                    },
                    material: material.clone(),
                });
            }
            "usemtl" => {
                let name = line.trim_start()[kw.len()..].trim();
                material = if name.is_empty() { None } else { Some(name.to_string()) };
            }
            _ => {}
        }
    }

    for (pi, line_no, idx) in forward {
        if idx as u64 > vertices.len() as u64 {
            return Err(ModelError::IndexOutOfRange {
                file: file.to_string(),
                line: Some(line_no),
                polygon: pi,
                index: idx,
                vertex_count: vertices.len(),
                convention: CONVENTION,
            });
        }
    }
    Ok(Soup { vertices, polygons })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn all_reference_forms_and_materials() {
        let text = "# cube-ish\nmtllib x.mtl\no thing\nv 0 0 0\nv 1 0 0 1.0\nv 1 1 0 0.5 0.5 0.5\n\
                    vt 0 0\nvn 0 0 1\ng grp\nf 1 2 3\nusemtl brick\nf 1/1 2/1 3/1\r\n\
                    f 1/1/1 2/1/1 3/1/1 # comment\nusemtl\nf 1//1 -2//1 -1//1\n";
        let s = parse_obj("t.obj", text).unwrap();
        assert_eq!(s.vertices.len(), 3);
        assert_eq!(s.vertices[1], [1.0, 0.0, 0.0]);
        assert_eq!(s.polygons.len(), 4);
        for p in &s.polygons {
            assert_eq!(p.verts, vec![0, 1, 2]);
        }
        assert_eq!(s.polygons[0].material, None);
        assert_eq!(s.polygons[1].material.as_deref(), Some("brick"));
        assert_eq!(s.polygons[2].material.as_deref(), Some("brick"));
        assert_eq!(s.polygons[3].material, None);
        assert_eq!(
            s.polygons[0].source,
            SourceRef {
                line: Some(10),
                element: 0
            }
        );
        assert_eq!(
            s.polygons[3].source,
            SourceRef {
                line: Some(15),
                element: 3
            }
        );
    }

    #[test]
    fn forward_references_allowed() {
        let s = parse_obj("t.obj", "f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n").unwrap();
        assert_eq!(s.polygons[0].verts, vec![0, 1, 2]);
    }

    #[test]
    fn errors_name_lines() {
        let e = parse_obj("t.obj", "v 0 0 0\nv 1 x 0\n").unwrap_err();
        assert!(matches!(e, ModelError::Malformed { line: 2, .. }), "{e}");
        let e = parse_obj("t.obj", "v 0 0\n").unwrap_err();
        assert!(matches!(e, ModelError::Malformed { line: 1, .. }), "{e}");
        let e = parse_obj("t.obj", "v 0 0 0\nv 0 inf 0\n").unwrap_err();
        assert!(
            matches!(
                e,
                ModelError::NonFinite {
                    line: Some(2),
                    vertex: 1,
                    ..
                }
            ),
            "{e}"
        );
        let e = parse_obj("t.obj", "v 0 0 0\nv 0 NaN 0\n").unwrap_err();
        assert!(
            matches!(
                e,
                ModelError::NonFinite {
                    line: Some(2),
                    vertex: 1,
                    ..
                }
            ),
            "{e}"
        );
        let src = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n";
        let e = parse_obj("t.obj", src).unwrap_err();
        assert!(
            matches!(
                e,
                ModelError::IndexOutOfRange {
                    line: Some(5),
                    polygon: 1,
                    index: 4,
                    vertex_count: 3,
                    ..
                }
            ),
            "{e}"
        );
        let e = parse_obj("t.obj", "v 0 0 0\nf -2 1 1\n").unwrap_err();
        assert!(
            matches!(
                e,
                ModelError::IndexOutOfRange {
                    index: -2,
                    vertex_count: 1,
                    ..
                }
            ),
            "{e}"
        );
        let e = parse_obj("t.obj", "v 0 0 0\nf 0 1 1\n").unwrap_err();
        assert!(matches!(e, ModelError::IndexOutOfRange { index: 0, .. }), "{e}");
        let e = parse_obj("t.obj", "v 0 0 0\nf 1 1\n").unwrap_err();
        assert!(
            matches!(
                e,
                ModelError::TooFewVertices {
                    line: Some(2),
                    count: 2,
                    ..
                }
            ),
            "{e}"
        );
        let e = parse_obj("t.obj", "v 0 0 0\nf 1 a 1\n").unwrap_err();
        assert!(matches!(e, ModelError::Malformed { line: 2, .. }), "{e}");
        let e = parse_obj("t.obj", "v 0 0 0\nf 99999999999 1 1\n").unwrap_err();
        assert!(matches!(e, ModelError::IndexOutOfRange { .. }), "{e}");
    }

    #[test]
    fn garbage_never_panics() {
        for text in [
            "f",
            "v",
            "f //",
            "f /1/",
            "usemtl",
            "v 1e400 0 0",
            "f -9223372036854775808 1 1",
            "\u{feff}v 0 0 0",
        ] {
            let _ = parse_obj("t.obj", text);
        }
    }
}
