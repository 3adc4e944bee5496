//! Corner cases of the contact pass on generated meshes: deep penetration, grazing contact,
//! contact at a mesh boundary, bad input. Documented results, never a panic or a NaN.

#[path = "common/meshes.rs"]
mod meshes;

use contact_skin::pass::{ContactPass, ObjectParams, PassError, RestBody};
use contact_skin::report::metrics;
use meshes::{grid, icosphere, TestMesh};
use nalgebra::{Point3, Vector3};

fn moved(m: &TestMesh, scale: f64, offset: Vector3<f64>) -> Vec<Point3<f64>> {
    m.positions
        .iter()
        .map(|p| Point3::from(p.coords * scale + offset))
        .collect()
}

fn pass_for(bodies: &[RestBody]) -> ContactPass {
    let params = bodies.iter().map(|_| ObjectParams::default()).collect();
    ContactPass::new(bodies, params, vec![]).expect("pass precomputes")
}

fn finite(out: &[Vec<Point3<f64>>]) -> bool {
    out.iter().all(|b| metrics::non_finite(b) == 0)
}

/// A small sphere entirely inside a big one: no intersection curve, so no contact is found
/// (the method needs intersection curves to define `I_l`); the output is the input.
#[test]
fn an_object_entirely_inside_another_is_left_unchanged() {
    let s = icosphere(3);
    let (big, small) = (
        moved(&s, 1.0, Vector3::zeros()),
        moved(&s, 0.3, Vector3::new(0.1, 0.0, 0.0)),
    );
    let pass = pass_for(&[(&big, &s.triangles), (&small, &s.triangles)]);
    let out = pass.run(&[big.clone(), small.clone()]).expect("runs");
    assert!(out.contacts.is_empty());
    assert_eq!(out.positions, vec![big, small]);
}

/// Two ellipsoids crossing at right angles about one center: the normals over each side's
/// intersection region cancel out, so Eq. 2 gives no direction. The pair is left as it was and
/// counted (`pairs_without_direction`, a warning in `pose`: until 2026-12-05 it was dropped
/// without a word, as if the bodies only touched); a configured direction resolves it.
#[test]
fn a_symmetric_crossing_is_counted_and_a_configured_direction_resolves_it() {
    use contact_skin::pass::{DirectionTrack, PairOverride};
    let s = icosphere(3);
    let stretched = |axis: usize| -> Vec<Point3<f64>> {
        let mut scale = Vector3::repeat(0.3);
        scale[axis] = 1.0;
        s.positions
            .iter()
            .map(|p| Point3::from(p.coords.component_mul(&scale)))
            .collect()
    };
    let (a, b) = (stretched(0), stretched(2));
    let bodies = [
        (a.as_slice(), s.triangles.as_slice()),
        (b.as_slice(), s.triangles.as_slice()),
    ];
    let input = vec![a.clone(), b.clone()];
    let out = pass_for(&bodies).run(&input).expect("runs");
    assert_eq!(out.pairs_without_direction, 1);
    assert!(out.contacts.is_empty());
    assert_eq!(out.positions, input);
    let along_y = PairOverride {
        direction: Some(DirectionTrack::constant(Vector3::y())),
        ..PairOverride::new([0, 1])
    };
    let params = bodies.iter().map(|_| ObjectParams::default()).collect();
    let pass = ContactPass::new(&bodies, params, vec![along_y]).expect("pass precomputes");
    let out = pass.run(&input).expect("runs");
    assert_eq!((out.pairs_without_direction, out.contacts.len()), (0, 1));
    assert!(finite(&out.positions));
    assert_ne!(out.positions, input);
}

/// Deep penetration: a sphere sunk past its center into another, down to almost entirely
/// inside. Finite output, no inverted face; the volume is exact whenever the cubic has a root,
/// otherwise (almost swallowed: the free part of the small sphere can only bulge inward) the
/// documented fallback is no bulge (`RootKind` reported).
#[test]
fn deep_penetration_is_resolved_without_nan() {
    let s = icosphere(3);
    let mut exact = 0;
    for depth in [0.6, 0.9, 1.1, 1.2] {
        let a = moved(&s, 1.0, Vector3::zeros());
        let b = moved(&s, 0.6, Vector3::new(0.0, 0.0, 1.6 - depth));
        let pass = pass_for(&[(&a, &s.triangles), (&b, &s.triangles)]);
        let out = pass.run(&[a.clone(), b.clone()]).expect("runs");
        assert!(finite(&out.positions), "depth {depth}: NaN");
        assert_eq!(out.contacts.len(), 1, "depth {depth}");
        for (k, input) in [a, b].iter().enumerate() {
            let v0 = contact_skin::mesh::signed_volume(input, &s.triangles);
            let v1 = contact_skin::mesh::signed_volume(&out.positions[k], &s.triangles);
            let stats = out.diagnostics[k]
                .as_ref()
                .and_then(|d| d.stats)
                .expect("deformed");
            let inv = metrics::inverted_faces(&s.triangles, input, &out.positions[k]);
            let err = ((v1 - v0) / v0).abs();
            println!("depth {depth} body {k}: volume error {err:.2e}, root {:?}, h_v {:.3}, zone {}, inverted {}", stats.root, stats.bulge_height, stats.zone_vertices, inv.inverted);
            assert_eq!(inv.inverted, 0, "depth {depth} body {k}: inverted faces");
            if stats.root == Some(contact_skin::deform::volume::RootKind::Exact) {
                assert!(err < 1e-4, "depth {depth} body {k}: volume error {err}");
                exact += 1;
            } else {
                assert_eq!(stats.bulge_height, 0.0);
            }
        }
    }
    assert!(exact >= 6, "most cases must be exact ({exact})");
}

/// Grazing contact: spheres touching at a vertex, then overlapping by tiny amounts. A touch is
/// no contact; a tiny overlap gives a tiny, finite displacement.
#[test]
fn grazing_contact_is_continuous_and_finite() {
    let s = icosphere(3);
    let a = moved(&s, 1.0, Vector3::zeros());
    let top = a.iter().map(|p| p.z).fold(f64::MIN, f64::max);
    let bottom = s.positions.iter().map(|p| p.z).fold(f64::MAX, f64::min) * 0.5;
    for overlap in [0.0, 1e-12, 1e-9, 1e-6, 1e-3] {
        let b = moved(&s, 0.5, Vector3::new(0.0, 0.0, top - bottom - overlap));
        let pass = pass_for(&[(&a, &s.triangles), (&b, &s.triangles)]);
        let out = pass.run(&[a.clone(), b.clone()]).expect("runs");
        assert!(finite(&out.positions));
        let moved_most = out.positions[0]
            .iter()
            .zip(&a)
            .chain(out.positions[1].iter().zip(&b))
            .map(|(p, q)| (p - q).norm())
            .fold(0.0, f64::max);
        println!(
            "overlap {overlap:e}: contacts {}, largest displacement {moved_most:e}",
            out.contacts.len()
        );
        assert!(
            moved_most <= 10.0 * overlap + 1e-12,
            "overlap {overlap}: moved {moved_most}"
        );
    }
}

/// Contact at a mesh boundary: a sphere pressed into an open square sheet near its border. The
/// sheet's border bounds the extent (`φ_max,eff`), no volume is solved for the open sheet, and
/// its border does not move.
#[test]
fn contact_at_an_open_border_keeps_the_border_fixed() {
    let sheet = grid(24);
    let s = icosphere(3);
    let plane: Vec<Point3<f64>> = sheet.positions.clone();
    let ball = moved(&s, 0.3, Vector3::new(0.85, 0.0, 0.25));
    let pass = pass_for(&[(&plane, &sheet.triangles), (&ball, &s.triangles)]);
    let out = pass.run(&[plane.clone(), ball.clone()]).expect("runs");
    assert!(finite(&out.positions));
    assert_eq!(out.contacts.len(), 1);
    let stats = out.diagnostics[0]
        .as_ref()
        .and_then(|d| d.stats)
        .expect("sheet deformed");
    assert!(stats.extent_bound, "the border must bound the extent");
    assert_eq!(stats.root, None, "an open sheet has no volume to preserve");
    let border = |p: &Point3<f64>| p.x.abs().max(p.y.abs()) > 1.0 - 1e-9;
    for (p, q) in plane.iter().zip(&out.positions[0]) {
        if border(p) {
            assert!((p - q).norm() < 1e-12, "border vertex moved");
        }
    }
    let v0 = contact_skin::mesh::signed_volume(&ball, &s.triangles);
    let v1 = contact_skin::mesh::signed_volume(&out.positions[1], &s.triangles);
    assert!(((v1 - v0) / v0).abs() < 1e-4);
}

#[test]
fn bad_input_gives_typed_errors() {
    let s = icosphere(2);
    let a = moved(&s, 1.0, Vector3::zeros());
    let b = moved(&s, 1.0, Vector3::new(1.5, 0.0, 0.0));
    let pass = pass_for(&[(&a, &s.triangles), (&b, &s.triangles)]);
    let mut nan = b.clone();
    nan[3].x = f64::NAN;
    assert!(matches!(
        pass.run(&[a.clone(), nan]),
        Err(PassError::Intersect { body: 1, .. })
    ));
    assert!(matches!(
        pass.run(std::slice::from_ref(&a)),
        Err(PassError::Mismatch(_))
    ));
    let short = a[..10].to_vec();
    assert!(matches!(
        pass.run(&[a.clone(), short]),
        Err(PassError::Intersect { .. })
    ));
    let bad_tris = vec![[0, 1, 99_999]];
    let params = vec![ObjectParams::default(); 2];
    assert!(ContactPass::new(&[(&a, &s.triangles), (&b, &bad_tris)], params, vec![]).is_err());
    // Degenerate faces and duplicated faces are tolerated.
    let mut tris = s.triangles.clone();
    tris.push(tris[0]);
    tris.push([0, 0, 1]);
    let params = vec![ObjectParams::default(); 2];
    let pass =
        ContactPass::new(&[(&a, &tris), (&b, &s.triangles)], params, vec![]).expect("tolerated");
    let out = pass.run(&[a.clone(), b.clone()]).expect("runs");
    assert!(finite(&out.positions));
    // One body: no pair and no tree to build, its positions still checked; a finite frame
    // comes back as it went in.
    let single = pass_for(&[(&a, &s.triangles)]);
    let mut nan = a.clone();
    nan[7].y = f64::NAN;
    assert!(matches!(
        single.run(&[nan]),
        Err(PassError::Intersect { body: 0, .. })
    ));
    assert!(matches!(
        single.run(&[a[..10].to_vec()]),
        Err(PassError::Intersect { body: 0, .. })
    ));
    let out = single.run(std::slice::from_ref(&a)).expect("runs");
    assert_eq!(out.positions, vec![a.clone()]);
    assert!(out.contacts.is_empty());
    // Its diagnostics are not stored, but given: those of an untouched body.
    assert!(out.diagnostics.len() == 1 && out.diagnostics[0].is_none());
    let d = out.diagnostics_of(0).expect("one body");
    assert_eq!(d.u, vec![1.0; a.len()]);
    assert!(d.stats.is_none() && d.zone.iter().all(|z| !z) && d.bulge.len() == a.len());
    assert!(out.diagnostics_of(1).is_none());
}

/// Sec. 4.2: when one object sinks past its silhouette into the other, the other side's
/// mapping region grows beyond its intersection region through the extruded contour quads
/// (`P_l(B_k)`), and the result has no residual penetration beyond the chord tolerance.
#[test]
fn extruded_contours_extend_the_mapping_region_in_deep_contact() {
    let s = icosphere(3);
    let a = moved(&s, 1.0, Vector3::zeros());
    let b = moved(&s, 0.6, Vector3::new(0.0, 0.0, 1.6 - 1.1));
    let pass = pass_for(&[(&a, &s.triangles), (&b, &s.triangles)]).with_passes(1);
    let out = pass.run(&[a.clone(), b.clone()]).expect("runs");
    let c = &out.contacts[0].contact;
    let (sa, sb) = (&c.sides[0].mapping, &c.sides[1].mapping);
    println!("mapping A {sa:?}\nmapping B {sb:?}");
    assert!(
        sa.contour_segments + sb.contour_segments > 0,
        "a silhouette inside the other body"
    );
    assert!(sa.wall_crossings + sb.wall_crossings > 0);
    assert!(
        sa.projected + sb.projected > 0,
        "P_l(B_k) adds vertices beyond B_l"
    );
    // Rays of B_l always hit; the propagation of P_l(B_k) stops at its first unmappable
    // vertices (counted as misses).
    let nan = out
        .positions
        .iter()
        .map(|p| metrics::non_finite(p))
        .sum::<usize>();
    assert_eq!(nan, 0);
}

/// The contact pass makes a body's normals only for a contact: `resolve_pair_lazily` asks for
/// none when two surfaces' boxes overlap without an intersection, one per side when they
/// meet, and then finds what `resolve_pair` finds with the same normals.
#[test]
fn normals_are_made_only_for_a_contact() {
    use contact_skin::contact::{
        resolve_pair, resolve_pair_lazily, PairOutcome, PairParams, SideFrame,
    };
    use contact_skin::intersect::MeshIndex;
    use contact_skin::mesh::operators::{vertex_normals, NormalWeighting};
    use std::cell::Cell;
    let s = icosphere(3);
    let a = moved(&s, 1.0, Vector3::zeros());
    let index = MeshIndex::new(&a, &s.triangles).expect("index");
    let params = PairParams::default();
    // Apart along the diagonal (boxes overlapping), then sunk into each other.
    for (offset, meets) in [(1.3, false), (0.9, true)] {
        let b = moved(&s, 0.6, Vector3::repeat(offset));
        let posed = [index.pose(&a).expect("a"), index.pose(&b).expect("b")];
        let normals = [&a, &b].map(|p| vertex_normals(p, &s.triangles, NormalWeighting::Area));
        let asked = Cell::new(0);
        let lazily = resolve_pair_lazily(
            [&posed[0], &posed[1]],
            |k| {
                asked.set(asked.get() + 1);
                &normals[k]
            },
            &params,
        )
        .expect("resolves");
        let side = |k: usize| SideFrame {
            mesh: &posed[k],
            normals: &normals[k],
            hittable: None,
        };
        let eager = resolve_pair(side(0), side(1), &params).expect("resolves");
        let lazily = match lazily {
            PairOutcome::Contact(c) => Some(*c),
            PairOutcome::Apart => None,
            PairOutcome::NoDirection => panic!("offset {offset}: no direction"),
        };
        assert_eq!(lazily.is_some(), meets, "offset {offset}");
        assert_eq!(asked.get(), if meets { 2 } else { 0 }, "offset {offset}");
        // The same contact but for its timings.
        let untimed = |c: Option<contact_skin::contact::Contact>| {
            c.map(|mut c| {
                c.timings = Default::default();
                format!("{c:?}")
            })
        };
        assert!(untimed(lazily) == untimed(eager), "offset {offset}");
    }
}
