//! Writing polygon soups: Wavefront OBJ and the `.mesh` format, atomically (a temporary
//! file in the same directory, renamed into place), so an error never leaves a partial file.

use std::io::Write;
use std::path::Path;

/// Writes `text` to `path` through a temporary sibling file and a rename.
pub fn write_atomic(path: &Path, text: &[u8]) -> std::io::Result<()> {
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(text)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// The soup as OBJ text (1-based indices), with a comment header.
pub fn obj_text(header: &str, vertices: &[[f64; 3]], polygons: &[Vec<u32>]) -> String {
    let mut s = String::with_capacity(vertices.len() * 32 + polygons.len() * 24);
    for line in header.lines() {
        s += "# ";
        s += line;
        s += "\n";
    }
    for v in vertices {
        s += &format!("v {} {} {}\n", v[0], v[1], v[2]);
    }
    for p in polygons {
        s += "f";
        for i in p {
            s += &format!(" {}", i + 1);
        }
        s += "\n";
    }
    s
}

/// The soup in the `.mesh` format (see the module docs of [`crate::model`]).
pub fn mesh_text(vertices: &[[f64; 3]], polygons: &[Vec<u32>]) -> String {
    let mut s = format!("{} {}\n", vertices.len(), polygons.len());
    for v in vertices {
        s += &format!("{} {} {}\n", v[0], v[1], v[2]);
    }
    for p in polygons {
        s += &p.len().to_string();
        for i in p {
            s += &format!(" {i}");
        }
        s += "\n";
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_through_both_formats() {
        let v = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.5]];
        let p = vec![vec![0, 2, 1], vec![0, 1, 3], vec![0, 3, 2], vec![1, 2, 3]];
        let a = crate::model::parse_obj_str("t", &obj_text("tetra", &v, &p)).unwrap();
        let b = crate::model::parse_mesh_str("t", &mesh_text(&v, &p)).unwrap();
        // The loader renumbers vertices in order of first use; compare as sets.
        let sorted = |mut x: Vec<[f64; 3]>| {
            x.sort_by(|p, q| p.partial_cmp(q).unwrap());
            x
        };
        assert_eq!(sorted(a.vertices.clone()), sorted(v.clone()));
        assert_eq!(sorted(b.vertices.clone()), sorted(v.clone()));
        assert_eq!(a.polygons.len(), 4);
        assert_eq!(b.polygons.len(), 4);
    }

    #[test]
    fn atomic_write_leaves_no_temporary() {
        let dir = std::env::temp_dir().join(format!("pf-write-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("a.obj");
        write_atomic(&f, b"v 0 0 0\n").unwrap();
        assert_eq!(std::fs::read(&f).unwrap(), b"v 0 0 0\n");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        // Writing into a missing directory fails and leaves nothing behind.
        assert!(write_atomic(&dir.join("missing/x.obj"), b"x").is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
