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

/// Whether `t` is an integer as written (an optional sign, then decimal digits), whatever
/// its size: an index that fails to parse as one is out of range, not malformed.
pub(crate) fn is_integer_literal(t: &str) -> bool {
    let digits = t.strip_prefix(['+', '-']).unwrap_or(t);
    !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit())
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

/// The size (bytes) of the pieces [`parse_obj`] parses in parallel; a piece ends at the end
/// of a line.
const CHUNK_BYTES: usize = 1 << 18;

/// Parses OBJ text into a polygon soup. Indices are validated: the soup is ready for cleaning.
///
/// The text is parsed in pieces of whole lines ([`CHUNK_BYTES`]) in parallel (rayon), with
/// the result (and the first error in file order) of one sequential pass: see
/// [`parse_obj_chunked`].
pub(crate) fn parse_obj(file: &str, text: &str) -> Result<Soup, ModelError> {
    parse_obj_chunked(file, text, CHUNK_BYTES)
}

/// The fuzzer's differential check of the chunked parser: `text` parsed in pieces of about
/// `chunk_bytes` gives what the whole text parsed as one piece gives (the soup, bit for bit
/// through `Debug`, or the same error). `Err` describes the first disagreement.
pub(crate) fn chunking_agrees(text: &str, chunk_bytes: usize) -> Result<(), String> {
    let show = |r: Result<Soup, ModelError>| match r {
        Ok(s) => format!("{s:?}"),
        Err(e) => format!("error: {e}"),
    };
    let whole = show(parse_obj_chunked("fuzz.obj", text, usize::MAX));
    let pieces = show(parse_obj_chunked("fuzz.obj", text, chunk_bytes));
    if whole == pieces {
        Ok(())
    } else {
        Err(format!(
            "the OBJ parse in pieces of {chunk_bytes} bytes differs from the whole parse"
        ))
    }
}

/// Positive indices beyond the vertices defined so far, checked at the end: (polygon, line,
/// raw index).
type Forward = Vec<(usize, usize, i64)>;

/// The parser state at the start of a piece of the text: what the lines before it defined.
#[derive(Clone, Debug, Default)]
struct State {
    /// Lines before the piece.
    lines: usize,
    /// Vertices and polygons defined before it.
    vertices: usize,
    polygons: usize,
    /// The material of the following faces (the last `usemtl` before the piece).
    material: Option<String>,
}

/// [`parse_obj`] in pieces of about `chunk_bytes` (each extended to the end of its line).
///
/// **Why it is the sequential parse.** The sequential parser reads the lines in order with
/// a state: the line number, the vertices and polygons defined so far (negative indices and
/// the element numbers of errors depend on their counts) and the current `usemtl` material;
/// it stops at the first error, and checks the forward references after the last line.
/// Here a first parallel pass finds, per piece, its number of lines (its `\n`s: each piece
/// but the last ends with one, so `str::lines` numbers them alike), of `v` and `f` lines
/// and its last `usemtl`, from the same keyword test as the parser ([`keyword`]); prefix sums
/// give each piece its state. A second parallel pass parses each piece from its state with
/// the sequential parser's loop ([`parse_piece`]), stopping at the piece's first error.
/// Every `v` line of a piece without an error defines exactly one vertex and every `f` line
/// one polygon, so the state of every piece up to the first one with an error is the
/// sequential parser's state there; that piece's first error is the first in the file
/// (the earlier pieces have none). Without one, each piece has written its vertices and
/// polygons where the sequential parser puts them (the counts of the pieces before it), and
/// the forward references, concatenated in order, are checked in that order as before.
/// (Only references beyond the vertices defined so far are kept for that check: the others
/// are in range at the end too.) `chunk_bytes = usize::MAX` is the sequential parser.
fn parse_obj_chunked(file: &str, text: &str, chunk_bytes: usize) -> Result<Soup, ModelError> {
    use rayon::prelude::*;
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let pieces = split_lines(text, chunk_bytes);
    let counts: Vec<(usize, usize, usize, Option<Option<String>>)> = pieces.par_iter().map(|p| scan_piece(p)).collect();
    let mut states = Vec::with_capacity(pieces.len());
    let mut state = State::default();
    for (lines, v, f, material) in counts {
        states.push(state.clone());
        state.lines += lines;
        state.vertices += v;
        state.polygons += f;
        if let Some(m) = material {
            state.material = m;
        }
    }
    // Each piece writes its vertices and polygons in place.
    let mut vertices: Vec<[f64; 3]> = vec![[0.0; 3]; state.vertices];
    let mut polygons: Vec<RawPolygon> = (0..state.polygons)
        .into_par_iter()
        .map(|_| RawPolygon {
            verts: Vec::new(),
            source: SourceRef { line: None, element: 0 },
            material: None,
        })
        .collect();
    let mut outputs = Vec::with_capacity(pieces.len());
    let (mut vrest, mut prest) = (vertices.as_mut_slice(), polygons.as_mut_slice());
    for (i, st) in states.iter().enumerate() {
        let next = states.get(i + 1).unwrap_or(&state);
        let (v, vr) = vrest.split_at_mut(next.vertices - st.vertices);
        let (p, pr) = prest.split_at_mut(next.polygons - st.polygons);
        outputs.push((v, p));
        (vrest, prest) = (vr, pr);
    }
    let forward: Vec<Result<Forward, ModelError>> = pieces
        .par_iter()
        .zip(states)
        .zip(outputs)
        .map(|((text, st), (v, p))| parse_piece(file, text, st, v, p))
        .collect();
    let mut all_forward = Vec::new();
    for f in forward {
        all_forward.extend(f?);
    }
    for (pi, line_no, idx) in all_forward {
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

/// `text` cut into pieces of at least `chunk_bytes` (but the last), each ending just after a
/// `\n` (but the last), in order.
fn split_lines(text: &str, chunk_bytes: usize) -> Vec<&str> {
    let mut pieces = Vec::new();
    let mut rest = text;
    while !rest.is_empty() {
        let cut = match rest.as_bytes().get(chunk_bytes.max(1) - 1..) {
            Some(tail) => tail
                .iter()
                .position(|&b| b == b'\n')
                .map_or(rest.len(), |i| chunk_bytes.max(1) + i),
            None => rest.len(),
        };
        let (piece, r) = rest.split_at(cut);
        pieces.push(piece);
        rest = r;
    }
    pieces
}

/// The keyword of a line (its first token once the comment is stripped) and the comment-free
/// line.
fn keyword(raw_line: &str) -> Option<(&str, &str)> {
    let line = strip_comment(raw_line);
    line.split_whitespace().next().map(|kw| (kw, line))
}

/// The material a `usemtl` line sets.
fn usemtl(line: &str, kw: &str) -> Option<String> {
    let name = line.trim_start()[kw.len()..].trim();
    if name.is_empty() { None } else { Some(name.to_string()) }
}

/// A piece's lines, `v` lines, `f` lines, and the material its last `usemtl` sets (`None`
/// without one).
fn scan_piece(text: &str) -> (usize, usize, usize, Option<Option<String>>) {
    let (mut lines, mut v, mut f, mut material) = (0, 0, 0, None);
    for raw_line in text.lines() {
        lines += 1;
        match keyword(raw_line) {
            Some(("v", _)) => v += 1,
            Some(("f", _)) => f += 1,
            Some((kw @ "usemtl", line)) => material = Some(usemtl(line, kw)),
            _ => {}
        }
    }
    (lines, v, f, material)
}

/// The sequential parser's loop over the lines of `text`, from `state`: writes the piece's
/// vertices and polygons to `vertices` and `polygons` (as many as its `v` and `f` lines) and
/// returns its references beyond the vertices defined so far, to be checked at the end
/// (polygon, line, raw index), or its first error.
fn parse_piece(
    file: &str,
    text: &str,
    state: State,
    vertices: &mut [[f64; 3]],
    polygons: &mut [RawPolygon],
) -> Result<Forward, ModelError> {
    let (mut nv, mut np) = (0, 0);
    let mut forward: Forward = Vec::new();
    let mut material = state.material;

    for (lineno0, raw_line) in text.lines().enumerate() {
        let line_no = state.lines + lineno0 + 1;
        let Some((kw, line)) = keyword(raw_line) else { continue };
        let mut toks = line.split_whitespace();
        toks.next();
        match kw {
            "v" => {
                let vi = state.vertices + nv;
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
                vertices[nv] = p;
                nv += 1;
            }
            "f" => {
                let pi = state.polygons + np;
                let defined = state.vertices + nv;
                let mut verts = Vec::new();
                for t in toks {
                    let first = t.split('/').next().unwrap_or("");
                    if is_integer_literal(first) && first.parse::<i64>().is_err() {
                        return Err(ModelError::IndexTooLarge {
                            file: file.to_string(),
                            line: line_no,
                            polygon: pi,
                            index: first.to_string(),
                            convention: CONVENTION,
                        });
                    }
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
                        let r = defined as i64 + idx;
                        if r < 0 {
                            return Err(out_of_range(defined));
                        }
                        r
                    } else if idx == 0 {
                        return Err(out_of_range(defined));
                    } else {
                        if idx as u64 > defined as u64 {
                            forward.push((pi, line_no, idx));
                        }
                        idx - 1
                    };
                    let r = u32::try_from(resolved).map_err(|_| out_of_range(defined))?;
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
                polygons[np] = RawPolygon {
                    verts,
                    source: SourceRef {
                        line: Some(line_no),
                        element: pi,
                    },
                    material: material.clone(),
                };
                np += 1;
            }
            "usemtl" => material = usemtl(line, kw),
            _ => {}
        }
    }
    Ok(forward)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sequential parser [`parse_obj`] replaced (a test oracle), unchanged.
    fn parse_obj_sequential(file: &str, text: &str) -> Result<Soup, ModelError> {
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

    /// One line of random OBJ text: vertices (some malformed or non-finite), faces with
    /// every reference form (negative, forward, zero, out of range, malformed), `usemtl`
    /// with and without a name, comments, other keywords and blank lines.
    fn random_line(rng: &mut crate::base::rng::SplitMix64, bad: f64, nv: usize) -> String {
        let num = |rng: &mut crate::base::rng::SplitMix64| format!("{}", (rng.signed_unit() * 100.0).round() / 8.0);
        let r = rng.unit();
        if r < 0.45 {
            if rng.unit() < bad {
                ["v 1 x 2", "v 1 2", "v 1 inf 0", "v NaN 0 0"][rng.below(4)].to_string()
            } else {
                let w = if rng.below(4) == 0 { " 1.0" } else { "" };
                format!("v {} {}\t{}{w}", num(rng), num(rng), num(rng))
            }
        } else if r < 0.8 {
            let n = if rng.unit() < bad {
                rng.below(3)
            } else {
                3 + rng.below(3)
            };
            let refs: Vec<String> = (0..n)
                .map(|_| {
                    let i: i64 = if rng.unit() < bad {
                        [0, -1000, 99_999_999_999, 40][rng.below(4)]
                    } else if rng.below(3) == 0 {
                        -1 - rng.below(nv.max(1)) as i64
                    } else {
                        // Forward references (beyond the vertices so far) now and then.
                        let beyond = rng.below(2);
                        1 + rng.below(nv + 1 + beyond) as i64
                    };
                    let t = if rng.unit() < bad / 4.0 {
                        "x".to_string()
                    } else {
                        i.to_string()
                    };
                    match rng.below(4) {
                        0 => t,
                        1 => format!("{t}/1"),
                        2 => format!("{t}/1/2"),
                        _ => format!("{t}//3"),
                    }
                })
                .collect();
            format!("f {}", refs.join(" "))
        } else if r < 0.87 {
            ["usemtl brick", "usemtl", "usemtl  two words ", "usemtl stone # c"][rng.below(4)].to_string()
        } else {
            [
                "",
                "# comment",
                "vt 0 0",
                "vn 0 0 1",
                "g group",
                "  ",
                "o x # y",
                "\u{a0}v 1 2 3",
                "s off",
            ][rng.below(9)]
            .to_string()
        }
    }

    #[test]
    fn parallel_parse_equals_the_sequential_parser() {
        let mut rng = crate::base::rng::SplitMix64(23);
        let (mut ok, mut errors) = (0, 0);
        for trial in 0..1500 {
            let bad = [0.0, 0.002, 0.02][trial % 3];
            let mut text = String::new();
            if rng.below(10) == 0 {
                text.push('\u{feff}');
            }
            let mut nv = 0;
            for _ in 0..rng.below(120) {
                let line = random_line(&mut rng, bad, nv);
                nv += line.starts_with("v ") as usize;
                text.push_str(&line);
                text.push_str(if rng.below(5) == 0 { "\r\n" } else { "\n" });
            }
            if rng.below(3) == 0 {
                text.push_str(&random_line(&mut rng, bad, nv)); // no final newline
            }
            let want = format!("{:?}", parse_obj_sequential("t.obj", &text));
            if want.starts_with("Ok") {
                ok += 1;
            } else {
                errors += 1;
            }
            for chunk in [1, 2, 7, 64, 300, CHUNK_BYTES, usize::MAX] {
                let got = format!("{:?}", parse_obj_chunked("t.obj", &text, chunk));
                assert_eq!(got, want, "trial {trial}, chunk {chunk}:\n{text}");
            }
        }
        assert!(ok > 300 && errors > 300, "{ok} {errors}");
    }

    #[test]
    fn pieces_end_at_line_ends() {
        for text in ["", "a", "a\n", "ab\ncd\n\nef", "\n\n\n"] {
            for chunk in [1, 2, 3, 100, usize::MAX] {
                let pieces = split_lines(text, chunk);
                assert_eq!(pieces.concat(), text);
                for p in &pieces[..pieces.len().saturating_sub(1)] {
                    assert!(p.ends_with('\n') && p.len() >= chunk, "{text:?} {chunk} {pieces:?}");
                }
            }
        }
    }

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
