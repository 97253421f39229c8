//! Newtype indices. Every index that crosses a module boundary is one of these, so a
//! vertex index can never be passed where a tetrahedron index is expected.
//!
//! All are `u32`: a million-triangle model has ~7M tetrahedra, far below `u32::MAX`.

use serde::{Deserialize, Serialize};

macro_rules! id_type {
    ($(#[$m:meta])* $name:ident) => {
        $(#[$m])*
        #[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
        pub struct $name(pub u32);
        impl $name {
            /// The index as a `usize`, for slice access.
            #[inline]
            pub fn idx(self) -> usize {
                self.0 as usize
            }
        }
        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                write!(f, "{}", self.0)
            }
        }
    };
}

id_type!(
    /// A welded model vertex; also a vertex of the tetrahedralization.
    VertexId
);
id_type!(
    /// A finite tetrahedron of a [`crate::delaunay::Tetrahedralization`].
    TetId
);
id_type!(
    /// A model polygon (after cleaning).
    PolygonId
);
id_type!(
    /// A cell of the cell complex (a convex piece after splitting, or a merged cell).
    CellId
);
id_type!(
    /// A patch of the cell complex: a face shared by two cells (or a cell and the
    /// outside), the tag of the cells' polyhedron faces (`complex` re-exports it).
    PatchId
);
