//! The summary of a run as printed: its warnings, then JSON for machines or, for people, its
//! contacts, its folds, the ones left out and the metrics.

use super::{Args, LeftOutFold, Summary};
use crate::cli::measure::RunMetrics;
use crate::cli::CliResult;
use contact_skin::selfcontact::pass::FoldLayers;

/// The run's warnings on stderr, then its summary on stdout: JSON with `--json`, else a few
/// lines per pass and the metrics.
pub(super) fn print_summary(s: &Summary, a: &Args) -> CliResult {
    warn_stale(s, a);
    if let Some(first) = &s.first_fold_failure {
        eprintln!(
            "warning: {} self-contact fold(s) failed and were left as skinned, the others \
             resolved (first: {first})",
            s.folds_failed
        );
    }
    if let Some(first) = &s.first_contact_failure {
        eprintln!(
            "warning: {} contact(s) or deformation(s) between bodies failed and were left as \
             skinned, the others resolved (first: {first}); `[[pair]] enabled = false` or \
             `[[object]] contact = false` in the configuration leaves a pair or a body out",
            s.contacts_failed
        );
    }
    if let Some(first) = &s.first_inside_out {
        eprintln!(
            "warning: {} time(s) a pose turned a closed body inside out (a joint scaled by a \
             negative factor: its signed volume changed sign), left out of the passes in that \
             frame (first: {first})",
            s.bodies_inside_out
        );
    }
    if s.contacts_without_direction > 0 {
        eprintln!(
            "warning: {} time(s) two bodies intersected with no direction to resolve them \
             along (their normals cancel out, as in a symmetric crossing): left as they were; \
             a `[[pair]] direction` in the configuration resolves them",
            s.contacts_without_direction
        );
    }
    if a.json {
        println!("{}", serde_json::to_string_pretty(s)?);
        return Ok(());
    }
    println!(
        "posed {} ({} vertices) with {}: {} frames in {:.1} ms (precompute {:.1} ms, median {:.3} ms per frame), wrote {} file(s) to {}",
        s.rig,
        s.vertices,
        s.skinning,
        s.frames,
        s.total_ms,
        s.precompute_ms,
        s.median_frame_ms,
        s.files.len() + s.diagnostics,
        a.out.display()
    );
    print_contact(s);
    print_self_contact(s);
    if let Some(m) = &s.metrics {
        print_metrics(m);
    }
    Ok(())
}

/// The warning about an earlier run's frame files left in the output folder.
fn warn_stale(s: &Summary, a: &Args) {
    if let (Some(first), Some(last)) = (s.stale_files.first(), s.stale_files.last()) {
        eprintln!(
            "warning: {}: {} frame file(s) of an earlier run left in place ({first}{}), not part \
             of this run's {} frame(s)",
            a.out.display(),
            s.stale_files.len(),
            if first == last {
                String::new()
            } else {
                format!(" … {last}")
            },
            s.frames
        );
    }
}

/// The contact pass's line: frames in contact and median stage times.
fn print_contact(s: &Summary) {
    if let (Some(passes), Some(t)) = (s.passes, &s.stage_ms) {
        println!(
            "contact ({} pass(es), config {}): {} of {} frames in contact; median ms: intersection {:.3}, mapping {:.3}, zones {:.3}, parametrization {:.3}, directions {:.3}, fields {:.3}, deformation {:.3}, wall {:.3}",
            passes,
            s.config.as_deref().unwrap_or("none (defaults)"),
            s.contact_frames,
            s.frames,
            t.intersection,
            t.mapping,
            t.zones,
            t.parametrization,
            t.directions,
            t.fields,
            t.deformation,
            t.wall
        );
    }
    if !s.pairs_left_out_at_rest.is_empty() {
        let pairs: Vec<String> = (s.pairs_left_out_at_rest.iter())
            .map(|[a, b]| format!("'{a}' / '{b}'"))
            .collect();
        println!(
            "contact: {} pair(s) of bodies cross at rest (modeled overlaps) and are left out: {} ([[pair]] enabled = true resolves one)",
            pairs.len(),
            pairs.join(", ")
        );
    }
}

/// The line on the pairs left out in every frame, if any.
fn print_left_out_folds(folds: &[LeftOutFold]) {
    if folds.is_empty() {
        return;
    }
    let why = |f: &LeftOutFold| match (f.disabled, f.crossing_at_rest, &f.failure_at_rest) {
        (true, ..) => format!("{} (disabled)", f.name),
        (false, Some(n), _) => format!("{} ({n} face pairs cross at rest)", f.name),
        (false, None, Some(e)) => format!("{} (at rest: {e})", f.name),
        (false, None, None) => f.name.clone(),
    };
    println!(
        "self-contact: {} joint pair(s) left as they come in every frame: {} ([[self_contact.pair]] enabled = true resolves one whose sides cross at rest)",
        folds.len(),
        first_eight(folds, why)
    );
}

/// The first eight of `items` shown, then how many more: `a, b and 3 more`.
fn first_eight<T>(items: &[T], show: impl Fn(&T) -> String) -> String {
    let listed: Vec<String> = items.iter().take(8).map(show).collect();
    match items.len() - listed.len() {
        0 => listed.join(", "),
        more => format!("{} and {more} more", listed.join(", ")),
    }
}

/// The line on the pairs run without layers, if any.
fn print_layers(folds: &[FoldLayers]) {
    if folds.is_empty() {
        return;
    }
    let show = |f: &FoldLayers| {
        let faces: Vec<String> = f.layers.iter().map(|l| l.faces.to_string()).collect();
        format!("{} (pieces of {} faces)", f.name, faces.join(", "))
    };
    println!(
        "self-contact: {} joint pair(s) run without the separate pieces of the mesh sunk into them or lying inside others at rest, which follow the skinning: {}",
        folds.len(),
        first_eight(folds, show)
    );
}

/// The self-contact pass's lines: frames with a fold, median step times, Table 1's columns,
/// and what was skipped, left out, left unresolved or guarded.
fn print_self_contact(s: &Summary) {
    if let (Some(wall), Some(t)) = (s.self_contact_ms, &s.fold_ms) {
        let folds = if s.folds.is_empty() {
            "none".to_string()
        } else {
            s.folds.join(", ")
        };
        println!(
            "self-contact ({} joint pair(s)): {} of {} frames with a fold ({folds}); median ms per frame {wall:.3}; with a fold: detection {:.3}, crease {:.3}, contact {:.3}, directions {:.3}, deformation {:.3}, volume {:.3}, wall {:.3}",
            s.self_contact_pairs.len(),
            s.fold_frames,
            s.frames,
            t.steps.detection,
            t.steps.crease,
            t.steps.contact,
            t.steps.directions,
            t.steps.deformation,
            t.steps.volume,
            t.wall
        );
        let q = &t.steps.stages;
        println!(
            "self-contact in Table 1's columns (ms): i. {:.3}, m. {:.3}, c. {:.3}, p. {:.3}, di. {:.3}, g. {:.3}, de. {:.3}, s. {:.3}",
            q.intersection,
            q.mapping,
            q.zones,
            q.parametrization,
            q.directions,
            q.fields,
            q.deformation,
            q.factorization
        );
        for reason in &s.self_contact_pairs_skipped {
            println!("self-contact: skipped {reason}");
        }
        print_left_out_folds(&s.self_contact_pairs_left_out);
        print_layers(&s.self_contact_layers);
        if s.folds_without_direction > 0 {
            println!(
                "self-contact: {} fold(s) skipped without a direction (bones folded 180°, no common relative motion, or separated regions crossing symmetrically)",
                s.folds_without_direction
            );
        }
        if s.folds_unbalanced > 0 {
            let r = &s.folds_unbalanced_by_reason;
            println!(
                "self-contact: {} fold(s) left unresolved: no bulge could keep the volume without a spike or a face turned over ({} without a root of the volume cubic, {} too steep, {} turning a face over)",
                s.folds_unbalanced, r.no_volume_root, r.steep_bulge, r.turned_face
            );
        }
        if s.vertices_guarded > 0 {
            println!(
                "self-contact: the turn guard scaled back {} vertex displacement(s) (summed over the folds) so that no face turns over",
                s.vertices_guarded
            );
        }
        if s.bulges_guarded > 0 {
            println!(
                "self-contact: the bulge guard scaled back {} vertex bulge(s) (summed over the folds) so that no bulge enters the other part",
                s.bulges_guarded
            );
        }
        if s.crease_pairs_unseparated > 0 {
            println!(
                "self-contact: {} of the {} crossing face pair(s) of the crease cuts left on one side of their cut (summed over the folds), where the fold does not resolve them",
                s.crease_pairs_unseparated, s.crease_pairs
            );
        }
        if s.sweeps_max > s.sweeps_planned {
            println!(
                "self-contact: up to {} sweeps over the folds in a frame ({} planned, more while a fold still penetrated)",
                s.sweeps_max, s.sweeps_planned
            );
        }
    }
}

/// `--metrics` in words: each measure's worst frame.
fn print_metrics(m: &RunMetrics) {
    let at = |x: Option<usize>| x.map_or("-".into(), |x| x.to_string());
    let temporal = m.temporal.map_or("fewer than 3 frames".to_string(), |t| {
        format!(
            "{:.2} (frame {}, vertex {}); displacement-step ratio {:.3} ({:.3} h from frame {} to the next, vertex {}; the input's fastest vertex {:.3} h per frame)",
            t.ratio,
            at(t.frame),
            at(t.vertex),
            t.step_ratio,
            t.step_max_h,
            at(t.step_frame),
            at(t.step_vertex),
            t.input_step_max_h,
        )
    });
    println!(
        "metrics (worst frame; h = {:.4}): penetrating vertices {} (frame {}) in the input, {} (frame {}) in the output, deepest {:.2} h (frame {}); volume error of the closed bodies {:.1e} (frame {}); inverted faces {} (frame {}), of which turned by the deformer {} (frame {}); non-finite values {}; temporal second-difference ratio {temporal}",
        m.h,
        m.penetrating_before.value,
        m.penetrating_before.frame,
        m.penetrating_after.value,
        m.penetrating_after.frame,
        m.max_depth_after_h.value,
        m.max_depth_after_h.frame,
        m.volume_error.value,
        m.volume_error.frame,
        m.inverted_faces.value,
        m.inverted_faces.frame,
        m.turned_faces.value,
        m.turned_faces.frame,
        m.non_finite
    );
}
