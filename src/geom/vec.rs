//! The vector helpers of [`crate::base::vec`], under the path the geometry kernel uses.

pub(crate) use crate::base::vec::*;
