//! The heat method with a source curve on edges (2021 Sec. 5.1) and harmonic diffusion on cut
//! meshes: accuracy against exact geodesic distances, exactness on linear data, agreement with
//! an independent dense solve, continuity as the source slides, degenerate input.

#[path = "common/meshes.rs"]
mod meshes;

use contact_skin::heat::{band_faces, Boundary, HeatParams, RegionSolver};
use contact_skin::mesh::operators::mean_edge_length;
use contact_skin::mesh::Region;
use meshes::{grid, icosphere, TestMesh};
use nalgebra::{DMatrix, DVector, Point3, Vector3};

fn solver(mesh: &TestMesh) -> (RegionSolver, Vec<Point3<f64>>) {
    let region = Region::whole(&mesh.triangles);
    let positions = region.gather(&mesh.positions);
    (RegionSolver::new(region).expect("symbolic"), positions)
}

/// Mean of |φ - exact| / exact over vertices farther than `2h` from the source (the relative
/// error is 0/0 on the source itself).
fn mean_relative_error(phi: &[f64], exact: &[f64], h: f64) -> f64 {
    let (mut sum, mut n) = (0.0, 0);
    for (p, e) in phi.iter().zip(exact) {
        if *e > 2.0 * h {
            assert!(p.is_finite());
            sum += (p - e).abs() / e;
            n += 1;
        }
    }
    sum / n as f64
}

fn distance(
    mesh: &TestMesh,
    boundary_of: impl Fn(&Region, &[Point3<f64>]) -> Boundary,
) -> (Vec<f64>, Vec<Point3<f64>>, f64) {
    let (s, pos) = solver(mesh);
    let boundary = boundary_of(&s.region, &pos);
    let mut problem = s.problem(&pos, &boundary).expect("cut");
    let phi = problem.distance(HeatParams::default()).expect("solve");
    (phi, pos, mean_edge_length(&mesh.positions, &mesh.triangles))
}

fn check_refinement(name: &str, errors: &[f64]) {
    println!("{name}: mean relative errors {errors:?}");
    assert!(
        *errors.last().expect("levels") < 0.03,
        "{name}: finest error above 3 %"
    );
    for w in errors.windows(2) {
        assert!(
            w[1] < w[0],
            "{name}: error does not decrease under refinement"
        );
    }
}

#[test]
fn plane_point_source() {
    let errors: Vec<f64> = [20, 40, 80]
        .iter()
        .map(|&n| {
            let mesh = grid(n);
            let (phi, pos, h) = distance(&mesh, |r, p| {
                let c = (0..r.vertex_count())
                    .min_by(|&a, &b| p[a].coords.norm().total_cmp(&p[b].coords.norm()))
                    .expect("vertex");
                Boundary::vertices(r.vertex_count(), vec![c as u32])
            });
            let exact: Vec<f64> = pos.iter().map(|p| p.coords.norm()).collect();
            mean_relative_error(&phi, &exact, h)
        })
        .collect();
    check_refinement("plane, point source", &errors);
}

#[test]
fn plane_circle_source() {
    let r0 = 0.3;
    let errors: Vec<f64> = [20, 40, 80]
        .iter()
        .map(|&n| {
            let mesh = grid(n);
            let (phi, pos, h) = distance(&mesh, |r, p| {
                let f: Vec<f64> = p.iter().map(|q| q.coords.norm() - r0).collect();
                Boundary::from_level_set(r, &f)
            });
            let exact: Vec<f64> = pos
                .iter()
                .map(|p| (p.coords.norm() - r0).max(0.0))
                .collect();
            mean_relative_error(&phi, &exact, h)
        })
        .collect();
    check_refinement("plane, circle source", &errors);
}

#[test]
fn sphere_point_source() {
    let errors: Vec<f64> = [3, 4, 5]
        .iter()
        .map(|&levels| {
            let mesh = icosphere(levels);
            let (phi, pos, h) =
                distance(&mesh, |r, _| Boundary::vertices(r.vertex_count(), vec![0]));
            let exact: Vec<f64> = pos
                .iter()
                .map(|p| p.coords.dot(&pos[0].coords).clamp(-1.0, 1.0).acos())
                .collect();
            mean_relative_error(&phi, &exact, h)
        })
        .collect();
    check_refinement("sphere, point source", &errors);
}

#[test]
fn sphere_circle_source() {
    let z0: f64 = 0.5;
    let theta0 = z0.acos();
    let errors: Vec<f64> = [3, 4, 5]
        .iter()
        .map(|&levels| {
            let mesh = icosphere(levels);
            let (phi, pos, h) = distance(&mesh, |r, p| {
                let f: Vec<f64> = p.iter().map(|q| z0 - q.z).collect();
                Boundary::from_level_set(r, &f)
            });
            let exact: Vec<f64> = pos
                .iter()
                .map(|p| (p.z.clamp(-1.0, 1.0).acos() - theta0).max(0.0))
                .collect();
            mean_relative_error(&phi, &exact, h)
        })
        .collect();
    check_refinement("sphere, circle source", &errors);
}

/// Dirichlet data: a circle cut inside the grid plus every vertex of the outer border.
fn annulus(n: usize) -> (RegionSolver, Vec<Point3<f64>>, Boundary) {
    let mesh = grid(n);
    let (s, pos) = solver(&mesh);
    let f: Vec<f64> = pos.iter().map(|q| q.coords.norm() - 0.37).collect();
    let mut boundary = Boundary::from_level_set(&s.region, &f);
    boundary.vertices = (0..pos.len() as u32)
        .filter(|&v| s.region.border[v as usize])
        .collect();
    (s, pos, boundary)
}

fn dirichlet_nodes(
    problem_nodes: &[Point3<f64>],
    s: &RegionSolver,
    b: &Boundary,
) -> Vec<Point3<f64>> {
    let n = s.region.vertex_count();
    let mut out: Vec<Point3<f64>> = (0..b.points.len()).map(|k| problem_nodes[n + k]).collect();
    out.extend(b.vertices.iter().map(|&v| problem_nodes[v as usize]));
    out
}

#[test]
fn harmonic_reproduces_linear_functions_exactly() {
    let (s, pos, boundary) = annulus(24);
    let mut problem = s.problem(&pos, &boundary).expect("cut");
    let nodes = dirichlet_nodes(&problem.cut.nodes, &s, &boundary);
    let lin = |p: &Point3<f64>| 0.7 * p.x - 1.3 * p.y + 0.25;
    let values: Vec<f64> = nodes.iter().map(lin).collect();
    let x = problem.harmonic(&values).expect("solve");
    let mut worst: f64 = 0.0;
    for v in 0..pos.len() {
        if !boundary.inside[v] {
            worst = worst.max((x[v] - lin(&pos[v])).abs());
        }
    }
    assert!(worst < 1e-9, "linear function not reproduced: {worst:e}");
    let vec_values: Vec<Vector3<f64>> = nodes
        .iter()
        .map(|p| Vector3::new(lin(p), 2.0 * p.x, -p.y))
        .collect();
    let xv = problem.harmonic_vector(&vec_values).expect("solve");
    for v in 0..pos.len() {
        if !boundary.inside[v] {
            let expect = Vector3::new(lin(&pos[v]), 2.0 * pos[v].x, -pos[v].y);
            assert!((xv[v] - expect).norm() < 1e-9);
        }
    }
    // Dirichlet vertices hold their values.
    for (j, &v) in boundary.vertices.iter().enumerate() {
        assert!((x[v as usize] - values[boundary.points.len() + j]).abs() < 1e-10);
    }
}

/// Dense P1 assembly from the cut mesh's node positions and triangles, with its own cotangent
/// formula, solved by LU with the Dirichlet nodes eliminated.
fn dense_harmonic(
    nodes: &[Point3<f64>],
    tris: &[[u32; 3]],
    fixed: &[(usize, f64)],
    n_vertices: usize,
) -> Vec<f64> {
    let m = nodes.len();
    let mut k = DMatrix::<f64>::zeros(m, m);
    for t in tris {
        for c in 0..3 {
            let (i, j, o) = (
                t[c] as usize,
                t[(c + 1) % 3] as usize,
                t[(c + 2) % 3] as usize,
            );
            let (a, b) = (nodes[i] - nodes[o], nodes[j] - nodes[o]);
            let cot = a.dot(&b) / a.cross(&b).norm();
            k[(i, j)] -= 0.5 * cot;
            k[(j, i)] -= 0.5 * cot;
            k[(i, i)] += 0.5 * cot;
            k[(j, j)] += 0.5 * cot;
        }
    }
    let mut rhs = DVector::<f64>::zeros(m);
    for &(node, value) in fixed {
        for r in 0..m {
            k[(node, r)] = 0.0;
        }
        k[(node, node)] = 1.0;
        rhs[node] = value;
    }
    // Nodes in no triangle (inside vertices) are pinned to 0.
    for r in 0..m {
        if k.row(r).iter().all(|&x| x == 0.0) {
            k[(r, r)] = 1.0;
        }
    }
    let x = k.lu().solve(&rhs).expect("dense solve");
    x.iter().take(n_vertices).copied().collect()
}

#[test]
fn cut_solves_match_a_dense_solve_and_hold_their_boundary() {
    let (s, pos, boundary) = annulus(8);
    let mut problem = s.problem(&pos, &boundary).expect("cut");
    let n = pos.len();
    let nodes = problem.cut.nodes.clone();
    let values: Vec<f64> = (0..boundary.dirichlet_count())
        .map(|k| ((k * 7919) % 13) as f64 / 13.0 - 0.4)
        .collect();
    let mut fixed: Vec<(usize, f64)> = (0..boundary.points.len())
        .map(|k| (n + k, values[k]))
        .collect();
    fixed.extend(
        boundary
            .vertices
            .iter()
            .enumerate()
            .map(|(j, &v)| (v as usize, values[boundary.points.len() + j])),
    );
    let dense = dense_harmonic(&nodes, &problem.cut.triangles, &fixed, n);
    let sparse = problem.harmonic(&values).expect("solve");
    for v in 0..n {
        if !boundary.inside[v] {
            assert!(
                (dense[v] - sparse[v]).abs() < 1e-10,
                "vertex {v}: dense {} sparse {}",
                dense[v],
                sparse[v]
            );
        }
    }
    for &(node, value) in &fixed {
        if node < n {
            assert!((sparse[node] - value).abs() < 1e-10);
        }
    }
}

#[test]
fn distance_moves_continuously_as_the_source_slides_across_vertices() {
    let mesh = grid(30);
    let (s, pos) = solver(&mesh);
    let probes: Vec<usize> = (0..pos.len())
        .filter(|&v| (pos[v].coords.norm() - 0.8).abs() < 0.05)
        .collect();
    let steps = 80;
    let (r_start, r_end) = (0.25, 0.35);
    let mut previous: Option<Vec<f64>> = None;
    let mut crossings = 0;
    let mut previous_inside: Option<Vec<bool>> = None;
    let dr = (r_end - r_start) / steps as f64;
    let mut worst: f64 = 0.0;
    for k in 0..=steps {
        let r0 = r_start + dr * k as f64;
        let f: Vec<f64> = pos.iter().map(|q| q.coords.norm() - r0).collect();
        let boundary = Boundary::from_level_set(&s.region, &f);
        if let Some(pi) = &previous_inside {
            crossings += pi
                .iter()
                .zip(&boundary.inside)
                .filter(|(a, b)| a != b)
                .count();
        }
        let phi = s
            .problem(&pos, &boundary)
            .expect("cut")
            .distance(HeatParams::default())
            .expect("solve");
        let sample: Vec<f64> = probes.iter().map(|&v| phi[v]).collect();
        if let Some(prev) = &previous {
            for (a, b) in prev.iter().zip(&sample) {
                // In the continuum every probe gets closer by exactly dr.
                worst = worst.max(((b - a) + dr).abs() / dr);
            }
        }
        previous = Some(sample);
        previous_inside = Some(boundary.inside);
    }
    println!("sweep: {crossings} vertex crossings, worst |Δφ + Δr| / Δr = {worst:.3}");
    assert!(crossings > 20, "the sweep must cross vertices");
    assert!(
        worst < 0.5,
        "the distance pops as the source crosses vertices: {worst}"
    );
}

/// Distance on a band of radius `factor · φ_max + 3h` against the whole region, inside `φ_max`.
fn band_difference(factor: f64) -> (f64, f64, usize, usize) {
    let mesh = grid(60);
    let (s, pos) = solver(&mesh);
    let f: Vec<f64> = pos.iter().map(|q| q.coords.norm() - 0.3).collect();
    let boundary = Boundary::from_level_set(&s.region, &f);
    let full = s
        .problem(&pos, &boundary)
        .expect("cut")
        .distance(HeatParams::default())
        .expect("solve");
    let h = mean_edge_length(&pos, &s.region.triangles);
    let phi_max = 0.2;
    let faces = band_faces(&s.region, &pos, &boundary, factor * phi_max + 3.0 * h);
    let band = Region::from_faces(&s.region.triangles, faces);
    let band_pos = band.gather(&pos);
    let band_boundary = Boundary::from_level_set(&band, &band.gather(&f));
    let bs = RegionSolver::new(band).expect("symbolic");
    let phi = bs
        .problem(&band_pos, &band_boundary)
        .expect("cut")
        .distance(HeatParams::default())
        .expect("solve");
    let mut worst: f64 = 0.0;
    for (local, &v) in bs.region.vertices.iter().enumerate() {
        if full[v as usize] < phi_max {
            worst = worst.max((phi[local] - full[v as usize]).abs());
        }
    }
    (
        worst / h,
        worst / phi_max,
        bs.region.vertex_count(),
        pos.len(),
    )
}

#[test]
fn band_solve_matches_the_whole_region_inside_the_extent() {
    // The margin of PIPELINE.md (1.5 φ_max + 3h) and wider ones: the Neumann rim of the band
    // perturbs the heat and Poisson solutions; measure by how much.
    let mut previous = f64::INFINITY;
    for factor in [1.5, 2.0, 3.0] {
        let (in_h, rel, band, all) = band_difference(factor);
        println!("band {factor} φ_max + 3h: {band} of {all} vertices, max |Δφ| inside φ_max = {in_h:.3} h ({:.2} % of φ_max)", 100.0 * rel);
        assert!(band < all, "the band is a part of the region");
        assert!(in_h < 0.25, "band-local distance off by {in_h} h");
        assert!(in_h <= previous * 1.05, "a wider band must not be worse");
        previous = in_h;
    }
}

#[test]
fn degenerate_inputs_stay_finite() {
    let mut mesh = grid(10);
    // A zero-area face, a duplicated face and an isolated vertex.
    let extra = mesh.positions.len() as u32;
    mesh.positions.push(Point3::new(5.0, 5.0, 0.0));
    mesh.positions.push(Point3::new(0.0, 0.0, 0.0));
    mesh.triangles.push([0, 1, 1]);
    let dup = mesh.triangles[5];
    mesh.triangles.push(dup);
    let _ = extra;
    let region = Region::whole(&mesh.triangles);
    let pos = region.gather(&mesh.positions);
    let s = RegionSolver::new(region).expect("symbolic");
    let f: Vec<f64> = pos.iter().map(|q| q.coords.norm() - 0.3).collect();
    let boundary = Boundary::from_level_set(&s.region, &f);
    let phi = s
        .problem(&pos, &boundary)
        .expect("cut")
        .distance(HeatParams::default())
        .expect("solve");
    assert!(phi.iter().all(|x| !x.is_nan()));
    // A second component with no source is reported unreached (distance +∞), not NaN.
    let mut two = grid(4);
    let shift = two.positions.len() as u32;
    let other = grid(4);
    two.positions.extend(
        other
            .positions
            .iter()
            .map(|p| p + Vector3::new(5.0, 0.0, 0.0)),
    );
    two.triangles
        .extend(other.triangles.iter().map(|t| t.map(|i| i + shift)));
    let region = Region::whole(&two.triangles);
    let pos = region.gather(&two.positions);
    let s = RegionSolver::new(region).expect("symbolic");
    let mut problem = s
        .problem(&pos, &Boundary::vertices(pos.len(), vec![0]))
        .expect("cut");
    let phi = problem.distance(HeatParams::default()).expect("solve");
    assert!(problem.unreached().iter().filter(|&&u| u).count() == other.positions.len());
    assert!(phi.iter().all(|x| !x.is_nan()));
    // An inconsistent boundary is a typed error.
    let mut bad = Boundary::from_level_set(&s.region, &vec![-1.0; pos.len()]);
    bad.inside[0] = false;
    assert!(s.problem(&pos, &bad).is_err());
}
