//! Tests of the intersection building blocks (2021 Sec. 4.1-4.2): edge-face hits, curves,
//! intersection regions and their integrals, farthest-hit rays, silhouettes, self-contact,
//! degenerate inputs and determinism. Every mesh is generated here.

use contact_skin::intersect::{
    face_facing, farthest_hit, farthest_hit_among, farthest_hits, intersect_meshes,
    vertex_front_mask, EdgeHit, Facing, FrontSide, IntersectError, IntersectionRegion,
    Intersections, MeshIndex, PartsUnion, PosedMesh, QuadratureRule, Ray, RayHit, SegmentRays,
    Side, Silhouette,
};
use nalgebra::{Point3, Rotation3, Vector3};

#[path = "common/meshes.rs"]
mod meshes;
#[path = "common/rng.rs"]
mod rng;
use rng::Rng;

type Mesh = (Vec<Point3<f64>>, Vec<[u32; 3]>);

// ---------------------------------------------------------------------------------------------
// Generators
// ---------------------------------------------------------------------------------------------

fn signed_volume((pos, tris): &Mesh) -> f64 {
    tris.iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| pos[i as usize].coords);
            a.dot(&b.cross(&c))
        })
        .sum::<f64>()
        / 6.0
}

/// Makes a closed mesh outward oriented.
fn orient_outward(mut m: Mesh) -> Mesh {
    if signed_volume(&m) < 0.0 {
        for t in &mut m.1 {
            t.swap(1, 2);
        }
    }
    m
}

/// Icosphere with `subdiv` midpoint subdivisions (20 * 4^subdiv faces), vertices on the sphere
/// of `radius` about `center`, turned by `rot` (the shared generator of
/// `tests/common/meshes.rs`).
fn icosphere(subdiv: u32, radius: f64, center: Point3<f64>, rot: &Rotation3<f64>) -> Mesh {
    let m = meshes::icosphere(subdiv as usize);
    let pos = m
        .positions
        .iter()
        .map(|p| center + rot * p.coords * radius)
        .collect();
    (pos, m.triangles)
}

/// UV sphere with the given polar angles for its rings (poles added); `ring_override` replaces
/// the vertices of one ring by given points (shared exactly with another mesh).
fn uv_sphere(
    radius: f64,
    center: Point3<f64>,
    polar: &[f64],
    n_lon: usize,
    ring_override: Option<(usize, &[Point3<f64>])>,
) -> Mesh {
    let mut pos = vec![center + Vector3::z() * radius];
    for (j, &th) in polar.iter().enumerate() {
        for k in 0..n_lon {
            let ph = std::f64::consts::TAU * k as f64 / n_lon as f64 + 0.1;
            let p = match ring_override {
                Some((r, pts)) if r == j => pts[k],
                _ => {
                    center
                        + Vector3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()) * radius
                }
            };
            pos.push(p);
        }
    }
    pos.push(center - Vector3::z() * radius);
    let south = pos.len() as u32 - 1;
    let v = |j: usize, k: usize| (1 + j * n_lon + k % n_lon) as u32;
    let mut tris = Vec::new();
    for k in 0..n_lon {
        tris.push([0, v(0, k), v(0, k + 1)]);
        tris.push([south, v(polar.len() - 1, k + 1), v(polar.len() - 1, k)]);
    }
    for j in 0..polar.len() - 1 {
        for k in 0..n_lon {
            tris.push([v(j, k), v(j + 1, k), v(j + 1, k + 1)]);
            tris.push([v(j, k), v(j + 1, k + 1), v(j, k + 1)]);
        }
    }
    orient_outward((pos, tris))
}

/// Polar angles from 0 to pi (exclusive), `n1` steps up to `theta0` (included) and `n2` after.
fn polar_with_ring(theta0: f64, n1: usize, n2: usize) -> (Vec<f64>, usize) {
    let mut v: Vec<f64> = (1..=n1).map(|j| theta0 * j as f64 / n1 as f64).collect();
    let ring = v.len() - 1;
    v.extend((1..n2).map(|j| theta0 + (std::f64::consts::PI - theta0) * j as f64 / n2 as f64));
    (v, ring)
}

/// Square grid (open surface) centered at `c`, spanned by unit `e1`, `e2`, normal `e1 × e2`.
fn grid(c: Point3<f64>, e1: Vector3<f64>, e2: Vector3<f64>, half: f64, n: usize) -> Mesh {
    let mut pos = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (u, v) = (
                -half + 2.0 * half * i as f64 / n as f64,
                -half + 2.0 * half * j as f64 / n as f64,
            );
            pos.push(c + e1 * u + e2 * v);
        }
    }
    let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    let mut tris = Vec::new();
    for j in 0..n {
        for i in 0..n {
            tris.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            tris.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    (pos, tris)
}

/// Horizontal grid at exactly `z` (coordinates computed without rotation).
fn flat_grid(z: f64, half: f64, n: usize) -> Mesh {
    let mut m = grid(Point3::origin(), Vector3::x(), Vector3::y(), half, n);
    for p in &mut m.0 {
        p.z = z;
    }
    m
}

/// Concatenates meshes (vertex ids offset).
fn concat(a: &Mesh, b: &Mesh) -> Mesh {
    let off = a.0.len() as u32;
    let mut pos = a.0.clone();
    pos.extend(&b.0);
    let mut tris = a.1.clone();
    tris.extend(b.1.iter().map(|t| t.map(|v| v + off)));
    (pos, tris)
}

fn total_area((pos, tris): &Mesh) -> f64 {
    tris.iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| pos[i as usize]);
            0.5 * (b - a).cross(&(c - a)).norm()
        })
        .sum()
}

fn intersections(a: &Mesh, b: &Mesh) -> Intersections {
    intersect_meshes(&a.0, &a.1, &b.0, &b.1).expect("valid meshes")
}

// ---------------------------------------------------------------------------------------------
// Checks shared by several tests
// ---------------------------------------------------------------------------------------------

/// The hit lies on its edge (the point is the edge's lerp at `t`) and on its face: on the face
/// plane and at its barycentric coordinates, within `tol`.
fn check_hit(h: &EdgeHit, edge_mesh: &Mesh, face_mesh: &Mesh, tol: f64) {
    assert!((0.0..=1.0).contains(&h.t), "{h:?}");
    assert!(h.edge[0] < h.edge[1]);
    let (p, q) = (
        edge_mesh.0[h.edge[0] as usize],
        edge_mesh.0[h.edge[1] as usize],
    );
    assert!(
        (p + (q - p) * h.t - h.point).norm() <= tol,
        "off its edge: {h:?}"
    );
    let c = face_mesh.1[h.face as usize].map(|v| face_mesh.0[v as usize]);
    let n = (c[1] - c[0]).cross(&(c[2] - c[0])).normalize();
    let plane = n.dot(&(h.point - c[0])).abs();
    assert!(plane <= tol, "off the face plane by {plane:e}: {h:?}");
    assert!(h.bary.iter().all(|&b| b >= 0.0));
    assert!((h.bary.iter().sum::<f64>() - 1.0).abs() <= 1e-12);
    let from_bary = c[0].coords * h.bary[0] + c[1].coords * h.bary[1] + c[2].coords * h.bary[2];
    assert!((from_bary - h.point.coords).norm() <= tol, "{h:?}");
    // The crossing sign: the edge direction against the face normal.
    assert_eq!(h.entering, (q - p).dot(&n) < 0.0, "{h:?}");
}

fn check_all_hits(ints: &Intersections, a: &Mesh, b: &Mesh, tol: f64) {
    for h in &ints.hits {
        match h.side {
            Side::A => check_hit(h, a, b, tol),
            Side::B => check_hit(h, b, a, tol),
        }
    }
}

/// Closed surfaces: every curve is a closed loop and every hit is used by exactly two segments.
fn check_closed_curves(ints: &Intersections) {
    let mut uses = vec![0; ints.hits.len()];
    for s in &ints.segments {
        assert_ne!(s.hits[0], s.hits[1]);
        for h in s.hits {
            uses[h as usize] += 1;
        }
    }
    assert!(uses.iter().all(|&u| u == 2), "hit uses {uses:?}");
    assert!(ints.curves.iter().all(|c| c.closed));
    let covered: usize = ints.curves.iter().map(|c| c.segments.len()).sum();
    assert_eq!(covered, ints.segments.len());
    assert_eq!(ints.stats.anomalous_pairs, 0);
    // Consecutive segments of a curve share their hit.
    for c in &ints.curves {
        for (k, &s) in c.segments.iter().enumerate() {
            let seg = ints.segments[s as usize];
            assert_eq!(seg.hits[0], c.nodes[k]);
            assert_eq!(seg.hits[1], c.nodes[(k + 1) % c.nodes.len()]);
        }
    }
}

/// Distance of `x` to the circle of center `c`, unit normal `m`, radius `r`.
fn circle_distance(x: &Point3<f64>, c: &Point3<f64>, m: &Vector3<f64>, r: f64) -> f64 {
    let d = x - c;
    let h = m.dot(&d);
    let rho = (d - m * h).norm();
    (h * h + (rho - r) * (rho - r)).sqrt()
}

/// Smallest distance from the center to a face plane (the polyhedron lies between it and R).
fn inradius((pos, tris): &Mesh, c: &Point3<f64>) -> f64 {
    tris.iter()
        .map(|t| {
            let [a, b, d] = t.map(|i| pos[i as usize]);
            (b - a).cross(&(d - a)).normalize().dot(&(a - c)).abs()
        })
        .fold(f64::INFINITY, f64::min)
}

// ---------------------------------------------------------------------------------------------
// (a), (b): two spheres
// ---------------------------------------------------------------------------------------------

/// Analytic setting: sphere A (center 0, radius 1) and sphere B (center (0,0,1.2), radius 0.7)
/// meet in the circle z = 0.8125, radius sqrt(0.33984375), at about 88 degrees.
const Z0: f64 = 0.8125;
fn circle_radius() -> f64 {
    (1.0 - Z0 * Z0).sqrt()
}

#[test]
fn sphere_sphere_hits_lie_on_both_surfaces_and_curves_close() {
    let mut rng = Rng(7);
    let a = icosphere(3, 1.0, Point3::new(0.013, -0.021, 0.007), &rng.rotation());
    let b = icosphere(3, 0.7, Point3::new(0.031, 0.017, 1.2), &rng.rotation());
    let ints = intersections(&a, &b);
    assert!(ints.hits.len() > 50);
    check_all_hits(&ints, &a, &b, 1e-12);
    check_closed_curves(&ints);
    assert_eq!(ints.curves.len(), 1, "one loop");
    assert_eq!(ints.stats.symbolic_ties, 0, "generic position");
    assert_eq!(ints.stats.intersecting_pairs, ints.segments.len());
    // Both kinds of hits occur and alternate consistently.
    assert!(ints.hits.iter().any(|h| h.side == Side::A));
    assert!(ints.hits.iter().any(|h| h.side == Side::B));
}

#[test]
fn high_resolution_sphere_curve_approaches_the_analytic_circle() {
    // Each hit lies on both polyhedra, hence within [inradius, R] of both centers: its distance
    // to the analytic circle is at most about (dA + dB) / sin(angle), d = R - inradius.
    let mut rng = Rng(11);
    let (ca, cb) = (Point3::origin(), Point3::new(0.0, 0.0, 1.2));
    let sin_angle = (1.0 - (0.05f64 / 1.4).powi(2)).sqrt();
    let mut previous = f64::INFINITY;
    for subdiv in [3, 5] {
        let a = icosphere(subdiv, 1.0, ca, &rng.rotation());
        let b = icosphere(subdiv, 0.7, cb, &rng.rotation());
        let ints = intersections(&a, &b);
        check_all_hits(&ints, &a, &b, 1e-12);
        check_closed_curves(&ints);
        let bound = ((1.0 - inradius(&a, &ca)) + (0.7 - inradius(&b, &cb))) / sin_angle;
        let c = Point3::new(0.0, 0.0, Z0);
        let worst = ints
            .hits
            .iter()
            .map(|h| circle_distance(&h.point, &c, &Vector3::z(), circle_radius()))
            .fold(0.0, f64::max);
        assert!(
            worst <= 1.1 * bound,
            "subdiv {subdiv}: {worst:e} > {bound:e}"
        );
        assert!(
            worst < previous / 8.0,
            "quadratic convergence: {worst:e} vs {previous:e}"
        );
        previous = worst;
    }
    assert!(previous < 2e-3);
}

/// Acceptance: "the intersection curve of two spheres is the analytic circle (points within 1e-9
/// of it)". Two polyhedral spheres only meet on the analytic circle where both have their
/// vertices on it, so this is made exactly checkable with two UV spheres (A: center 0, radius 1;
/// B: center (0,0,1.2), radius 0.7) sharing one ring of vertices placed on the analytic circle
/// (bitwise identical points, the whole scene under a random rotation). The two polyhedra then
/// cross exactly along that ring: every hit must be one of its vertices (exact degenerate
/// crossings resolved by the symbolic perturbation, t = 0 or 1), so every hit lies within 1e-9
/// of the analytic circle AND on both meshes, and the curve is one closed loop.
#[test]
fn intersection_curve_of_two_spheres_is_the_analytic_circle() {
    let n_lon = 64;
    let rot = Rng(3).rotation();
    let (ca, cb) = (Point3::origin(), Point3::new(0.0, 0.0, 1.2));
    let ring: Vec<Point3<f64>> = (0..n_lon)
        .map(|k| {
            let ph = std::f64::consts::TAU * k as f64 / n_lon as f64 + 0.1;
            Point3::new(circle_radius() * ph.cos(), circle_radius() * ph.sin(), Z0)
        })
        .collect();
    let theta_a = Z0.acos();
    let theta_b = ((Z0 - 1.2) / 0.7).acos();
    let (pa, ra) = polar_with_ring(theta_a, 6, 26);
    let (pb, rb) = polar_with_ring(theta_b, 22, 10);
    let rotate = |m: Mesh| -> Mesh { (m.0.iter().map(|p| rot * p).collect(), m.1) };
    let a = rotate(uv_sphere(1.0, ca, &pa, n_lon, Some((ra, &ring))));
    let b = rotate(uv_sphere(0.7, cb, &pb, n_lon, Some((rb, &ring))));
    let ring: Vec<Point3<f64>> = ring.iter().map(|p| rot * p).collect();
    let (c, m) = (rot * Point3::new(0.0, 0.0, Z0), rot * Vector3::z());

    let ints = intersections(&a, &b);
    assert!(!ints.hits.is_empty());
    assert!(ints.stats.symbolic_ties > 0, "a degenerate configuration");
    check_closed_curves(&ints);
    assert_eq!(ints.curves.len(), 1);
    check_all_hits(&ints, &a, &b, 1e-12);
    for h in &ints.hits {
        let d = circle_distance(&h.point, &c, &m, circle_radius());
        assert!(d <= 1e-9, "hit {d:e} away from the analytic circle: {h:?}");
        assert!(
            ring.iter().any(|r| (r - h.point).norm() <= 1e-15),
            "not a ring vertex"
        );
        assert!(h.t == 0.0 || h.t == 1.0 || h.t < 1e-15 || h.t > 1.0 - 1e-15);
    }
    // The loop visits the whole ring.
    let mut visited: Vec<usize> = ints
        .hits
        .iter()
        .filter_map(|h| ring.iter().position(|r| (r - h.point).norm() <= 1e-15))
        .collect();
    visited.sort_unstable();
    visited.dedup();
    assert_eq!(visited.len(), n_lon);
}

/// The plane of the analytic circle cuts a polyhedral sphere: each hit lies on that plane (to
/// 1e-9; the plane mesh is exactly z = Z0) and on an edge of the sphere mesh (1e-12), and its
/// distance to the analytic circle is bounded by the sphere's discretization (R - inradius).
#[test]
fn radical_plane_hits_lie_on_the_plane_of_the_analytic_circle() {
    let ca = Point3::origin();
    let a = icosphere(4, 1.0, ca, &Rng(5).rotation());
    let b = flat_grid(Z0, 1.5, 17);
    let ints = intersections(&a, &b);
    check_all_hits(&ints, &a, &b, 1e-12);
    check_closed_curves(&ints);
    let rho_min = (inradius(&a, &ca).powi(2) - Z0 * Z0).sqrt();
    let c = Point3::new(0.0, 0.0, Z0);
    for h in &ints.hits {
        assert!((h.point.z - Z0).abs() <= 1e-9);
        let d = circle_distance(&h.point, &c, &Vector3::z(), circle_radius());
        assert!(d <= circle_radius() - rho_min + 1e-12, "{d:e}");
    }
}

// ---------------------------------------------------------------------------------------------
// (c): intersection regions and integrals
// ---------------------------------------------------------------------------------------------

/// Part of a convex polygon on the side `m·x <= c` (Sutherland-Hodgman, one plane).
fn clip_below(poly: &[Point3<f64>], m: &Vector3<f64>, c: f64) -> Vec<Point3<f64>> {
    let mut out = Vec::new();
    for i in 0..poly.len() {
        let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
        let (dp, dq) = (m.dot(&p.coords) - c, m.dot(&q.coords) - c);
        if dp <= 0.0 {
            out.push(p);
        }
        if (dp < 0.0 && dq > 0.0) || (dp > 0.0 && dq < 0.0) {
            out.push(p + (q - p) * (dp / (dp - dq)));
        }
    }
    out
}

/// Fan-integrates `f` (evaluated with a rule exact for quadratics) over a convex polygon.
fn polygon_integral(poly: &[Point3<f64>], f: &impl Fn(&Point3<f64>) -> f64) -> f64 {
    let mut s = 0.0;
    for k in 1..poly.len().saturating_sub(1) {
        let (a, b, c) = (poly[0], poly[k], poly[k + 1]);
        let area = 0.5 * (b - a).cross(&(c - a)).norm();
        let at = |w: [f64; 3]| Point3::from(a.coords * w[0] + b.coords * w[1] + c.coords * w[2]);
        let (x, y) = (2.0 / 3.0, 1.0 / 6.0);
        s += area / 3.0 * (f(&at([x, y, y])) + f(&at([y, x, y])) + f(&at([y, y, x])));
    }
    s
}

/// Sphere (A) against a tilted plane mesh (B) `m·x = c`: the sphere's region inside the "plane
/// body" is the part below the plane.
#[test]
fn region_of_a_plane_cutting_a_sphere() {
    let mut rng = Rng(21);
    let sphere = icosphere(3, 1.0, Point3::origin(), &rng.rotation());
    let m = rng.unit();
    let c = 0.3;
    let e1 = m.cross(&Vector3::new(0.3, 0.5, 0.8)).normalize();
    let e2 = m.cross(&e1);
    let plane = grid(Point3::from(m * c), e1, e2, 1.6, 23);
    assert!(e1.cross(&e2).dot(&m) > 0.999);

    let ia = MeshIndex::new(&sphere.0, &sphere.1).expect("sphere");
    let ib = MeshIndex::new(&plane.0, &plane.1).expect("plane");
    let (a, b) = (
        ia.pose(&sphere.0).expect("a"),
        ib.pose(&plane.0).expect("b"),
    );
    let ints = Intersections::between(&a, &b).expect("in contact");
    check_all_hits(&ints, &sphere, &plane, 1e-12);
    assert_eq!(ints.curves.len(), 1);
    assert!(ints.curves[0].closed);

    let inside = IntersectionRegion::inside(&ints, Side::A, &a).expect("region");
    let outside = IntersectionRegion::outside(&ints, Side::A, &a).expect("region");
    assert_eq!(inside.stats, Default::default());
    // Exact against an independent half-space clip of the polyhedron.
    let clip_area: f64 = sphere
        .1
        .iter()
        .map(|t| {
            polygon_integral(
                &clip_below(&t.map(|v| sphere.0[v as usize]), &m, c),
                &|_| 1.0,
            )
        })
        .sum();
    let area = inside.area(&a);
    assert!((area - clip_area).abs() <= 1e-12, "{area} vs {clip_area}");
    // Analytic cap area 2 pi R (R + c) within the discretization error (polyhedral area deficit).
    let analytic = std::f64::consts::TAU * (1.0 + c);
    let deficit = 1.0 - total_area(&sphere) / (4.0 * std::f64::consts::PI);
    assert!(
        (area / analytic - 1.0).abs() <= 1.5 * deficit,
        "{area} vs {analytic}"
    );
    // Inside and outside tile the surface.
    let total = total_area(&sphere);
    assert!((area + outside.area(&a) - total).abs() <= 1e-12 * total);
    let whole_in: usize = inside.whole_faces.len() + outside.whole_faces.len();
    assert_eq!(whole_in + inside.cut_faces.len(), sphere.1.len());

    // Linear and quadratic fields against the same independent clip.
    let lin =
        |p: &Point3<f64>| Vector3::new(0.3 * p.x - p.y + 2.0, p.z * 1.7, -p.x + 0.5 * p.y + p.z);
    let values: Vec<Vector3<f64>> = sphere.0.iter().map(lin).collect();
    let integral = inside.integrate_linear(&a, &values).expect("field");
    for k in 0..3 {
        let direct: f64 = sphere
            .1
            .iter()
            .map(|t| {
                let poly = clip_below(&t.map(|v| sphere.0[v as usize]), &m, c);
                polygon_integral(&poly, &|p| lin(p)[k])
            })
            .sum();
        assert!(
            (integral[k] - direct).abs() <= 1e-12,
            "{k}: {} vs {direct}",
            integral[k]
        );
    }
    let tris = &sphere.1;
    let quad = inside.integrate(&a, QuadratureRule::Degree2, |f, w| {
        let t = tris[f as usize];
        let v: Vector3<f64> = (0..3).map(|k| values[t[k] as usize] * w[k]).sum();
        v.norm_squared()
    });
    let direct: f64 = sphere
        .1
        .iter()
        .map(|t| {
            let poly = clip_below(&t.map(|v| sphere.0[v as usize]), &m, c);
            polygon_integral(&poly, &|p| lin(p).norm_squared())
        })
        .sum();
    assert!(
        (quad - direct).abs() <= 1e-11 * direct.abs(),
        "{quad} vs {direct}"
    );

    // The plane's region inside the sphere is the polygon bounded by the curve.
    let disk = IntersectionRegion::inside(&ints, Side::B, &b).expect("region");
    let loop_pts: Vec<Point3<f64>> = ints.curves[0]
        .nodes
        .iter()
        .map(|&h| ints.hits[h as usize].point)
        .collect();
    let shoelace = (0..loop_pts.len())
        .map(|i| {
            loop_pts[i]
                .coords
                .cross(&loop_pts[(i + 1) % loop_pts.len()].coords)
        })
        .sum::<Vector3<f64>>()
        .dot(&m)
        .abs()
        / 2.0;
    assert!(
        (disk.area(&b) - shoelace).abs() <= 1e-12,
        "{} vs {shoelace}",
        disk.area(&b)
    );
    let analytic_disk = std::f64::consts::PI * (1.0 - c * c);
    assert!((shoelace / analytic_disk - 1.0).abs() < 2.0 * deficit);
    let plane_total = total_area(&plane);
    let plane_out = IntersectionRegion::outside(&ints, Side::B, &b)
        .expect("region")
        .area(&b);
    assert!((disk.area(&b) + plane_out - plane_total).abs() <= 1e-12 * plane_total);
}

#[test]
fn region_vertex_labels_follow_the_crossing_signs() {
    let mut rng = Rng(31);
    let a = icosphere(3, 1.0, Point3::origin(), &rng.rotation());
    let b = icosphere(2, 0.6, Point3::new(0.2, 0.1, 0.9), &rng.rotation());
    let ia = MeshIndex::new(&a.0, &a.1).expect("a");
    let ib = MeshIndex::new(&b.0, &b.1).expect("b");
    let (pa, pb) = (ia.pose(&a.0).expect("a"), ib.pose(&b.0).expect("b"));
    let ints = Intersections::between(&pa, &pb).expect("in contact");
    for (side, mesh, other_c, other_r, posed) in [
        (Side::A, &a, Point3::new(0.2, 0.1, 0.9), 0.6, &pa),
        (Side::B, &b, Point3::origin(), 1.0, &pb),
    ] {
        let region = IntersectionRegion::inside(&ints, side, posed).expect("region");
        assert_eq!(region.stats, Default::default());
        assert!(!region.cut_faces.is_empty());
        // Vertices clearly inside / outside the other (analytic) sphere.
        for (v, p) in mesh.0.iter().enumerate() {
            let d = (p - other_c).norm() - other_r;
            if d.abs() > 0.05 {
                assert_eq!(region.inside[v], d < 0.0, "{side:?} vertex {v}");
            }
        }
        for h in ints.hits.iter().filter(|h| h.side == side) {
            assert_eq!(region.inside[h.edge[1] as usize], h.entering);
        }
        // Cut faces are exactly the faces holding a segment.
        let mut with_segment: Vec<u32> = ints
            .segments
            .iter()
            .map(|s| {
                if side == Side::A {
                    s.faces[0]
                } else {
                    s.faces[1]
                }
            })
            .collect();
        with_segment.sort_unstable();
        with_segment.dedup();
        let cut: Vec<u32> = region.cut_faces.iter().map(|c| c.face).collect();
        assert_eq!(cut, with_segment);
    }
}

// ---------------------------------------------------------------------------------------------
// (d): farthest-hit rays
// ---------------------------------------------------------------------------------------------

/// Moller-Trumbore, returning `t` in `[0, max_t]`.
fn moller_trumbore(ray: &Ray, c: [Point3<f64>; 3]) -> Option<f64> {
    let (e1, e2) = (c[1] - c[0], c[2] - c[0]);
    let p = ray.dir.cross(&e2);
    let det = e1.dot(&p);
    if det.abs() < 1e-300 {
        return None;
    }
    let s = ray.origin - c[0];
    let u = s.dot(&p) / det;
    let q = s.cross(&e1);
    let v = ray.dir.dot(&q) / det;
    let t = e2.dot(&q) / det;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t >= 0.0 && t <= ray.max_t).then_some(t)
}

/// A non-convex closed surface: an icosphere with a radial bump.
fn bumpy_sphere() -> Mesh {
    let (mut pos, tris) = icosphere(3, 1.0, Point3::origin(), &Rotation3::identity());
    for p in &mut pos {
        let r = 1.0 + 0.4 * (5.0 * p.x).sin() * (4.0 * p.y).cos() + 0.25 * (6.0 * p.z).sin();
        *p = Point3::from(p.coords * r);
    }
    (pos, tris)
}

#[test]
fn farthest_hit_matches_brute_force() {
    let mesh = bumpy_sphere();
    let index = MeshIndex::new(&mesh.0, &mesh.1).expect("mesh");
    let posed = index.pose(&mesh.0).expect("pose");
    let mut rng = Rng(99);
    let rays: Vec<Ray> = (0..3000)
        .map(|_| {
            let mut point =
                |h: f64| Point3::new(rng.range(-h, h), rng.range(-h, h), rng.range(-h, h));
            // Mostly aimed through the middle of the object, with various lengths.
            let (o, target) = (point(1.6), point(0.5));
            Ray::new(o, (target - o).normalize(), rng.range(0.5, 4.0))
        })
        .collect();
    let batch = farthest_hits(&posed, &rays);
    let (mut hits, mut multi) = (0, 0);
    for (ray, got) in rays.iter().zip(&batch) {
        assert_eq!(*got, farthest_hit(&posed, ray));
        let all: Vec<(f64, u32)> = mesh
            .1
            .iter()
            .enumerate()
            .filter_map(|(f, t)| {
                moller_trumbore(ray, t.map(|v| mesh.0[v as usize])).map(|t| (t, f as u32))
            })
            .collect();
        multi += (all.len() > 2) as usize;
        let brute = all
            .iter()
            .map(|x| x.0)
            .fold(None, |b: Option<f64>, t| Some(b.map_or(t, |b| b.max(t))));
        match (got, brute) {
            (None, None) => {}
            (Some(h), Some(t)) => {
                hits += 1;
                assert!((h.t - t).abs() <= 1e-9, "{} vs {t}", h.t);
                assert!((h.point - (ray.origin + ray.dir * t)).norm() <= 1e-9);
                check_ray_hit(h, &mesh);
            }
            _ => panic!("ray {ray:?}: {got:?} vs brute force {brute:?}"),
        }
    }
    eprintln!(
        "{hits} of {} rays hit, {multi} with more than two crossings",
        rays.len()
    );
    assert!(
        hits > 1500 && multi > 100,
        "{hits} hits, {multi} with several crossings"
    );
}

fn check_ray_hit(h: &RayHit, mesh: &Mesh) {
    let c = mesh.1[h.face as usize].map(|v| mesh.0[v as usize]);
    let from_bary = c[0].coords * h.bary[0] + c[1].coords * h.bary[1] + c[2].coords * h.bary[2];
    assert!((from_bary - h.point.coords).norm() <= 1e-9);
}

#[test]
fn farthest_hit_through_a_shared_edge_and_invalid_rays() {
    // Two triangles sharing the edge x = 0 in the plane z = 0; a ray straight through the edge.
    let pos = vec![
        Point3::new(0.0, -1.0, 0.0),
        Point3::new(0.0, 1.0, 0.0),
        Point3::new(-1.0, 0.0, 0.0),
        Point3::new(1.0, 0.0, 0.0),
    ];
    let tris = vec![[0, 1, 2], [1, 0, 3]];
    let index = MeshIndex::new(&pos, &tris).expect("mesh");
    let posed = index.pose(&pos).expect("pose");
    let ray = Ray::new(Point3::new(0.0, 0.25, 1.0), -Vector3::z(), 5.0);
    let h = farthest_hit(&posed, &ray).expect("watertight: the edge is hit");
    assert_eq!(h.face, 0, "ties go to the smallest face");
    assert_eq!(h.t, 1.0);
    // A ray ending exactly on the surface counts (closed interval).
    let short = Ray::new(Point3::new(0.5, 0.1, 1.0), -Vector3::z(), 1.0);
    assert_eq!(farthest_hit(&posed, &short).map(|h| h.face), Some(1));
    for bad in [
        Ray::new(Point3::origin(), Vector3::zeros(), 1.0),
        Ray::new(Point3::new(f64::NAN, 0.0, 0.0), Vector3::z(), 1.0),
        Ray::new(Point3::origin(), Vector3::z(), -1.0),
    ] {
        assert_eq!(farthest_hit(&posed, &bad), None);
    }
}

/// The bisection points of segment `a -> b` (as a boundary bisection visits them, both ways),
/// its ends, and points off it: beyond its end, and beside its middle within its box.
fn points_along(a: Point3<f64>, b: Point3<f64>, rng: &mut Rng) -> Vec<Point3<f64>> {
    let beside = Point3::new(a.x, b.y, 0.5 * (a.z + b.z));
    let mut out = vec![a, b, a + (b - a) * 1.5 + rng.unit() * 0.3, beside];
    for toward_b in [true, false] {
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..16 {
            let mid = 0.5 * (lo + hi);
            out.push(a + (b - a) * mid);
            if toward_b {
                lo = mid;
            } else {
                hi = mid;
            }
        }
    }
    out
}

/// Rays from the points of a segment, their candidate faces gathered once, hit what the tree's
/// farthest hit does, to the bit: on a non-convex closed surface with random segments (edge
/// sized and long), directions (some along an axis, some along the segment) and a hittable
/// mask, and on a grid whose rays run down its edges and through its vertices.
#[test]
fn segment_rays_match_the_tree() {
    let mesh = bumpy_sphere();
    let index = MeshIndex::new(&mesh.0, &mesh.1).expect("mesh");
    let posed = index.pose(&mesh.0).expect("pose");
    let mut rng = Rng(7);
    let hittable: Vec<bool> = (0..mesh.1.len()).map(|f| f % 5 != 0).collect();
    let (mut hits, mut compared) = (0, 0);
    for case in 0..400 {
        let a = Point3::from(rng.unit() * rng.range(0.0, 1.6));
        let length = if case % 2 == 0 { 0.05 } else { 1.0 };
        let b = a + rng.unit() * length;
        let dir = match case % 4 {
            0 => Vector3::x(),
            1 => (b - a).normalize(),
            _ => rng.unit(),
        };
        let max_t = rng.range(0.2, 4.0);
        let mask = (case % 3 == 0).then_some(&hittable[..]);
        let rays = SegmentRays::new(&posed, mask, [a, b], dir, max_t);
        for o in points_along(a, b, &mut rng) {
            let tree = farthest_hit_among(&posed, &Ray::new(o, dir, max_t), mask);
            assert_eq!(rays.farthest_hit(o), tree, "case {case}, origin {o:?}");
            hits += tree.is_some() as usize;
            compared += 1;
        }
    }
    assert!(hits > compared / 4, "{hits} hits of {compared}");
    // Rays straight down onto a grid, from segments over its edges and vertices.
    let flat = flat_grid(0.0, 1.0, 8);
    let index = MeshIndex::new(&flat.0, &flat.1).expect("grid");
    let posed = index.pose(&flat.0).expect("pose");
    let down = -Vector3::z();
    for (a, b) in [
        ((-1.0, 0.25), (1.0, 0.25)),
        ((0.0, -1.0), (0.0, 1.0)),
        ((-1.0, -1.0), (1.0, 1.0)),
    ] {
        let (a, b) = (Point3::new(a.0, a.1, 1.0), Point3::new(b.0, b.1, 1.0));
        let rays = SegmentRays::new(&posed, None, [a, b], down, 1.0);
        for o in points_along(a, b, &mut rng) {
            let tree = farthest_hit(&posed, &Ray::new(o, down, 1.0));
            assert_eq!(rays.farthest_hit(o), tree, "grid, origin {o:?}");
        }
        assert!(
            rays.farthest_hit(a).is_some(),
            "the ray from {a:?} ends on the grid"
        );
    }
}

/// A body's box without a refit is the refit tree's root box to the bit, over the faces the
/// index holds (not the other vertices), and refuses the positions a refit refuses.
#[test]
fn bounding_box_is_the_refit_root_box() {
    let mesh = bumpy_sphere();
    let mut rng = Rng(3);
    // The faces of one side: the other side's vertices, unused, lie beyond their box.
    let half: Vec<u32> = (0..mesh.1.len() as u32)
        .filter(|&f| {
            mesh.1[f as usize]
                .iter()
                .all(|&v| mesh.0[v as usize].x > 0.2)
        })
        .collect();
    for faces in [None, Some(&half)] {
        let index = match faces {
            None => MeshIndex::new(&mesh.0, &mesh.1),
            Some(f) => MeshIndex::with_faces(&mesh.0, &mesh.1, f),
        }
        .expect("index");
        for _ in 0..5 {
            let moved: Vec<Point3<f64>> = mesh
                .0
                .iter()
                .map(|p| p + rng.unit() * 0.1 + Vector3::new(3.0, -1.0, 0.5))
                .collect();
            let root = index.pose(&moved).expect("pose").bvh().root_box();
            assert_eq!(index.bounding_box(&moved).expect("box"), root);
            let all = moved.iter().fold(f64::INFINITY, |m, p| m.min(p.x));
            let lowest = root.expect("faces").min.x;
            assert_eq!(
                faces.is_some(),
                lowest > all + 0.1,
                "{lowest} against {all}"
            );
        }
        let mut bad = mesh.0.clone();
        bad[7].y = f64::NAN;
        assert!(index.bounding_box(&bad).is_err() && index.pose(&bad).is_err());
        assert!(index.bounding_box(&mesh.0[1..]).is_err());
    }
}

// ---------------------------------------------------------------------------------------------
// (e): silhouettes
// ---------------------------------------------------------------------------------------------

#[test]
fn silhouette_of_a_sphere_is_near_the_great_circle() {
    let mut rng = Rng(41);
    let r = 1.3;
    let center = Point3::new(0.2, -0.1, 0.4);
    let mesh = icosphere(4, r, center, &rng.rotation());
    let normals: Vec<Vector3<f64>> = mesh.0.iter().map(|p| (p - center).normalize()).collect();
    let d = rng.unit();
    let sil = Silhouette::compute(&mesh.0, &mesh.1, &normals, &d, FrontSide::NonPositive)
        .expect("silhouette");
    assert_eq!(sil.curves.len(), 1);
    assert!(sil.curves[0].closed);
    assert_eq!(sil.curves[0].segments.len(), sil.segments.len());
    assert_eq!(sil.points.len(), sil.segments.len());
    // With exact sphere normals, g is linear along each edge and vanishes on the plane through
    // the center orthogonal to d: every contour point lies on that plane.
    let sagitta = r - inradius(&mesh, &center);
    for p in &sil.points {
        let x = p.point - center;
        assert!(x.dot(&d).abs() <= 1e-12, "{:e}", x.dot(&d));
        assert!(x.norm() <= r + 1e-12 && x.norm() >= r - sagitta - 1e-12);
    }
    // Front-facing on the left of each oriented segment, seen from outside.
    let front = vertex_front_mask(&normals, &d, FrontSide::NonPositive);
    for s in &sil.segments {
        let t = mesh.1[s.face as usize];
        let [a, b] = s.points.map(|i| sil.points[i as usize].point);
        let n = (mesh.0[t[1] as usize] - mesh.0[t[0] as usize])
            .cross(&(mesh.0[t[2] as usize] - mesh.0[t[0] as usize]));
        for v in t {
            let left = n.cross(&(b - a)).dot(&(mesh.0[v as usize] - a)) > 0.0;
            assert_eq!(left, front[v as usize]);
        }
    }
    let facing = face_facing(&mesh.1, &front);
    let mixed = facing.iter().filter(|&&f| f == Facing::Mixed).count();
    assert_eq!(mixed, sil.segments.len());
    assert!(facing.contains(&Facing::Front) && facing.contains(&Facing::Back));
    // On a face subset (one hemisphere along another axis) the curve is open.
    let axis = d.cross(&rng.unit()).normalize();
    let half: Vec<u32> = (0..mesh.1.len() as u32)
        .filter(|&f| {
            mesh.0[mesh.1[f as usize][0] as usize].coords.dot(&axis) > center.coords.dot(&axis)
        })
        .collect();
    let part = Silhouette::compute_on_faces(
        &mesh.0,
        &mesh.1,
        &normals,
        &d,
        FrontSide::NonPositive,
        &half,
    )
    .expect("subset");
    assert!(!part.curves.is_empty() && part.curves.iter().all(|c| !c.closed));
    // Opposite convention: the same points, segments reversed.
    let flipped = Silhouette::compute(&mesh.0, &mesh.1, &normals, &d, FrontSide::NonNegative)
        .expect("flipped");
    assert_eq!(flipped.points.len(), sil.points.len());
    for (x, y) in flipped.segments.iter().zip(&sil.segments) {
        assert_eq!(x.points, [y.points[1], y.points[0]]);
    }
}

// ---------------------------------------------------------------------------------------------
// (f): self-contact
// ---------------------------------------------------------------------------------------------

/// An open tube along x, folded at x = 0 by a rigid rotation of its x > 0 half about the y axis
/// (a sharp joint); faces labelled 1 (x < 0 at rest) and 2 (x > 0).
fn folded_tube(angle_deg: f64, jitter: f64) -> (Mesh, Vec<u8>) {
    let mut rng = Rng(13);
    let (n_along, n_around, half_len, r) = (24usize, 20usize, 2.0, 0.3);
    let rot = Rotation3::from_axis_angle(&Vector3::y_axis(), angle_deg.to_radians());
    let mut pos = Vec::new();
    for i in 0..=n_along {
        let x = -half_len + 2.0 * half_len * i as f64 / n_along as f64;
        for k in 0..n_around {
            let a = std::f64::consts::TAU * (k as f64 + 0.37) / n_around as f64;
            let p = Point3::new(x, r * a.cos(), r * a.sin());
            let p = if x > 0.0 { rot * p } else { p };
            pos.push(p + rng.unit() * jitter);
        }
    }
    let v = |i: usize, k: usize| (i * n_around + k % n_around) as u32;
    let (mut tris, mut parts) = (Vec::new(), Vec::new());
    for i in 0..n_along {
        let part = if 2 * i < n_along { 1 } else { 2 };
        for k in 0..n_around {
            tris.push([v(i, k), v(i + 1, k + 1), v(i + 1, k)]);
            tris.push([v(i, k), v(i, k + 1), v(i + 1, k + 1)]);
            parts.extend([part, part]);
        }
    }
    ((pos, tris), parts)
}

/// `(side, edge, face)` of a hit.
type HitKey = (Side, [u32; 2], u32);

/// Float segment-triangle crossing margin: the smallest of the barycentric coordinates of the
/// plane crossing and of its parameters `t`, `1 - t` (negative: no crossing), or `None` when
/// the segment is parallel to the plane.
fn crossing_margin(p: &Point3<f64>, q: &Point3<f64>, c: [Point3<f64>; 3]) -> Option<f64> {
    let n = (c[1] - c[0]).cross(&(c[2] - c[0]));
    let (dp, dq) = (n.dot(&(p - c[0])), n.dot(&(q - c[0])));
    if dp == dq {
        return None;
    }
    let t = dp / (dp - dq);
    let x = p + (q - p) * t;
    let w: [f64; 3] = std::array::from_fn(|k| {
        n.dot(&(c[(k + 1) % 3] - x).cross(&(c[(k + 2) % 3] - x))) / n.norm_squared()
    });
    Some(w.iter().copied().fold(t.min(1.0 - t), f64::min))
}

/// Edge-face crossings between the parts, over every non-adjacent cross-part pair, with a
/// float test: `(crossings with margin > tol, crossings with margin > -tol)`.
fn brute_force_self_hits((pos, tris): &Mesh, parts: &[u8], tol: f64) -> (Vec<HitKey>, Vec<HitKey>) {
    let shares = |f: usize, g: usize| tris[f].iter().any(|v| tris[g].contains(v));
    let (mut strict, mut loose) = (Vec::new(), Vec::new());
    for (fa, ta) in tris.iter().enumerate().filter(|(f, _)| parts[*f] == 1) {
        for (fb, tb) in tris.iter().enumerate().filter(|(f, _)| parts[*f] == 2) {
            if shares(fa, fb) {
                continue;
            }
            for (side, t_edge, face, t_face) in [(Side::A, ta, fb, tb), (Side::B, tb, fa, ta)] {
                for k in 0..3 {
                    let (u, v) = (t_edge[k], t_edge[(k + 1) % 3]);
                    let c = t_face.map(|i| pos[i as usize]);
                    let key = (side, [u.min(v), u.max(v)], face as u32);
                    match crossing_margin(&pos[u as usize], &pos[v as usize], c) {
                        Some(m) if m > tol => {
                            strict.push(key);
                            loose.push(key);
                        }
                        Some(m) if m > -tol => loose.push(key),
                        _ => {}
                    }
                }
            }
        }
    }
    for v in [&mut strict, &mut loose] {
        v.sort_unstable();
        v.dedup();
    }
    (strict, loose)
}

/// The self-contact pass indexes its truncated parts per frame from their union's index
/// (`PartsUnion`, built once): the same faces, edges, edges around each vertex and
/// intersections as parts indexed alone, whether the union holds both parts (edges picked
/// from the union's) or not (a part with a face outside it: sorted and built as alone).
#[test]
fn parts_indexed_within_their_union_match_parts_indexed_alone() {
    let ((pos, tris), parts) = folded_tube(150.0, 1e-3);
    let all: Vec<u32> = (0..tris.len() as u32).collect();
    let first: Vec<u32> = all
        .iter()
        .copied()
        .filter(|&f| parts[f as usize] == 1)
        .collect();
    // The parts moved as a crease cut moves them: every fifth face of part 1 goes to part 2.
    let mut moved = parts.clone();
    for f in first.iter().step_by(5) {
        moved[*f as usize] = 2;
    }
    for (union_faces, labels) in [(&all, &parts), (&all, &moved), (&first, &moved)] {
        let union = PartsUnion::new(&pos, &tris, union_faces).expect("union");
        let alone = MeshIndex::self_contact_parts(&pos, &tris, labels).expect("alone");
        let within = MeshIndex::self_contact_parts_within(Some(&union), &pos, &tris, labels)
            .expect("within");
        for (a, w) in alone.iter().zip(&within) {
            assert_eq!(a.faces(), w.faces());
            assert_eq!(a.edges(), w.edges());
            for v in 0..pos.len() as u32 {
                assert_eq!(a.vertex_edges(v), w.vertex_edges(v));
            }
        }
        let hits = |p: &[MeshIndex; 2]| {
            let posed = [p[0].pose(&pos).expect("p0"), p[1].pose(&pos).expect("p1")];
            let ints = Intersections::self_contact(&posed[0], &posed[1]).expect("self contact");
            let keys: Vec<HitKey> = ints.hits.iter().map(|h| (h.side, h.edge, h.face)).collect();
            keys
        };
        let expected = hits(&alone);
        assert!(!expected.is_empty());
        assert_eq!(expected, hits(&within));
    }
}

/// A separated pair's parts never change: indexed once at rest and posed at each frame, they
/// give the intersections of parts indexed at the frame's positions (the self-contact pass
/// builds them once since 2026-12-04).
#[test]
fn parts_indexed_at_rest_and_posed_match_parts_indexed_at_the_frame() {
    let ((rest, tris), parts) = folded_tube(30.0, 1e-3);
    let ((frame, frame_tris), frame_parts) = folded_tube(150.0, 1e-3);
    assert_eq!((&tris, &parts), (&frame_tris, &frame_parts));
    let all: Vec<u32> = (0..tris.len() as u32).collect();
    let union = PartsUnion::new(&rest, &tris, &all).expect("union");
    let at_rest =
        MeshIndex::self_contact_parts_within(Some(&union), &rest, &tris, &parts).expect("at rest");
    let at_frame = MeshIndex::self_contact_parts_within(Some(&union), &frame, &tris, &parts)
        .expect("at the frame");
    let hits = |p: &[MeshIndex; 2], at: &[Point3<f64>]| {
        let posed = [p[0].pose(at).expect("p0"), p[1].pose(at).expect("p1")];
        let ints = Intersections::self_contact(&posed[0], &posed[1]).expect("self contact");
        let keys: Vec<HitKey> = ints.hits.iter().map(|h| (h.side, h.edge, h.face)).collect();
        keys
    };
    let expected = hits(&at_frame, &frame);
    assert!(!expected.is_empty());
    assert_eq!(hits(&at_rest, &frame), expected);
    assert!(hits(&at_rest, &rest).is_empty());
}

#[test]
fn self_contact_of_a_folded_tube_skips_adjacent_faces() {
    // Generic position (vertices jittered): the exact result equals a brute-force float scan.
    let ((pos, tris), parts) = folded_tube(150.0, 1e-3);
    let [i1, i2] = MeshIndex::self_contact_parts(&pos, &tris, &parts).expect("parts");
    let (p1, p2) = (i1.pose(&pos).expect("p1"), i2.pose(&pos).expect("p2"));
    let ints = Intersections::self_contact(&p1, &p2).expect("self contact");
    assert!(ints.hits.len() > 20);
    assert!(ints.stats.adjacent_pairs_skipped > 0);
    assert_eq!(ints.stats.anomalous_pairs, 0);
    let mesh = (pos.clone(), tris.clone());
    check_all_hits(&ints, &mesh, &mesh, 1e-12);
    let shares = |f: u32, g: u32| {
        tris[f as usize]
            .iter()
            .any(|v| tris[g as usize].contains(v))
    };
    for s in &ints.segments {
        assert_eq!(parts[s.faces[0] as usize], 1);
        assert_eq!(parts[s.faces[1] as usize], 2);
        assert!(!shares(s.faces[0], s.faces[1]));
    }
    let (strict, loose) = brute_force_self_hits(&mesh, &parts, 1e-9);
    let got: Vec<HitKey> = ints.hits.iter().map(|h| (h.side, h.edge, h.face)).collect();
    assert_eq!(strict, loose, "generic position");
    assert_eq!(got, strict);
    // Curves are open where adjacent pairs were skipped; every hit is used once or twice.
    let mut uses = vec![0; ints.hits.len()];
    for s in &ints.segments {
        uses[s.hits[0] as usize] += 1;
        uses[s.hits[1] as usize] += 1;
    }
    assert!(uses.iter().all(|&u| u == 1 || u == 2));
    let ends = uses.iter().filter(|&&u| u == 1).count();
    assert_eq!(ends, 2 * ints.curves.iter().filter(|c| !c.closed).count());
    let region = IntersectionRegion::inside(&ints, Side::A, &p1).expect("region");
    assert!(region.area(&p1) > 0.0 && region.area(&p1).is_finite());
}

#[test]
fn self_contact_of_a_symmetric_fold_resolves_ties_consistently() {
    // Without jitter the fold is a mirror image: many exact ties (edges through edges).
    let ((pos, tris), parts) = folded_tube(150.0, 0.0);
    let ints = contact_skin::intersect::intersect_parts(&pos, &tris, &parts).expect("parts");
    assert_eq!(ints.stats.anomalous_pairs, 0);
    let mesh = (pos, tris);
    check_all_hits(&ints, &mesh, &mesh, 1e-12);
    // Every hit found is a loose brute-force crossing, and every strict one is found.
    let (strict, loose) = brute_force_self_hits(&mesh, &parts, 1e-9);
    let got: Vec<HitKey> = ints.hits.iter().map(|h| (h.side, h.edge, h.face)).collect();
    assert!(got.iter().all(|k| loose.binary_search(k).is_ok()));
    assert!(strict.iter().all(|k| got.binary_search(k).is_ok()));
    assert!(strict.len() < loose.len(), "the configuration has ties");
}

#[test]
fn self_contact_of_two_disjoint_parts_equals_the_two_body_query() {
    let mut rng = Rng(51);
    let a = icosphere(2, 1.0, Point3::origin(), &rng.rotation());
    let b = icosphere(2, 0.8, Point3::new(0.3, 0.9, 0.4), &rng.rotation());
    let (pos, tris) = concat(&a, &b);
    let parts: Vec<u8> = (0..tris.len())
        .map(|f| if f < a.1.len() { 1 } else { 2 })
        .collect();
    let selfc = contact_skin::intersect::intersect_parts(&pos, &tris, &parts).expect("parts");
    let two = intersections(&a, &b);
    assert_eq!(selfc.hits.len(), two.hits.len());
    assert_eq!(selfc.segments.len(), two.segments.len());
    let (off_v, off_f) = (a.0.len() as u32, a.1.len() as u32);
    for (x, y) in selfc.hits.iter().zip(&two.hits) {
        let (ev, fv) = match y.side {
            Side::A => (0, off_f),
            Side::B => (off_v, 0),
        };
        assert_eq!(x.edge, y.edge.map(|v| v + ev));
        assert_eq!(x.face, y.face + fv);
        assert_eq!(
            (x.t, x.point, x.bary, x.entering),
            (y.t, y.point, y.bary, y.entering)
        );
    }
    check_closed_curves(&selfc);
}

// ---------------------------------------------------------------------------------------------
// (g): degenerate inputs
// ---------------------------------------------------------------------------------------------

fn assert_finite(ints: &Intersections) {
    for h in &ints.hits {
        assert!(h.t.is_finite() && h.point.iter().all(|x| x.is_finite()));
        assert!(h.bary.iter().all(|x| x.is_finite()));
    }
}

#[test]
fn empty_meshes_give_empty_results() {
    let sphere = icosphere(1, 1.0, Point3::origin(), &Rotation3::identity());
    let empty: Mesh = (Vec::new(), Vec::new());
    let ints = intersections(&sphere, &empty);
    assert!(ints.is_empty() && ints.curves.is_empty());
    let ints = intersections(&empty, &empty);
    assert!(ints.is_empty());
    let index = MeshIndex::new(&empty.0, &empty.1).expect("empty");
    let posed = index.pose(&empty.0).expect("pose");
    let region = IntersectionRegion::inside(&ints, Side::A, &posed).expect("region");
    assert!(region.is_empty() && region.area(&posed) == 0.0);
    assert_eq!(
        farthest_hit(&posed, &Ray::new(Point3::origin(), Vector3::x(), 1.0)),
        None
    );
    let sil = Silhouette::compute(
        &empty.0,
        &empty.1,
        &[],
        &Vector3::x(),
        FrontSide::NonPositive,
    )
    .expect("empty");
    assert!(sil.points.is_empty() && sil.curves.is_empty());
}

#[test]
fn zero_area_and_duplicated_faces_do_not_break_anything() {
    let mut rng = Rng(61);
    let (mut pos, mut tris) = icosphere(2, 1.0, Point3::origin(), &rng.rotation());
    let other = icosphere(2, 0.7, Point3::new(0.2, 0.3, 0.8), &rng.rotation());
    // A collinear face (corner at an edge midpoint), a repeated-index face, duplicated faces.
    let [u, v, _] = tris[0];
    pos.push(nalgebra::center(&pos[u as usize], &pos[v as usize]));
    let mid = pos.len() as u32 - 1;
    tris.push([u, v, mid]);
    tris.push([u, u, v]);
    let dup: Vec<[u32; 3]> = tris[..40].to_vec();
    tris.extend(dup);
    let mesh = (pos, tris);
    let ints = intersections(&mesh, &other);
    assert_finite(&ints);
    assert_eq!(ints.stats.index_degenerate_faces, 1);
    assert!(!ints.hits.is_empty());
    // A collinear face crossing the other sphere: never crossed, its edges are.
    let flat: Mesh = (
        vec![
            Point3::new(-2.0, 0.1, 0.2),
            Point3::new(0.0, 0.1, 0.2),
            Point3::new(2.0, 0.1, 0.2),
        ],
        vec![[0, 1, 2]],
    );
    let ints_flat = intersections(&flat, &other);
    assert_finite(&ints_flat);
    assert!(ints_flat.stats.degenerate_pairs > 0);
    assert!(ints_flat.hits.iter().all(|h| h.side == Side::A));
    let ia = MeshIndex::new(&mesh.0, &mesh.1).expect("mesh");
    let posed = ia.pose(&mesh.0).expect("pose");
    let region = IntersectionRegion::inside(&ints, Side::A, &posed).expect("region");
    assert!(region.area(&posed).is_finite());
    // Both meshes fully duplicated: every hit is found twice (once per copy of the face).
    let doubled = |m: &Mesh| (m.0.clone(), [m.1.clone(), m.1.clone()].concat());
    let a = icosphere(2, 1.0, Point3::origin(), &rng.rotation());
    let single = intersections(&a, &other);
    let twice = intersections(&doubled(&a), &other);
    assert_finite(&twice);
    assert_eq!(
        twice.hits.len(),
        single.hits.len() + single.hits.iter().filter(|h| h.side == Side::B).count()
    );
}

#[test]
fn coplanar_triangles_never_intersect() {
    let a: Mesh = (
        vec![
            Point3::new(0.0, 0.0, 0.5),
            Point3::new(1.0, 0.0, 0.5),
            Point3::new(0.0, 1.0, 0.5),
        ],
        vec![[0, 1, 2]],
    );
    let b: Mesh = (
        vec![
            Point3::new(0.2, 0.2, 0.5),
            Point3::new(1.2, 0.2, 0.5),
            Point3::new(0.2, 1.2, 0.5),
        ],
        vec![[0, 1, 2]],
    );
    let ints = intersections(&a, &b);
    assert!(ints.is_empty());
    assert_eq!(ints.stats.coplanar_pairs, 1);
    // Overlapping coplanar grids, one of them flipped.
    let g1 = flat_grid(0.25, 1.0, 6);
    let mut g2 = flat_grid(0.25, 0.8, 5);
    for t in &mut g2.1 {
        t.swap(1, 2);
    }
    let ints = intersections(&g1, &g2);
    assert!(ints.is_empty() && ints.stats.coplanar_pairs > 0);
}

/// A plane exactly through a ring of vertices (z = 0 on the equator of a UV sphere): every
/// crossing is an exact tie resolved by the perturbation. The curve still closes and the region
/// matches the exact half-space clip.
#[test]
fn plane_through_a_ring_of_vertices() {
    let polar: Vec<f64> = (1..16)
        .map(|j| std::f64::consts::PI * j as f64 / 16.0)
        .collect();
    let mut sphere = uv_sphere(1.0, Point3::origin(), &polar, 24, None);
    for p in &mut sphere.0 {
        if p.z.abs() < 1e-12 {
            p.z = 0.0;
        }
    }
    let plane = flat_grid(0.0, 1.5, 7);
    let ia = MeshIndex::new(&sphere.0, &sphere.1).expect("sphere");
    let ib = MeshIndex::new(&plane.0, &plane.1).expect("plane");
    let (a, b) = (
        ia.pose(&sphere.0).expect("a"),
        ib.pose(&plane.0).expect("b"),
    );
    let ints = Intersections::between(&a, &b).expect("in contact");
    assert!(ints.stats.symbolic_ties > 0);
    assert_finite(&ints);
    check_closed_curves(&ints);
    check_all_hits(&ints, &sphere, &plane, 1e-12);
    let inside = IntersectionRegion::inside(&ints, Side::A, &a).expect("region");
    let m = Vector3::z();
    let clip: f64 = sphere
        .1
        .iter()
        .map(|t| {
            polygon_integral(
                &clip_below(&t.map(|v| sphere.0[v as usize]), &m, 0.0),
                &|_| 1.0,
            )
        })
        .sum();
    assert!(
        (inside.area(&a) - clip).abs() <= 1e-12,
        "{} vs {clip}",
        inside.area(&a)
    );
    let total = total_area(&sphere);
    let outside = IntersectionRegion::outside(&ints, Side::A, &a).expect("region");
    assert!((inside.area(&a) + outside.area(&a) - total).abs() <= 1e-12);
}

#[test]
fn invalid_inputs_are_typed_errors() {
    let (mut pos, tris) = icosphere(1, 1.0, Point3::origin(), &Rotation3::identity());
    assert!(matches!(
        MeshIndex::new(&pos, &[[0, 1, 999]]),
        Err(IntersectError::VertexOutOfRange { vertex: 999, .. })
    ));
    let index = MeshIndex::new(&pos, &tris).expect("index");
    assert!(matches!(
        index.pose(&pos[1..]),
        Err(IntersectError::PositionCount { .. })
    ));
    pos[3].y = f64::NAN;
    assert_eq!(
        index.pose(&pos).err(),
        Some(IntersectError::NonFinitePosition(3))
    );
    assert!(matches!(
        MeshIndex::self_contact_parts(&pos[..0], &tris, &[1]),
        Err(IntersectError::PartCount { .. })
    ));
}

// ---------------------------------------------------------------------------------------------
// (h): determinism
// ---------------------------------------------------------------------------------------------

fn posed<'a>(index: &'a MeshIndex, m: &'a Mesh, rebuild: bool) -> PosedMesh<'a> {
    if rebuild {
        index.pose_rebuilt(&m.0).expect("pose")
    } else {
        index.pose(&m.0).expect("pose")
    }
}

type Everything = (
    Intersections,
    IntersectionRegion,
    IntersectionRegion,
    Vec<Option<RayHit>>,
    Silhouette,
);

fn everything(a: &Mesh, b: &Mesh, rays: &[Ray], rebuild: bool) -> Everything {
    let ia = MeshIndex::new(&a.0, &a.1).expect("a");
    let ib = MeshIndex::new(&b.0, &b.1).expect("b");
    let (pa, pb) = (posed(&ia, a, rebuild), posed(&ib, b, rebuild));
    let ints = Intersections::between(&pa, &pb).expect("in contact");
    let ra = IntersectionRegion::inside(&ints, Side::A, &pa).expect("region");
    let rb = IntersectionRegion::inside(&ints, Side::B, &pb).expect("region");
    let hits = farthest_hits(&pb, rays);
    let normals: Vec<Vector3<f64>> = a.0.iter().map(|p| p.coords.normalize()).collect();
    let sil = Silhouette::compute(
        &a.0,
        &a.1,
        &normals,
        &Vector3::new(0.3, -0.2, 0.9),
        FrontSide::NonPositive,
    )
    .expect("silhouette");
    (ints, ra, rb, hits, sil)
}

#[test]
fn results_are_identical_across_runs_and_thread_counts() {
    let mut rng = Rng(71);
    // Rest pose, then a deformed frame: the refitted and the rebuilt BVH must agree too.
    let rest = icosphere(4, 1.0, Point3::origin(), &rng.rotation());
    let b = icosphere(4, 0.7, Point3::new(0.1, 0.2, 0.95), &rng.rotation());
    let mut frame = rest.clone();
    for p in &mut frame.0 {
        p.z += 0.15 * (2.0 * p.x).sin();
    }
    let rays: Vec<Ray> = (0..500)
        .map(|_| {
            Ray::new(
                Point3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 2.5),
                -Vector3::z(),
                5.0,
            )
        })
        .collect();
    let run = |threads: usize, rebuild: bool| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool")
            .install(|| {
                let ia = MeshIndex::new(&rest.0, &rest.1).expect("index");
                let ib = MeshIndex::new(&b.0, &b.1).expect("index");
                let (pa, pb) = if rebuild {
                    (
                        ia.pose_rebuilt(&frame.0).expect("a"),
                        ib.pose_rebuilt(&b.0).expect("b"),
                    )
                } else {
                    (ia.pose(&frame.0).expect("a"), ib.pose(&b.0).expect("b"))
                };
                let ints = Intersections::between(&pa, &pb).expect("in contact");
                let ra = IntersectionRegion::inside(&ints, Side::A, &pa).expect("region");
                (
                    ints,
                    ra,
                    farthest_hits(&pa, &rays),
                    everything(&frame, &b, &rays, rebuild),
                )
            })
    };
    let reference = run(1, false);
    assert!(!reference.0.is_empty());
    assert_eq!(reference, run(2, false));
    assert_eq!(reference, run(2, false));
    assert_eq!(reference, run(2, true));
    assert_eq!(reference, run(1, true));
}

/// A tetrahedron poking through a two-triangle square (the module example): the square's region
/// inside the tetrahedron is exactly the cross-section triangle, split by the square's diagonal.
#[test]
fn tetrahedron_through_a_square() {
    let square: Mesh = (
        [(-2., -2.), (2., -2.), (2., 2.), (-2., 2.)]
            .map(|(x, y)| Point3::new(x, y, 0.0))
            .to_vec(),
        vec![[0, 1, 2], [0, 2, 3]],
    );
    let apex = Point3::new(0.3, 0.25, 0.5);
    let base = [(-0.5, -0.5), (1.0, -0.2), (0.0, 1.0)].map(|(x, y)| Point3::new(x, y, -1.0));
    let tet: Mesh = (
        vec![base[0], base[1], base[2], apex],
        vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]],
    );
    assert!(signed_volume(&tet) > 0.0);
    let ia = MeshIndex::new(&square.0, &square.1).expect("square");
    let ib = MeshIndex::new(&tet.0, &tet.1).expect("tet");
    let (a, b) = (ia.pose(&square.0).expect("a"), ib.pose(&tet.0).expect("b"));
    let ints = Intersections::between(&a, &b).expect("in contact");
    check_all_hits(&ints, &square, &tet, 1e-14);
    check_closed_curves(&ints);
    assert!(
        ints.hits.iter().any(|h| h.side == Side::A),
        "the diagonal is cut"
    );
    let section = IntersectionRegion::inside(&ints, Side::A, &a).expect("region");
    assert_eq!(section.stats, Default::default());
    let p = base.map(|q| q + (apex - q) * (2.0 / 3.0));
    let expected = 0.5 * (p[1] - p[0]).cross(&(p[2] - p[0])).norm();
    assert!(
        (section.area(&a) - expected).abs() <= 1e-14,
        "{} vs {expected}",
        section.area(&a)
    );
    assert_eq!(section.cut_faces.len(), 2);
    // The tetrahedron below the square: the base and the lower parts of the sides.
    let below = IntersectionRegion::inside(&ints, Side::B, &b).expect("region");
    let above = IntersectionRegion::outside(&ints, Side::B, &b).expect("region");
    let total = total_area(&tet);
    assert!((below.area(&b) + above.area(&b) - total).abs() <= 1e-14 * total);
    // Above: the small tetrahedron similar with ratio 1/3, without its base.
    let top = (total - 0.5 * (base[1] - base[0]).cross(&(base[2] - base[0])).norm()) / 9.0;
    assert!(
        (above.area(&b) - top).abs() <= 1e-14,
        "{} vs {top}",
        above.area(&b)
    );
    assert_eq!(below.whole_faces, vec![0]);
}

/// A box with a pyramidal dent in its top whose tip pierces a square lying inside the box: the
/// square is inside the box except for a small square hole (the dent's cross-section), a curve
/// loop entirely inside one face. No edge of the square is cut, so the corners' status comes
/// from the loop's orientation (clockwise: a hole).
#[test]
fn hole_in_a_face_from_a_dent() {
    let (c, h) = (Point3::new(0.8, -0.5, 0.0), 0.3);
    let mut pos: Vec<Point3<f64>> = Vec::new();
    for z in [-1.0, 1.0] {
        pos.extend([(-3., -3.), (3., -3.), (3., 3.), (-3., 3.)].map(|(x, y)| Point3::new(x, y, z)));
    }
    pos.extend(
        [(-h, -h), (h, -h), (h, h), (-h, h)].map(|(x, y)| Point3::new(c.x + x, c.y + y, 1.0)),
    );
    pos.push(Point3::new(c.x, c.y, -0.5));
    let mut tris = vec![[0, 2, 1], [0, 3, 2]];
    for k in 0..4u32 {
        let k1 = (k + 1) % 4;
        tris.extend([[k, k1, 4 + k1], [k, 4 + k1, 4 + k]]);
        tris.extend([[4 + k, 4 + k1, 8 + k1], [4 + k, 8 + k1, 8 + k]]);
        tris.push([8 + k, 8 + k1, 12]);
    }
    let dented: Mesh = (pos, tris);
    assert!(signed_volume(&dented) > 0.0);
    let square: Mesh = (
        [(-2., -2.), (2., -2.), (2., 2.), (-2., 2.)]
            .map(|(x, y)| Point3::new(x, y, 0.0))
            .to_vec(),
        vec![[0, 1, 2], [0, 2, 3]],
    );
    let ia = MeshIndex::new(&square.0, &square.1).expect("square");
    let ib = MeshIndex::new(&dented.0, &dented.1).expect("box");
    let (a, b) = (
        ia.pose(&square.0).expect("a"),
        ib.pose(&dented.0).expect("b"),
    );
    let ints = Intersections::between(&a, &b).expect("in contact");
    check_closed_curves(&ints);
    assert!(ints.hits.iter().all(|h| h.side == Side::B));
    let region = IntersectionRegion::inside(&ints, Side::A, &a).expect("region");
    assert_eq!(region.stats, Default::default());
    assert!(region.inside.iter().all(|&x| x));
    assert_eq!(region.whole_faces, vec![1]);
    assert_eq!(region.cut_faces.len(), 1);
    assert!(!region.cut_faces[0].holes.is_empty());
    let hole = (2.0 * h / 3.0).powi(2);
    assert!(
        (region.area(&a) - (16.0 - hole)).abs() <= 1e-13,
        "{}",
        region.area(&a)
    );
    let outside = IntersectionRegion::outside(&ints, Side::A, &a).expect("region");
    assert!(
        (outside.area(&a) - hole).abs() <= 1e-14,
        "{}",
        outside.area(&a)
    );
    // Integral of a linear field over the holed region.
    let values: Vec<Vector3<f64>> = square
        .0
        .iter()
        .map(|p| Vector3::new(p.x, p.y, 1.0))
        .collect();
    let m = region.integrate_linear(&a, &values).expect("integral");
    let expected = Vector3::new(-hole * c.x, -hole * c.y, 16.0 - hole);
    assert!((m - expected).norm() <= 1e-13, "{m:?} vs {expected:?}");
}

/// A coarse surface against a fine one is a contact, not an entanglement: an 8-sided tube
/// 6 long (16 triangles), tilted along the diagonal through a 20480-face unit sphere, has
/// long faces whose boxes each hold the whole sphere (more candidate pairs than 8 per face of
/// both surfaces, the plain budget), and the bounded query scales its budget by the ratio of
/// the two surfaces' face counts.
#[test]
fn bounded_queries_allow_coarse_against_fine() {
    let sphere = meshes::icosphere(5);
    let axis = Vector3::new(1.0, 1.0, 1.0).normalize();
    let [u, v] = contact_skin::contact::mapping::orthonormal_basis(&axis);
    let mut tube = Vec::new();
    for k in 0..8 {
        let a = k as f64 * std::f64::consts::TAU / 8.0;
        let ring = (u * a.cos() + v * a.sin()) * 0.3;
        tube.push(Point3::from(ring - axis * 3.0));
        tube.push(Point3::from(ring + axis * 3.0));
    }
    let tube_triangles: Vec<[u32; 3]> = (0..8u32)
        .flat_map(|k| {
            let (a, b) = (2 * k, 2 * ((k + 1) % 8));
            [[a, b, b + 1], [a, b + 1, a + 1]]
        })
        .collect();
    let ints = contact_skin::intersect::intersect_meshes(
        &sphere.positions,
        &sphere.triangles,
        &tube,
        &tube_triangles,
    )
    .expect("a contact, not an entanglement");
    let faces = sphere.triangles.len() + tube_triangles.len();
    assert!(
        ints.stats.candidate_pairs > 8 * faces,
        "{} candidates for {faces} faces",
        ints.stats.candidate_pairs
    );
    assert_eq!(
        ints.curves.len(),
        2,
        "the tube enters and leaves the sphere"
    );
    assert!(ints.curves.iter().all(|c| c.closed));
}
