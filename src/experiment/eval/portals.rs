//! Portal matching: final or separating portals reduced to centroid and area, matched
//! within tolerances (the rotation check of thesis 4.3.4).

use super::geometry::{dist, weighted_centroid};
use super::types::{Evaluation, PortalSummary, RotationCheck};
use crate::experiment::definition::CompareTo;
use crate::experiment::transform::{Transform, invert_all, length_factor};
use crate::geom::ConvexPolygon;
use crate::output::ResultDoc;

/// The final portals of a result document, centroids in the input's frame (the
/// document's `origin` added), where runs of different models are compared.
pub fn portal_summaries(doc: &ResultDoc) -> Vec<PortalSummary> {
    doc.portals
        .iter()
        .map(|p| {
            let polys: Vec<ConvexPolygon> = p.polygons.iter().map(|v| ConvexPolygon::new(v.clone())).collect();
            PortalSummary {
                centroid: crate::model::translate_point(weighted_centroid(&polys), doc.model.origin),
                area: p.area,
            }
        })
        .collect()
}

/// True when two portals match: centroids closer than `dist_tol`, areas within
/// `area_rel` of the larger one.
pub fn portals_match(a: &PortalSummary, b: &PortalSummary, dist_tol: f64, area_rel: f64) -> bool {
    dist(&a.centroid, &b.centroid) <= dist_tol && (a.area - b.area).abs() <= area_rel * a.area.max(b.area)
}

/// How many of `ours` match some portal of `theirs`.
pub fn match_portals(ours: &[PortalSummary], theirs: &[PortalSummary], dist_tol: f64, area_rel: f64) -> usize {
    ours.iter()
        .filter(|a| theirs.iter().any(|b| portals_match(a, b, dist_tol, area_rel)))
        .count()
}

/// Maps portals by the inverse of `ts` (centroids; areas by the inverse scale squared).
pub fn map_back(ps: &[PortalSummary], ts: &[Transform]) -> Vec<PortalSummary> {
    let f = length_factor(ts);
    ps.iter()
        .map(|p| PortalSummary {
            centroid: invert_all(ts, p.centroid),
            area: p.area / (f * f),
        })
        .collect()
}

/// The separating portals of an evaluation (`None` without a ground truth).
pub fn separating_summaries(e: &Evaluation) -> Option<Vec<PortalSummary>> {
    let s = e.truth.as_ref()?.separation.as_ref()?;
    Some(
        s.portals
            .iter()
            .map(|p| PortalSummary {
                centroid: p.centroid,
                area: p.area,
            })
            .collect(),
    )
}

/// The rotation check of `ours` (this experiment's final or separating portals) against `theirs`, whose
/// model has bounding-box diagonal `their_diagonal`.
pub fn rotation_check(
    c: &CompareTo,
    ours: &[PortalSummary],
    theirs: &[PortalSummary],
    their_diagonal: f64,
) -> RotationCheck {
    let back = map_back(ours, &c.transform_inverse_of);
    let tol = c.distance_tolerance * their_diagonal;
    let ours_matched = match_portals(&back, theirs, tol, c.area_tolerance);
    let theirs_matched = match_portals(theirs, &back, tol, c.area_tolerance);
    let max_match_distance = back
        .iter()
        .filter_map(|a| {
            theirs
                .iter()
                .filter(|b| portals_match(a, b, tol, c.area_tolerance))
                .map(|b| dist(&a.centroid, &b.centroid))
                .min_by(f64::total_cmp)
        })
        .max_by(f64::total_cmp);
    RotationCheck {
        against: c.experiment.clone(),
        portals: c.portals,
        distance_tolerance: tol,
        area_tolerance: c.area_tolerance,
        ours_matched,
        ours_total: ours.len(),
        theirs_matched,
        theirs_total: theirs.len(),
        identical: ours.len() == theirs.len() && ours_matched == ours.len() && theirs_matched == theirs.len(),
        max_match_distance,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiment::definition::PortalSet;

    fn ps(c: [f64; 3], area: f64) -> PortalSummary {
        PortalSummary { centroid: c, area }
    }

    #[test]
    fn portals_match_by_distance_and_relative_area() {
        let a = ps([0.0; 3], 1.0);
        assert!(portals_match(&a, &ps([0.1, 0.0, 0.0], 1.1), 0.1, 0.1));
        assert!(!portals_match(&a, &ps([0.11, 0.0, 0.0], 1.0), 0.1, 0.1), "too far");
        assert!(
            !portals_match(&a, &ps([0.0; 3], 1.2), 0.1, 0.1),
            "area off by 1/6 of the larger"
        );
        let ours = [a, ps([5.0, 0.0, 0.0], 2.0), ps([9.0, 0.0, 0.0], 1.0)];
        let theirs = [ps([0.05, 0.0, 0.0], 1.0), ps([5.0, 0.0, 0.0], 20.0)];
        assert_eq!(match_portals(&ours, &theirs, 0.1, 0.2), 1);
        assert_eq!(match_portals(&theirs, &ours, 0.1, 0.2), 1);
    }

    #[test]
    fn rotation_check_maps_back_and_counts_both_ways() {
        let base = [ps([1.0, 0.0, 0.0], 1.0), ps([0.0, 2.0, 0.0], 2.0)];
        // Ours: the base scaled by 2 and shifted; the check maps them back.
        let ts = vec![Transform::Scale(2.0), Transform::Translate([10.0, 0.0, 0.0])];
        let ours: Vec<PortalSummary> = base
            .iter()
            .map(|p| ps(crate::experiment::apply_all(&ts, p.centroid), p.area * 4.0))
            .collect();
        let c = CompareTo {
            experiment: "base".into(),
            portals: PortalSet::Final,
            transform_inverse_of: ts,
            distance_tolerance: 0.01,
            area_tolerance: 0.01,
        };
        let r = rotation_check(&c, &ours, &base, 10.0);
        assert_eq!((r.ours_matched, r.theirs_matched), (2, 2));
        assert!(r.identical);
        assert_eq!(r.distance_tolerance, 0.1);
        assert!(r.max_match_distance.unwrap() < 1e-12);
        // One extra portal of theirs: not identical, and it is the one unmatched.
        let more = [base[0], base[1], ps([7.0, 7.0, 7.0], 1.0)];
        let r = rotation_check(&c, &ours, &more, 10.0);
        assert_eq!((r.ours_matched, r.theirs_matched, r.theirs_total), (2, 2, 3));
        assert!(!r.identical);
    }
}
