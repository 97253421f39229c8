//! What a caller knows beyond the run itself, drawn into the pictures: the full
//! decimation (the weight curve past the stop), the first room-joining collapse and the
//! ground truth (room sample points and doorways on the top view). `run` passes the full
//! run only; `experiment` passes all of it.

use crate::decimate::Step;
use crate::generate::thesis::GroundTruth;

/// Annotations for the pictures ([`super::SetOptions::notes`]); every field is optional.
#[derive(Clone, Copy, Debug, Default)]
pub struct Notes<'a> {
    /// The steps of the full decimation (stop `none`) when the run stopped earlier; the
    /// run's own steps are a prefix of them.
    pub full_steps: Option<&'a [Step]>,
    /// The 1-based step of the full run's first collapse joining two ground-truth rooms.
    pub first_join: Option<usize>,
    /// The ground truth (room sample points, doorways).
    pub truth: Option<&'a GroundTruth>,
}
