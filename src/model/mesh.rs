//! Reader of the simple text mesh format (`.mesh`; see the module docs of [`crate::model`]).

use super::SourceRef;
use super::clean::{RawPolygon, Soup};
use super::error::ModelError;
use super::obj::{excerpt, strip_comment};

const CONVENTION: &str = ".mesh indices are 0-based";

/// Parses `.mesh` text into a validated polygon soup.
pub(crate) fn parse_mesh(file: &str, text: &str) -> Result<Soup, ModelError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    // Content lines: (1-based line number, raw line, tokens).
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l, strip_comment(l)))
        .filter(|(_, _, l)| !l.trim().is_empty());

    let malformed = |line: usize, raw: &str, element: String, expected: &str| ModelError::Malformed {
        file: file.to_string(),
        line,
        element,
        expected: expected.to_string(),
        found: excerpt(raw),
    };

    let Some((header_line, raw, content)) = lines.next() else {
        return Err(ModelError::Empty {
            file: file.to_string(),
            reason: "the file has no header line `<vertex_count> <polygon_count>`".to_string(),
        });
    };
    let header_expected = "`<vertex_count> <polygon_count>`: two non-negative integers";
    let toks: Vec<&str> = content.split_whitespace().collect();
    // Medit's keywords (TetGen, Gmsh and meshio write this format as `.mesh` too).
    if toks
        .first()
        .is_some_and(|t| ["MeshVersionFormatted", "MeshVersion", "Dimension", "Vertices"].contains(t))
    {
        return Err(ModelError::OtherMeshFormat {
            file: file.to_string(),
            line: header_line,
            found: excerpt(raw),
        });
    }
    let (nv, np) = match toks.as_slice() {
        [a, b] => match (a.parse::<usize>(), b.parse::<usize>()) {
            (Ok(a), Ok(b)) => (a, b),
            _ => return Err(malformed(header_line, raw, "header".into(), header_expected)),
        },
        _ => return Err(malformed(header_line, raw, "header".into(), header_expected)),
    };
    if nv > u32::MAX as usize {
        return Err(malformed(
            header_line,
            raw,
            "header".into(),
            "at most 4294967295 vertices",
        ));
    }

    // Do not trust the header for allocation sizes beyond what the text could hold.
    let cap = text.len() / 2 + 1;
    let mut vertices: Vec<[f64; 3]> = Vec::with_capacity(nv.min(cap));
    for vi in 0..nv {
        let Some((line_no, raw, content)) = lines.next() else {
            return Err(ModelError::CountMismatch {
                file: file.to_string(),
                line: header_line,
                what: "vertices",
                declared: nv,
                found: vi,
            });
        };
        let expected = format!("a vertex line `x y z` with exactly three numbers (the header declares {nv} vertices)");
        let expected = expected.as_str();
        let toks: Vec<&str> = content.split_whitespace().collect();
        let element = || format!("vertex {vi} (0-based)");
        if toks.len() != 3 {
            return Err(malformed(line_no, raw, element(), expected));
        }
        let mut p = [0.0f64; 3];
        for (c, t) in p.iter_mut().zip(&toks) {
            *c = t
                .parse::<f64>()
                .map_err(|_| malformed(line_no, raw, element(), expected))?;
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

    let mut polygons: Vec<RawPolygon> = Vec::with_capacity(np.min(cap));
    for pi in 0..np {
        let Some((line_no, raw, content)) = lines.next() else {
            return Err(ModelError::CountMismatch {
                file: file.to_string(),
                line: header_line,
                what: "polygons",
                declared: np,
                found: pi,
            });
        };
        let expected = "a polygon line `n i0 ... i(n-1)`: a count n >= 3 followed by exactly n \
                        vertex indices";
        let element = || format!("polygon {pi} (0-based)");
        let mut toks = content.split_whitespace();
        let n: usize = toks
            .next()
            .and_then(|t| t.parse().ok())
            .ok_or_else(|| malformed(line_no, raw, element(), expected))?;
        let mut verts = Vec::with_capacity(n.min(64));
        for t in toks {
            if super::obj::is_integer_literal(t) && t.parse::<i64>().is_err() {
                return Err(ModelError::IndexTooLarge {
                    file: file.to_string(),
                    line: line_no,
                    polygon: pi,
                    index: t.to_string(),
                    convention: CONVENTION,
                });
            }
            let idx: i64 = t.parse().map_err(|_| malformed(line_no, raw, element(), expected))?;
            if idx < 0 || idx as u64 >= nv as u64 {
                return Err(ModelError::IndexOutOfRange {
                    file: file.to_string(),
                    line: Some(line_no),
                    polygon: pi,
                    index: idx,
                    vertex_count: nv,
                    convention: CONVENTION,
                });
            }
            verts.push(idx as u32);
        }
        if verts.len() != n {
            return Err(malformed(line_no, raw, element(), expected));
        }
        if n < 3 {
            return Err(ModelError::TooFewVertices {
                file: file.to_string(),
                line: Some(line_no),
                polygon: pi,
                count: n,
            });
        }
        polygons.push(RawPolygon {
            verts,
            source: SourceRef {
                line: Some(line_no),
                element: pi,
            },
            material: None,
        });
    }

    if let Some((line_no, _, _)) = lines.next() {
        let extra = 1 + lines.count();
        return Err(ModelError::CountMismatch {
            file: file.to_string(),
            line: line_no,
            what: "polygons",
            declared: np,
            found: np + extra,
        });
    }
    Ok(Soup { vertices, polygons })
}

#[cfg(test)]
mod tests {
    use super::*;

    const TET: &str = "# a tetrahedron\n4 4\n0 0 0\n1 0 0\n\n0 1 0 # apex later\n0 0 1\n\
                       3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";

    #[test]
    fn parses_tetrahedron() {
        let s = parse_mesh("t.mesh", TET).unwrap();
        assert_eq!(s.vertices.len(), 4);
        assert_eq!(s.vertices[2], [0.0, 1.0, 0.0]);
        assert_eq!(s.polygons.len(), 4);
        assert_eq!(s.polygons[0].verts, vec![0, 2, 1]);
        assert_eq!(
            s.polygons[0].source,
            SourceRef {
                line: Some(8),
                element: 0
            }
        );
        assert_eq!(
            s.polygons[3].source,
            SourceRef {
                line: Some(11),
                element: 3
            }
        );
    }

    #[test]
    fn errors() {
        let e = parse_mesh("t.mesh", "4 x\n").unwrap_err();
        assert!(matches!(e, ModelError::Malformed { line: 1, .. }), "{e}");
        let e = parse_mesh("t.mesh", "# c\n\n2 1\n0 0 0\n").unwrap_err();
        assert!(
            matches!(
                e,
                ModelError::CountMismatch {
                    line: 3,
                    what: "vertices",
                    declared: 2,
                    found: 1,
                    ..
                }
            ),
            "{e}"
        );
        let e = parse_mesh("t.mesh", "1 2\n0 0 0\n3 0 0 0\n").unwrap_err();
        assert!(
            matches!(
                e,
                ModelError::CountMismatch {
                    what: "polygons",
                    declared: 2,
                    found: 1,
                    ..
                }
            ),
            "{e}"
        );
        let e = parse_mesh("t.mesh", "1 1\n0 0 0\n3 0 0 0\n3 0 0 0\n\n3 0 0 0\n").unwrap_err();
        assert!(
            matches!(
                e,
                ModelError::CountMismatch {
                    line: 4,
                    declared: 1,
                    found: 3,
                    ..
                }
            ),
            "{e}"
        );
        let e = parse_mesh("t.mesh", "1 1\n0 0\n3 0 0 0\n").unwrap_err();
        assert!(matches!(e, ModelError::Malformed { line: 2, .. }), "{e}");
        let e = parse_mesh("t.mesh", "1 1\n0 0 nan\n3 0 0 0\n").unwrap_err();
        assert!(
            matches!(
                e,
                ModelError::NonFinite {
                    line: Some(2),
                    vertex: 0,
                    ..
                }
            ),
            "{e}"
        );
        let e = parse_mesh("t.mesh", "1 1\n0 0 0\n3 0 0 1\n").unwrap_err();
        assert!(
            matches!(
                e,
                ModelError::IndexOutOfRange {
                    line: Some(3),
                    index: 1,
                    vertex_count: 1,
                    ..
                }
            ),
            "{e}"
        );
        let e = parse_mesh("t.mesh", "1 1\n0 0 0\n3 0 0 -1\n").unwrap_err();
        assert!(matches!(e, ModelError::IndexOutOfRange { index: -1, .. }), "{e}");
        let e = parse_mesh("t.mesh", "1 1\n0 0 0\n3 0 0\n").unwrap_err();
        assert!(matches!(e, ModelError::Malformed { line: 3, .. }), "{e}");
        let e = parse_mesh("t.mesh", "1 1\n0 0 0\n2 0 0\n").unwrap_err();
        assert!(
            matches!(
                e,
                ModelError::TooFewVertices {
                    line: Some(3),
                    count: 2,
                    ..
                }
            ),
            "{e}"
        );
        let e = parse_mesh("t.mesh", "# nothing\n").unwrap_err();
        assert!(matches!(e, ModelError::Empty { .. }), "{e}");
    }

    #[test]
    fn huge_header_does_not_allocate_or_panic() {
        let e = parse_mesh("t.mesh", "4000000000 18446744073709551615\n").unwrap_err();
        assert!(matches!(e, ModelError::CountMismatch { .. }), "{e}");
    }
}
