//! Median timings over the frames of a run, in milliseconds: the per-stage columns of the
//! paper's Table 1 for the contact pass, the per-step columns of a fold for the self-contact
//! pass. Shared by the command line (`pose`, `demo`) and the benchmarks.

use crate::pass::StageTimings;
use crate::selfcontact::fold::FoldTimings;
use serde::Serialize;

/// Median of each stage over `timings`, in ms (the paper's Table 1 columns).
pub fn median_stages(timings: &[StageTimings]) -> StageTimings {
    let m = |f: fn(&StageTimings) -> f64| median(timings.iter().map(f).collect()) * 1e3;
    StageTimings {
        setup: m(|t| t.setup),
        intersection: m(|t| t.intersection),
        mapping: m(|t| t.mapping),
        zones: m(|t| t.zones),
        parametrization: m(|t| t.parametrization),
        directions: m(|t| t.directions),
        fields: m(|t| t.fields),
        deformation: m(|t| t.deformation),
        factorization: m(|t| t.factorization),
        wall: m(|t| t.wall),
    }
}

/// Median fold step times in ms: each step of [`FoldTimings`] summed over the folds of a frame,
/// and `wall`, the whole self-contact pass of the frame.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct FoldMs {
    /// The steps.
    #[serde(flatten)]
    pub steps: FoldTimings,
    /// The whole self-contact pass of the frame.
    pub wall: f64,
}

/// Median of each fold step over `frames` (`(summed fold timings, pass wall time)` in s), in
/// ms.
pub fn median_folds(frames: &[(FoldTimings, f64)]) -> FoldMs {
    let m = |f: fn(&(FoldTimings, f64)) -> f64| median(frames.iter().map(f).collect()) * 1e3;
    FoldMs {
        steps: FoldTimings {
            detection: m(|t| t.0.detection),
            crease: m(|t| t.0.crease),
            contact: m(|t| t.0.contact),
            directions: m(|t| t.0.directions),
            deformation: m(|t| t.0.deformation),
            volume: m(|t| t.0.volume),
            stages: median_stages(&frames.iter().map(|t| t.0.stages).collect::<Vec<_>>()),
        },
        wall: m(|t| t.1),
    }
}

/// Median of a list (0 for an empty one).
pub fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_even_and_empty_lists() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(vec![4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(Vec::new()), 0.0);
    }

    #[test]
    fn fold_medians_are_per_step_in_ms() {
        let step = |s: f64| FoldTimings {
            detection: s,
            crease: 2.0 * s,
            contact: 0.0,
            directions: 0.0,
            deformation: 3.0 * s,
            volume: 0.0,
            stages: StageTimings {
                parametrization: 4.0 * s,
                ..StageTimings::default()
            },
        };
        let m = median_folds(&[
            (step(0.001), 0.01),
            (step(0.003), 0.03),
            (step(0.002), 0.02),
        ]);
        assert!((m.steps.detection - 2.0).abs() < 1e-12);
        assert!((m.steps.crease - 4.0).abs() < 1e-12);
        assert!((m.steps.deformation - 6.0).abs() < 1e-12);
        assert!((m.steps.stages.parametrization - 8.0).abs() < 1e-12);
        assert!((m.wall - 20.0).abs() < 1e-12);
    }
}
