//! The thesis's six models ([`crate::generate::thesis::all`]) as a family: seed = index in the
//! thesis's order. Truth from their [`crate::generate::thesis::GroundTruth`]; membership by the
//! nearest sample point (see the module docs of [`crate::suite`]).

use super::{Membership, SuiteTruth, TruthRoom};
use crate::generate::scenes::Soup;

/// The thesis model with this index: its name, soup and truth.
pub fn model(index: usize) -> Option<(&'static str, Soup, SuiteTruth)> {
    let name = *crate::generate::thesis::NAMES.get(index)?;
    let m = crate::generate::thesis::by_name(name)?;
    let membership = Membership::NearestSample(
        m.truth
            .rooms
            .iter()
            .enumerate()
            .flat_map(|(i, r)| r.samples.iter().map(move |&s| (s, i)))
            .collect(),
    );
    let truth = SuiteTruth {
        rooms: m
            .truth
            .rooms
            .iter()
            .map(|r| TruthRoom {
                name: r.name.clone(),
                samples: r.samples.clone(),
            })
            .collect(),
        doorways: m.truth.doorways.clone(),
        membership,
    };
    Some((m.name, m.soup, truth))
}
