//! qbsp's portal file, PRT1: the leaves and portals `vis` reads.
//!
//! ```text
//! PRT1
//! <numleafs>
//! <numportals>
//! <numpoints> <leaf0> <leaf1> (x y z ) (x y z ) ...      one line per portal
//! ```
//!
//! Leaves are numbered `0..numleafs` (qbsp's visleafs: empty leaves only) and have no
//! geometry here. `vis` makes each portal a *forward* portal in `leaf0` leading to `leaf1`
//! with the plane of the winding flipped from Quake's `PlaneFromWinding` (which is
//! clockwise), i.e. the right-handed normal of the points as written points from `leaf0`
//! into `leaf1` — the orientation [`GraphPortal`] wants, so windings are taken as written.
//! Extra integer fields before the first point (Quake 3's hint flag) are ignored; other
//! headers (`PRT1-AM`, `PRT2`, with clusters) are refused as unsupported.

use super::{GraphPortal, PortalGraph};
use crate::base::vec::P3;
use std::path::Path;

/// An error reading a PRT file; line numbers are 1-based.
#[derive(Debug, thiserror::Error)]
pub enum PrtError {
    /// The file could not be read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// A header other than `PRT1`.
    #[error("line {line}: unsupported portal file format {found:?} (only PRT1 is read)")]
    Unsupported {
        /// Line number.
        line: usize,
        /// What was found.
        found: String,
    },
    /// A malformed line.
    #[error("line {line}: {message}")]
    Syntax {
        /// Line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// The file ends before all portals were read.
    #[error("line {line}: file ends after {found} of {expected} portals")]
    Truncated {
        /// The line after the last one.
        line: usize,
        /// Portals read.
        found: usize,
        /// Portals announced in the header.
        expected: usize,
    },
}

/// One portal of a PRT file.
#[derive(Clone, Debug, PartialEq)]
pub struct PrtPortal {
    /// `leaf0`, `leaf1`.
    pub leaves: [u32; 2],
    /// The winding as written.
    pub winding: Vec<P3>,
    /// Its line in the file.
    pub line: usize,
}

/// A PRT1 file.
#[derive(Clone, Debug, PartialEq)]
pub struct PrtFile {
    /// Number of leaves (`numleafs`).
    pub leaves: usize,
    /// Portals, in file order.
    pub portals: Vec<PrtPortal>,
}

impl PrtFile {
    /// The leaf graph: one cell per leaf, one [`GraphPortal`] per portal line.
    pub fn graph(&self) -> PortalGraph {
        PortalGraph {
            cells: self.leaves,
            portals: self
                .portals
                .iter()
                .map(|p| GraphPortal {
                    cells: p.leaves,
                    pieces: vec![p.winding.clone()],
                })
                .collect(),
            convex_cells: true,
        }
    }
}

/// Reads a PRT1 file.
pub fn read(path: &Path) -> Result<PrtFile, PrtError> {
    let text = std::fs::read_to_string(path).map_err(|source| PrtError::Io {
        path: path.display().to_string(),
        source,
    })?;
    parse(&text)
}

/// Parses the text of a PRT1 file.
pub fn parse(text: &str) -> Result<PrtFile, PrtError> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty());
    let syntax = |line: usize, message: String| PrtError::Syntax { line, message };
    let (l1, head) = lines.next().ok_or_else(|| syntax(1, "empty file".into()))?;
    if head != "PRT1" {
        return Err(PrtError::Unsupported {
            line: l1,
            found: head.to_string(),
        });
    }
    let mut count = |what: &str| -> Result<(usize, usize), PrtError> {
        let (l, s) = lines.next().ok_or_else(|| syntax(l1 + 1, format!("missing {what}")))?;
        let n = s
            .parse::<usize>()
            .map_err(|_| syntax(l, format!("{what}: expected a count, found {s:?}")))?;
        Ok((l, n))
    };
    let (_, leaves) = count("number of leaves")?;
    let (mut last, portals_n) = count("number of portals")?;
    let mut portals = Vec::with_capacity(portals_n.min(1 << 20));
    for (line, s) in lines {
        last = line;
        if portals.len() == portals_n {
            return Err(syntax(line, format!("more than the {portals_n} portals announced")));
        }
        let head_end = s
            .find('(')
            .ok_or_else(|| syntax(line, "no points (expected \"(x y z )\")".into()))?;
        let ints: Vec<&str> = s[..head_end].split_whitespace().collect();
        if ints.len() < 3 {
            return Err(syntax(
                line,
                format!("expected \"numpoints leaf0 leaf1\", found {:?}", &s[..head_end]),
            ));
        }
        let int = |t: &str, what: &str| {
            t.parse::<u32>()
                .map_err(|_| syntax(line, format!("{what}: expected an integer, found {t:?}")))
        };
        let n = int(ints[0], "number of points")? as usize;
        let l0 = int(ints[1], "leaf0")?;
        let l1 = int(ints[2], "leaf1")?;
        for (l, what) in [(l0, "leaf0"), (l1, "leaf1")] {
            if l as usize >= leaves {
                return Err(syntax(line, format!("{what} {l} is not below the {leaves} leaves")));
            }
        }
        let mut winding = Vec::with_capacity(n);
        for group in s[head_end..].split(')') {
            let g = group.trim();
            if g.is_empty() {
                continue;
            }
            let g = g
                .strip_prefix('(')
                .ok_or_else(|| syntax(line, format!("expected \"(\", found {g:?}")))?;
            let xyz: Vec<f64> = g
                .split_whitespace()
                .map(|t| t.parse::<f64>().ok().filter(|v| v.is_finite()))
                .collect::<Option<_>>()
                .ok_or_else(|| syntax(line, format!("point {}: not three numbers: {g:?}", winding.len() + 1)))?;
            if xyz.len() != 3 {
                return Err(syntax(
                    line,
                    format!("point {}: {} coordinates, expected 3", winding.len() + 1, xyz.len()),
                ));
            }
            winding.push([xyz[0], xyz[1], xyz[2]]);
        }
        if winding.len() != n || n < 3 {
            return Err(syntax(
                line,
                format!("{} points, header says {n} (at least 3)", winding.len()),
            ));
        }
        portals.push(PrtPortal {
            leaves: [l0, l1],
            winding,
            line,
        });
    }
    if portals.len() < portals_n {
        return Err(PrtError::Truncated {
            line: last + 1,
            found: portals.len(),
            expected: portals_n,
        });
    }
    Ok(PrtFile { leaves, portals })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_names_bad_lines() {
        let ok = "PRT1\n2\n1\n4 0 1 (0 0 0 ) (0 1 0 ) (0 1 1 ) (0 0 1 ) \n";
        let f = parse(ok).unwrap();
        assert_eq!((f.leaves, f.portals.len()), (2, 1));
        assert_eq!(f.portals[0].winding[2], [0.0, 1.0, 1.0]);
        let bad = "PRT1\n2\n1\n4 0 1 (0 0 0 ) (0 x 0 ) (0 1 1 ) (0 0 1 ) \n";
        let e = parse(bad).unwrap_err();
        assert!(matches!(e, PrtError::Syntax { line: 4, .. }), "{e}");
        let e = parse("PRT1\n2\n1\n4 0 5 (0 0 0 ) (0 1 0 ) (0 1 1 ) (0 0 1 )\n").unwrap_err();
        assert!(e.to_string().starts_with("line 4: leaf1 5"), "{e}");
        let e = parse("PRT1\n2\n2\n3 0 1 (0 0 0 ) (0 1 0 ) (0 1 1 )\n").unwrap_err();
        assert!(
            matches!(
                e,
                PrtError::Truncated {
                    found: 1,
                    expected: 2,
                    ..
                }
            ),
            "{e}"
        );
        assert!(matches!(
            parse("PRT2\n1\n1\n1\n").unwrap_err(),
            PrtError::Unsupported { line: 1, .. }
        ));
    }
}
