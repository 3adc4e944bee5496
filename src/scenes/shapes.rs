//! Closed, outward-oriented triangle meshes of the scene primitives: capsules and spheres,
//! a tapered tube with hemispherical caps, a stadium-shaped ring (the lips) and a box (the slab).
//!
//! Every generator takes a target edge length `h` and derives its segment counts from it, so
//! the bodies of one scene share one mesh density. Surfaces of revolution share their vertices
//! (no seam), so they are closed 2-manifolds as written; the box repeats the vertices of its
//! edges (one copy per face, for sharp normals) at bit-identical positions, so it is closed
//! after welding coincident positions.

use nalgebra::{Point3, Vector3};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// A triangle mesh with per-vertex unit normals; triangles are counter-clockwise seen from
/// outside.
#[derive(Clone, Debug, Default)]
pub(crate) struct MeshData {
    /// Vertex positions.
    pub positions: Vec<Point3<f64>>,
    /// Unit vertex normals.
    pub normals: Vec<Vector3<f64>>,
    /// Triangles (vertex indices).
    pub triangles: Vec<[u32; 3]>,
}

/// A right-handed orthonormal frame (`u × v = axis`) placing a surface of revolution.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Frame {
    /// Origin: the center of the first cap.
    pub origin: Point3<f64>,
    /// First radial direction (angle 0).
    pub u: Vector3<f64>,
    /// Second radial direction (angle π/2).
    pub v: Vector3<f64>,
    /// Axis of revolution.
    pub axis: Vector3<f64>,
}

impl Frame {
    /// The frame at `origin` whose axis is `axis` (normalized here); the radial directions are
    /// chosen deterministically.
    pub fn along(origin: Point3<f64>, axis: Vector3<f64>) -> Self {
        let axis = axis.normalize();
        let helper = if axis.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let u = helper.cross(&axis).normalize();
        let v = axis.cross(&u);
        Self { origin, u, v, axis }
    }
}

/// One sample of a meridian: distance along the axis, distance from it, and the unit normal
/// as (axial, radial) components.
#[derive(Clone, Copy, Debug)]
struct ProfilePoint {
    axial: f64,
    radius: f64,
    normal: (f64, f64),
}

impl ProfilePoint {
    /// A point of a sphere of radius `r` centered at `center` on the axis, at latitude `alpha`
    /// (−π/2 at the first pole, π/2 at the last).
    fn on_sphere(center: f64, r: f64, alpha: f64) -> Self {
        Self {
            axial: center + r * alpha.sin(),
            radius: r * alpha.cos(),
            normal: (alpha.sin(), alpha.cos()),
        }
    }
}

/// Number of latitude steps per quarter circle of radius `r` for edge length `h` (at least 2).
pub(crate) fn quarter_steps(r: f64, h: f64) -> usize {
    ((FRAC_PI_2 * r / h).round() as usize).max(2)
}

fn unit2(a: f64, b: f64) -> (f64, f64) {
    let n = a.hypot(b);
    (a / n, b / n)
}

/// Revolves a meridian whose first and last samples are the poles. `around` segments.
fn revolve(frame: &Frame, profile: &[ProfilePoint], around: usize) -> MeshData {
    let rings = &profile[1..profile.len() - 1];
    let mut mesh = MeshData::default();
    let first = profile[0];
    let last = profile[profile.len() - 1];
    push_pole(&mut mesh, frame, first.axial, -1.0);
    for p in rings {
        for j in 0..around {
            let phi = TAU * j as f64 / around as f64;
            let radial = frame.u * phi.cos() + frame.v * phi.sin();
            let pos = frame.origin + frame.axis * p.axial + radial * p.radius;
            let n = frame.axis * p.normal.0 + radial * p.normal.1;
            mesh.positions.push(pos);
            mesh.normals.push(n.normalize());
        }
    }
    push_pole(&mut mesh, frame, last.axial, 1.0);
    mesh.triangles = revolve_triangles(rings.len(), around);
    mesh
}

fn push_pole(mesh: &mut MeshData, frame: &Frame, axial: f64, sign: f64) {
    mesh.positions.push(frame.origin + frame.axis * axial);
    mesh.normals.push(frame.axis * sign);
}

/// Triangles of `rings` rings of `n` vertices between two poles (vertex 0 and the last).
fn revolve_triangles(rings: usize, n: usize) -> Vec<[u32; 3]> {
    let idx = |r: usize, j: usize| (1 + r * n + j % n) as u32;
    let top = (1 + rings * n) as u32;
    let mut tris = Vec::with_capacity(2 * n * rings);
    for j in 0..n {
        tris.push([0, idx(0, j + 1), idx(0, j)]);
    }
    for r in 0..rings - 1 {
        for j in 0..n {
            let (a, b, c, d) = (idx(r, j), idx(r, j + 1), idx(r + 1, j + 1), idx(r + 1, j));
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    for j in 0..n {
        tris.push([top, idx(rings - 1, j), idx(rings - 1, j + 1)]);
    }
    tris
}

/// A capsule: a cylinder of `length` along `frame.axis` from `frame.origin`, closed by two
/// hemispheres of radius `r` (a sphere centered at the origin when `length` is 0). It has
/// `4q` segments around, `q = quarter_steps(r, h)` latitude steps per cap, and cylinder rings
/// spaced like the latitude arcs, so the quads are close to squares.
pub(crate) fn capsule(frame: &Frame, r: f64, length: f64, h: f64) -> MeshData {
    let q = quarter_steps(r, h);
    let step = FRAC_PI_2 / q as f64;
    let mut profile: Vec<ProfilePoint> = (0..=q)
        .map(|i| ProfilePoint::on_sphere(0.0, r, -FRAC_PI_2 + step * i as f64))
        .collect();
    let k = if length > 0.0 {
        ((length / (r * step)).round() as usize).max(1)
    } else {
        0
    };
    profile.extend((1..=k).map(|j| ProfilePoint {
        axial: length * j as f64 / k as f64,
        radius: r,
        normal: (0.0, 1.0),
    }));
    profile.extend((1..=q).map(|i| ProfilePoint::on_sphere(length, r, step * i as f64)));
    revolve(frame, &profile, 4 * q)
}

/// The unit icosphere: the icosahedron with vertices `(0, ±1, ±φ)` and their cyclic
/// permutations, each face split into four `levels` times, every new vertex pushed onto the
/// sphere (`10·4^levels + 2` vertices). Unlike the surfaces of revolution, its triangulation is
/// mirror-symmetric about the three coordinate planes.
pub(crate) fn icosphere(levels: u32) -> MeshData {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let corners = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ];
    let mut positions: Vec<Point3<f64>> = corners
        .iter()
        .map(|p| Point3::from(Vector3::new(p[0], p[1], p[2]).normalize()))
        .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid: std::collections::HashMap<(u32, u32), u32> = Default::default();
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for tri in &triangles {
            let m: [u32; 3] = std::array::from_fn(|k| {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    let p = nalgebra::center(&positions[a as usize], &positions[b as usize]);
                    positions.push(Point3::from(p.coords.normalize()));
                    (positions.len() - 1) as u32
                })
            });
            next.push([tri[0], m[0], m[2]]);
            next.push([tri[1], m[1], m[0]]);
            next.push([tri[2], m[2], m[1]]);
            next.push([m[0], m[1], m[2]]);
        }
        triangles = next;
    }
    let normals = positions.iter().map(|p| p.coords).collect();
    MeshData {
        positions,
        normals,
        triangles,
    }
}

/// Volume of the smooth capsule of [`capsule`].
pub(crate) fn capsule_volume(r: f64, length: f64) -> f64 {
    PI * r * r * length + 4.0 / 3.0 * PI * r.powi(3)
}

/// A tapered tube along `frame.axis`: the radius is piecewise linear through `stations`
/// (axial position, radius), with increasing positions; hemispheres of the first and last
/// radii close it. Segments around: `4 · quarter_steps(max radius, h)`; rings spaced about `h`
/// along the axis, with a ring at every station.
pub(crate) fn tapered_tube(frame: &Frame, stations: &[(f64, f64)], h: f64) -> MeshData {
    let r_max = stations.iter().map(|s| s.1).fold(0.0, f64::max);
    let q = quarter_steps(r_max, h);
    let (a0, r0) = stations[0];
    let (an, rn) = stations[stations.len() - 1];
    let slopes: Vec<(f64, f64)> = stations
        .windows(2)
        .map(|w| unit2(-(w[1].1 - w[0].1), w[1].0 - w[0].0))
        .collect();
    let step = FRAC_PI_2 / q as f64;
    let mut profile: Vec<ProfilePoint> = (0..q)
        .map(|i| ProfilePoint::on_sphere(a0, r0, -FRAC_PI_2 + step * i as f64))
        .collect();
    profile.push(ProfilePoint {
        axial: a0,
        radius: r0,
        normal: unit2(slopes[0].0, slopes[0].1 + 1.0),
    });
    for (s, w) in stations.windows(2).enumerate() {
        let k = (((w[1].0 - w[0].0) / h).round() as usize).max(1);
        for j in 1..=k {
            let t = j as f64 / k as f64;
            let next = slopes.get(s + 1).copied().unwrap_or((0.0, 1.0));
            let normal = if j == k {
                unit2(slopes[s].0 + next.0, slopes[s].1 + next.1)
            } else {
                slopes[s]
            };
            profile.push(ProfilePoint {
                axial: w[0].0 + t * (w[1].0 - w[0].0),
                radius: w[0].1 + t * (w[1].1 - w[0].1),
                normal,
            });
        }
    }
    profile.extend((1..=q).map(|i| ProfilePoint::on_sphere(an, rn, step * i as f64)));
    revolve(frame, &profile, 4 * q)
}

/// Volume of the smooth solid of [`tapered_tube`]: frusta plus the two hemispheres.
pub(crate) fn tapered_tube_volume(stations: &[(f64, f64)]) -> f64 {
    let frusta: f64 = stations
        .windows(2)
        .map(|w| {
            PI / 3.0 * (w[1].0 - w[0].0) * (w[0].1 * w[0].1 + w[0].1 * w[1].1 + w[1].1 * w[1].1)
        })
        .sum();
    let (r0, rn) = (stations[0].1, stations[stations.len() - 1].1);
    frusta + 2.0 / 3.0 * PI * (r0.powi(3) + rn.powi(3))
}

/// A closed ring in the XY plane facing +Z, the shape of both lips: a tube of elliptical
/// cross-section swept along a stadium (two straight segments of length `2 · half_length` at
/// `y = ±corner`, joined by half circles of radius `corner`). The section has semi-axis
/// `thickness` in the ring plane and `depth` along Z; `thickness < corner`, so the opening is a
/// slit of height `2 (corner − thickness)`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Stadium {
    /// Half length of the straight parts (the middle of the lips).
    pub half_length: f64,
    /// Radius of the centerline at the mouth corners.
    pub corner: f64,
    /// Section semi-axis in the ring plane (half the height of a lip).
    pub thickness: f64,
    /// Section semi-axis along Z (half the depth of a lip).
    pub depth: f64,
}

impl Stadium {
    /// Length of the centerline.
    fn length(&self) -> f64 {
        4.0 * self.half_length + TAU * self.corner
    }

    /// Centerline point and in-plane outward normal at arc length `s`, starting at the middle
    /// of the lower straight part and running counter-clockwise seen from +Z.
    fn centerline(&self, s: f64) -> (Point3<f64>, Vector3<f64>) {
        let (c, rho) = (self.half_length, self.corner);
        let arc = PI * rho;
        let around = |center: f64, beta: f64| {
            let n = Vector3::new(beta.cos(), beta.sin(), 0.0);
            (Point3::new(center, 0.0, 0.0) + n * rho, n)
        };
        if s < c {
            (Point3::new(s, -rho, 0.0), -Vector3::y())
        } else if s < c + arc {
            around(c, -FRAC_PI_2 + (s - c) / rho)
        } else if s < 3.0 * c + arc {
            (Point3::new(c - (s - c - arc), rho, 0.0), Vector3::y())
        } else if s < 3.0 * c + 2.0 * arc {
            around(-c, FRAC_PI_2 + (s - 3.0 * c - arc) / rho)
        } else {
            (
                Point3::new(s - 4.0 * c - 2.0 * arc, -rho, 0.0),
                -Vector3::y(),
            )
        }
    }

    /// The mesh centered at the origin, and the centerline point of each vertex's section.
    /// Rings are spaced `~h` by arc length along the centerline (a multiple of 4, so the lip
    /// middles and the corner tips fall on rings); sections have `4 · round(P / 4h)` segments,
    /// `P` the section perimeter.
    pub fn mesh(&self, h: f64) -> (MeshData, Vec<Point3<f64>>) {
        let n_rings = 4 * ((self.length() / (4.0 * h)).round() as usize).max(2);
        let perimeter = ellipse_perimeter(self.thickness, self.depth);
        let n_section = 4 * ((perimeter / (4.0 * h)).round() as usize).max(2);
        let mut mesh = MeshData::default();
        let mut centers = Vec::with_capacity(n_rings * n_section);
        for i in 0..n_rings {
            let (c, n) = self.centerline(self.length() * i as f64 / n_rings as f64);
            for j in 0..n_section {
                let v = TAU * j as f64 / n_section as f64;
                let (cv, sv) = (v.cos(), v.sin());
                mesh.positions
                    .push(c + n * (self.thickness * cv) + Vector3::z() * (self.depth * sv));
                let normal = n * (cv / self.thickness) + Vector3::z() * (sv / self.depth);
                mesh.normals.push(normal.normalize());
                centers.push(c);
            }
        }
        mesh.triangles = ring_triangles(n_rings, n_section);
        (mesh, centers)
    }

    /// Volume of the smooth ring (Pappus: section area times centerline length).
    pub fn volume(&self) -> f64 {
        PI * self.thickness * self.depth * self.length()
    }
}

/// Triangles of a closed tube of `n_rings` rings of `n_section` vertices, ring-major.
fn ring_triangles(n_rings: usize, n_section: usize) -> Vec<[u32; 3]> {
    let idx = |i: usize, j: usize| ((i % n_rings) * n_section + j % n_section) as u32;
    let mut tris = Vec::with_capacity(2 * n_rings * n_section);
    for i in 0..n_rings {
        for j in 0..n_section {
            let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    tris
}

/// Perimeter of an ellipse of semi-axes `a`, `b` (Ramanujan's second approximation, relative
/// error below 1e-9 for the shapes used here).
fn ellipse_perimeter(a: f64, b: f64) -> f64 {
    let h = ((a - b) / (a + b)).powi(2);
    PI * (a + b) * (1.0 + 3.0 * h / (10.0 + (4.0 - 3.0 * h).sqrt()))
}

/// An axis-aligned box from `min` of size `size`, each face a grid of cells of about `h`
/// (diagonals alternating like a checkerboard). Each face has its own vertices with the face
/// normal; vertices on shared edges are computed from the same lattice formula, so copies
/// coincide exactly.
pub(crate) fn slab(min: Point3<f64>, size: Vector3<f64>, h: f64) -> MeshData {
    let cells = size.map(|s| ((s / h).round() as usize).max(1));
    let lattice = |ix: [usize; 3]| {
        Point3::from(Vector3::from_fn(|k, _| {
            min[k] + size[k] * ix[k] as f64 / cells[k] as f64
        }))
    };
    let mut mesh = MeshData::default();
    for axis in 0..3 {
        for positive in [false, true] {
            box_face(
                &mut mesh,
                axis,
                positive,
                [cells.x, cells.y, cells.z],
                &lattice,
            );
        }
    }
    mesh
}

/// Appends the face of the box normal to `axis`, on its `positive` side.
fn box_face(
    mesh: &mut MeshData,
    axis: usize,
    positive: bool,
    cells: [usize; 3],
    lattice: &dyn Fn([usize; 3]) -> Point3<f64>,
) {
    // (a, b) with e_a × e_b = ±e_axis pointing outward.
    let (a, b) = if positive {
        ((axis + 1) % 3, (axis + 2) % 3)
    } else {
        ((axis + 2) % 3, (axis + 1) % 3)
    };
    let mut normal = Vector3::zeros();
    normal[axis] = if positive { 1.0 } else { -1.0 };
    let base = mesh.positions.len();
    let (na, nb) = (cells[a], cells[b]);
    for j in 0..=nb {
        for i in 0..=na {
            let mut ix = [0; 3];
            ix[axis] = if positive { cells[axis] } else { 0 };
            ix[a] = i;
            ix[b] = j;
            mesh.positions.push(lattice(ix));
            mesh.normals.push(normal);
        }
    }
    let idx = |i: usize, j: usize| (base + j * (na + 1) + i) as u32;
    for j in 0..nb {
        for i in 0..na {
            let (p00, p10, p11, p01) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
            if (i + j) % 2 == 0 {
                mesh.triangles.push([p00, p10, p11]);
                mesh.triangles.push([p00, p11, p01]);
            } else {
                mesh.triangles.push([p00, p10, p01]);
                mesh.triangles.push([p10, p11, p01]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn volume(m: &MeshData) -> f64 {
        m.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| m.positions[i as usize].coords);
                a.dot(&b.cross(&c)) / 6.0
            })
            .sum()
    }

    #[test]
    fn capsule_volume_converges_from_below() {
        let f = Frame::along(Point3::new(0.1, 0.2, 0.3), Vector3::new(1.0, 2.0, -0.5));
        let exact = capsule_volume(0.3, 1.0);
        let coarse = volume(&capsule(&f, 0.3, 1.0, 0.1));
        let fine = volume(&capsule(&f, 0.3, 1.0, 0.02));
        assert!(
            coarse > 0.0 && coarse < fine && fine < exact,
            "{coarse} {fine} {exact}"
        );
        assert!((exact - fine) / exact < 0.005);
    }

    #[test]
    fn tapered_tube_volume_is_close() {
        let st = [(0.0, 0.1), (0.3, 0.09), (0.5, 0.07)];
        let f = Frame::along(Point3::origin(), Vector3::y());
        let v = volume(&tapered_tube(&f, &st, 0.005));
        let exact = tapered_tube_volume(&st);
        assert!((v - exact).abs() / exact < 0.01, "{v} {exact}");
    }

    #[test]
    fn stadium_and_slab_volumes() {
        let st = Stadium {
            half_length: 0.5,
            corner: 0.2,
            thickness: 0.15,
            depth: 0.2,
        };
        let (m, centers) = st.mesh(0.01);
        assert_eq!(centers.len(), m.positions.len());
        assert!((volume(&m) - st.volume()).abs() / st.volume() < 0.01);
        let s = slab(
            Point3::new(-1.0, -0.5, -1.0),
            Vector3::new(2.0, 0.5, 2.0),
            0.1,
        );
        assert!((volume(&s) - 2.0).abs() < 1e-9);
    }
}
