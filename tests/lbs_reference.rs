//! Independent reference evaluation of glTF 2.0 linear blend skinning.
//!
//! The evaluator in [`reference`] shares no code with `contact_skin::rig`: it decodes files with
//! the `gltf` crate's own readers and does its math on plain `[f64; 16]` column-major matrices
//! and `[x, y, z, w]` quaternions ([`math`]). The crate's posed vertices (`frames::evaluate` with
//! `Method::Lbs`) must match it to 1e-5 of the posed bounding-box diagonal, at every sampled
//! frame of every animation of the sample characters (`../shared/gltf-samples/`) and of the
//! generated `rigs/*.glb`, plus two instants outside each animation's key range (clamping).
//!
//! The reference slerp is exact (glTF 2.0 Appendix C); the spec lets implementations
//! approximate it, and the crate's normalized-lerp shortcut for nearly equal keys shows up as
//! errors of a few 1e-7 on CesiumMan, Fox and the Quaternius robot, well within tolerance.
//!
//! The corner cases at the end build small glTF documents (embedded base64 buffers) that
//! exercise one rule each: CUBICSPLINE and STEP sampling, `matrix` nodes, non-uniform scales,
//! unnormalized weights, integer joints and normalized integer weights, sparse accessors and
//! interleaved vertex buffers.

use contact_skin::frames::{self, Precomputed};
use contact_skin::rig::{self, Rig};
use contact_skin::skinning::Method;
use reference::Reference;
use std::path::{Path, PathBuf};

/// Largest accepted distance between the crate and the reference, relative to the diagonal of
/// the posed bounding box of the whole rig at that frame.
const TOLERANCE: f64 = 1e-5;

/// Plain f64 linear algebra: column-major matrices and `[x, y, z, w]` quaternions.
mod math {
    /// 4×4 matrix, column-major as glTF stores them: row `r`, column `c` at `c * 4 + r`.
    pub type M4 = [f64; 16];
    /// Quaternion `[x, y, z, w]` (glTF order, scalar last).
    pub type Quat = [f64; 4];

    pub const IDENTITY: M4 = [
        1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
    ];

    /// Matrix product `a · b`.
    pub fn mul(a: &M4, b: &M4) -> M4 {
        std::array::from_fn(|i| {
            let (c, r) = (i / 4, i % 4);
            (0..4).map(|k| a[k * 4 + r] * b[c * 4 + k]).sum()
        })
    }

    /// Transforms the point `p` (homogeneous w = 1; glTF matrices are affine).
    pub fn apply(m: &M4, p: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|r| m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r])
    }

    pub fn dot(a: Quat, b: Quat) -> f64 {
        a.iter().zip(&b).map(|(x, y)| x * y).sum()
    }

    fn norm(q: Quat) -> f64 {
        dot(q, q).sqrt()
    }

    /// `q / |q|`; glTF rotations are unit quaternions, stored in f32 so only nearly unit.
    pub fn normalize(q: Quat) -> Quat {
        let n = norm(q);
        assert!(
            n > 0.0 && n.is_finite(),
            "quaternion {q:?} cannot be normalized"
        );
        q.map(|x| x / n)
    }

    /// The local matrix of a glTF node given by TRS: `T · R · S` (glTF 2.0 §3.5.3).
    pub fn trs(t: [f64; 3], q: Quat, s: [f64; 3]) -> M4 {
        let [x, y, z, w] = normalize(q);
        // Columns of the rotation matrix of the unit quaternion (x, y, z, w).
        let rot = [
            [
                1.0 - 2.0 * (y * y + z * z),
                2.0 * (x * y + z * w),
                2.0 * (x * z - y * w),
            ],
            [
                2.0 * (x * y - z * w),
                1.0 - 2.0 * (x * x + z * z),
                2.0 * (y * z + x * w),
            ],
            [
                2.0 * (x * z + y * w),
                2.0 * (y * z - x * w),
                1.0 - 2.0 * (x * x + y * y),
            ],
        ];
        std::array::from_fn(|i| match (i / 4, i % 4) {
            (3, 3) => 1.0,
            (3, r) => t[r],
            (_, 3) => 0.0,
            // R · S scales the columns of R.
            (c, r) => rot[c][r] * s[c],
        })
    }

    /// Spherical linear interpolation from `a` (s = 0) to `b` (s = 1) along the shorter arc
    /// (glTF 2.0 Appendix C). The angle comes from `atan2`, which stays exact for nearly
    /// equal quaternions, so no linear fallback is needed.
    pub fn slerp(a: Quat, b: Quat, s: f64) -> Quat {
        let a = normalize(a);
        let mut b = normalize(b);
        // q and -q are the same rotation: flip b onto a's hemisphere for the shorter arc.
        if dot(a, b) < 0.0 {
            b = b.map(|x| -x);
        }
        let diff = norm(std::array::from_fn(|i| a[i] - b[i]));
        let sum = norm(std::array::from_fn(|i| a[i] + b[i]));
        let theta = 2.0 * diff.atan2(sum);
        let (wa, wb) = if theta < 1e-12 {
            (1.0 - s, s)
        } else {
            let sin = theta.sin();
            (((1.0 - s) * theta).sin() / sin, (s * theta).sin() / sin)
        };
        normalize(std::array::from_fn(|i| wa * a[i] + wb * b[i]))
    }

    /// The cubic Hermite spline of glTF 2.0 Appendix C between keys k and k+1:
    /// `p(s) = (2s³-3s²+1) v_k + td (s³-2s²+s) b_k + (-2s³+3s²) v_k+1 + td (s³-s²) a_k+1`,
    /// where `b_k` is the out-tangent of key k, `a_k+1` the in-tangent of key k+1 and `td` the
    /// key interval (tangents are stored per second, hence the scaling by `td`).
    pub fn hermite(v0: &[f64], b0: &[f64], v1: &[f64], a1: &[f64], td: f64, s: f64) -> Vec<f64> {
        let (s2, s3) = (s * s, s * s * s);
        let h_v0 = 2.0 * s3 - 3.0 * s2 + 1.0;
        let h_b0 = td * (s3 - 2.0 * s2 + s);
        let h_v1 = -2.0 * s3 + 3.0 * s2;
        let h_a1 = td * (s3 - s2);
        (0..v0.len())
            .map(|i| h_v0 * v0[i] + h_b0 * b0[i] + h_v1 * v1[i] + h_a1 * a1[i])
            .collect()
    }
}

/// The reference: a glTF file decoded with the `gltf` crate's readers and posed with [`math`].
mod reference {
    use super::math::{self, Quat, M4};
    use base64::Engine;
    use gltf::animation::util::ReadOutputs;
    use std::path::Path;

    /// A node's local transform, as written in the file.
    #[derive(Clone, Copy, Debug)]
    pub enum Local {
        Matrix(M4),
        Trs { t: [f64; 3], r: Quat, s: [f64; 3] },
    }

    impl Local {
        fn matrix(&self) -> M4 {
            match *self {
                Local::Matrix(m) => m,
                Local::Trs { t, r, s } => math::trs(t, r, s),
            }
        }
    }

    /// Animated node property.
    #[derive(Clone, Copy, Debug, PartialEq)]
    enum Path3 {
        Translation,
        Rotation,
        Scale,
        /// Morph target weights (glTF 2.0 §3.7.2.2).
        Weights,
    }

    #[derive(Clone, Copy, Debug, PartialEq)]
    enum Interp {
        Linear,
        Step,
        CubicSpline,
    }

    /// One animation channel with its sampler's keys.
    #[derive(Clone, Debug)]
    struct Channel {
        node: usize,
        path: Path3,
        interp: Interp,
        times: Vec<f64>,
        /// One entry per output element; CUBICSPLINE stores `[in-tangent, value, out-tangent]`
        /// for each key, so three entries per key.
        values: Vec<Vec<f64>>,
    }

    /// An animation: its node channels (transforms and morph target weights).
    #[derive(Clone, Debug)]
    pub struct Animation {
        channels: Vec<Channel>,
    }

    /// One skinned mesh instance: a node with both a mesh and a skin.
    #[derive(Clone, Debug)]
    pub struct Body {
        pub node: usize,
        /// Skin joint nodes and their inverse bind matrices.
        joints: Vec<usize>,
        ibm: Vec<M4>,
        /// Bind positions of the mesh's triangle primitives, concatenated in file order.
        pub positions: Vec<[f64; 3]>,
        /// Raw `(joint, weight)` influences of every JOINTS_n / WEIGHTS_n set, zeros dropped.
        influences: Vec<Vec<(usize, f64)>>,
        /// Morph targets: per target, the POSITION displacement of every vertex (zeros where a
        /// primitive's target has none), primitives concatenated as `positions`.
        targets: Vec<Vec<[f64; 3]>>,
        /// The node's `weights`, else the mesh's, else zeros.
        default_weights: Vec<f64>,
    }

    /// Everything needed to pose the file's skinned meshes.
    #[derive(Clone, Debug)]
    pub struct Reference {
        parents: Vec<Option<usize>>,
        rest: Vec<Local>,
        pub bodies: Vec<Body>,
        pub animations: Vec<Animation>,
    }

    impl Reference {
        /// Reads a `.gltf` / `.glb` file (relative buffer URIs resolve next to it).
        pub fn from_file(path: &Path) -> Self {
            let bytes = std::fs::read(path)
                .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
            Self::from_bytes(&bytes, path.parent())
        }

        /// Reads a glTF document from memory; `folder` resolves relative buffer URIs.
        pub fn from_bytes(bytes: &[u8], folder: Option<&Path>) -> Self {
            let gltf = gltf::Gltf::from_slice(bytes).expect("the gltf crate rejects the file");
            let buffers = read_buffers(&gltf, folder);
            let doc = &gltf.document;
            Self {
                parents: parents(doc),
                rest: doc.nodes().map(|n| rest_local(&n)).collect(),
                bodies: read_bodies(doc, &buffers),
                animations: doc
                    .animations()
                    .map(|a| read_animation(&a, &buffers))
                    .collect(),
            }
        }

        /// Posed positions of every body at time `t` of `animation` (rest pose for `None`);
        /// `None` for a vertex without any positive weight (glTF leaves it undefined).
        pub fn pose(&self, animation: Option<usize>, t: f64) -> Vec<Vec<Option<[f64; 3]>>> {
            let locals = self.locals_at(animation, t);
            let world = self.world(&locals);
            let weights = self.weights_at(animation, t);
            self.bodies
                .iter()
                .map(|b| {
                    let w = weights[b.node].as_ref().unwrap_or(&b.default_weights);
                    skin(b, &morphed(b, w), &world)
                })
                .collect()
        }

        /// Morph weights per node at time `t`: the value of the node's `weights` channel
        /// (`None` without one).
        fn weights_at(&self, animation: Option<usize>, t: f64) -> Vec<Option<Vec<f64>>> {
            let mut weights = vec![None; self.rest.len()];
            let channels = animation.map_or(&[][..], |a| &self.animations[a].channels[..]);
            for ch in channels.iter().filter(|c| c.path == Path3::Weights) {
                weights[ch.node] = Some(ch.sample(t));
            }
            weights
        }

        /// Local transforms at time `t`: every channel overrides one property of its node's
        /// rest TRS (glTF 2.0 §3.11; animated nodes never use `matrix`).
        fn locals_at(&self, animation: Option<usize>, t: f64) -> Vec<Local> {
            let mut locals = self.rest.clone();
            let channels = animation.map_or(&[][..], |a| &self.animations[a].channels[..]);
            for ch in channels.iter().filter(|c| c.path != Path3::Weights) {
                let v = ch.sample(t);
                let Local::Trs { t: tr, r, s } = &mut locals[ch.node] else {
                    panic!(
                        "glTF 2.0 §3.11: animated node {} must not use `matrix`",
                        ch.node
                    );
                };
                match ch.path {
                    Path3::Translation => *tr = [v[0], v[1], v[2]],
                    Path3::Scale => *s = [v[0], v[1], v[2]],
                    Path3::Rotation => *r = math::normalize([v[0], v[1], v[2], v[3]]),
                    Path3::Weights => unreachable!("filtered out"),
                }
            }
            locals
        }

        /// World matrices: `world(n) = world(parent(n)) · local(n)`, roots being their local.
        fn world(&self, locals: &[Local]) -> Vec<M4> {
            let mut memo = vec![None; locals.len()];
            (0..locals.len())
                .map(|n| self.world_of(n, locals, &mut memo))
                .collect()
        }

        fn world_of(&self, n: usize, locals: &[Local], memo: &mut [Option<M4>]) -> M4 {
            if let Some(m) = memo[n] {
                return m;
            }
            let local = locals[n].matrix();
            let m = match self.parents[n] {
                Some(p) => math::mul(&self.world_of(p, locals, memo), &local),
                None => local,
            };
            memo[n] = Some(m);
            m
        }
    }

    impl Animation {
        /// `[start, end]`: the earliest and latest key time over all channels.
        pub fn range(&self) -> (f64, f64) {
            let start = self
                .channels
                .iter()
                .map(|c| c.times[0])
                .fold(f64::INFINITY, f64::min);
            let end = self
                .channels
                .iter()
                .map(|c| c.times[c.times.len() - 1])
                .fold(f64::NEG_INFINITY, f64::max);
            if start.is_finite() {
                (start, end)
            } else {
                (0.0, 0.0)
            }
        }
    }

    impl Channel {
        /// The value at time `t` (glTF 2.0 §3.11 and Appendix C).
        fn sample(&self, t: f64) -> Vec<f64> {
            let cubic = self.interp == Interp::CubicSpline;
            // CUBICSPLINE keys are triples [in-tangent a_k, value v_k, out-tangent b_k].
            let value = |k: usize| &self.values[if cubic { 3 * k + 1 } else { k }][..];
            let last = self.times.len() - 1;
            // Outside the key range the output is clamped to the first / last value.
            if t <= self.times[0] {
                return value(0).to_vec();
            }
            if t >= self.times[last] {
                return value(last).to_vec();
            }
            // The interval [t_k, t_k+1) that contains t.
            let k = self
                .times
                .iter()
                .rposition(|&x| x <= t)
                .expect("t > times[0]");
            let td = self.times[k + 1] - self.times[k];
            let s = (t - self.times[k]) / td;
            match self.interp {
                // STEP holds the value of the key that starts the interval.
                Interp::Step => value(k).to_vec(),
                // LINEAR rotations use slerp; other properties interpolate linearly.
                Interp::Linear if self.path == Path3::Rotation => {
                    let (a, b) = (value(k), value(k + 1));
                    math::slerp([a[0], a[1], a[2], a[3]], [b[0], b[1], b[2], b[3]], s).to_vec()
                }
                Interp::Linear => {
                    let (a, b) = (value(k), value(k + 1));
                    a.iter().zip(b).map(|(x, y)| x + s * (y - x)).collect()
                }
                // CUBICSPLINE: Hermite between v_k and v_k+1 with out-tangent b_k and in-tangent
                // a_k+1; a rotation result is then normalized (done by `locals_at`).
                Interp::CubicSpline => math::hermite(
                    &self.values[3 * k + 1],
                    &self.values[3 * k + 2],
                    &self.values[3 * k + 4],
                    &self.values[3 * k + 3],
                    td,
                    s,
                ),
            }
        }
    }

    /// The bind positions morphed (glTF 2.0 §3.7.2.2): `p + Σ_k w_k Δp_k`.
    fn morphed(body: &Body, weights: &[f64]) -> Vec<[f64; 3]> {
        let mut out = body.positions.clone();
        for (target, &w) in body.targets.iter().zip(weights) {
            for (p, d) in out.iter_mut().zip(target) {
                for i in 0..3 {
                    p[i] += w * d[i];
                }
            }
        }
        out
    }

    /// LBS (glTF 2.0 §3.7.3): `p' = Σ_j w_j · (world(joint_j) · IBM_j) · p` with the weights
    /// of every set renormalized to sum 1, of the (morphed) bind `positions`. The mesh node's
    /// own transform is not applied.
    fn skin(body: &Body, positions: &[[f64; 3]], world: &[M4]) -> Vec<Option<[f64; 3]>> {
        let joint_mats: Vec<M4> = body
            .joints
            .iter()
            .zip(&body.ibm)
            .map(|(&node, ibm)| math::mul(&world[node], ibm))
            .collect();
        positions
            .iter()
            .zip(&body.influences)
            .map(|(&p, row)| {
                let total: f64 = row.iter().map(|&(_, w)| w).sum();
                (total > 0.0).then(|| {
                    let mut out = [0.0; 3];
                    for &(j, w) in row {
                        let q = math::apply(&joint_mats[j], p);
                        for (o, x) in out.iter_mut().zip(q) {
                            *o += w / total * x;
                        }
                    }
                    out
                })
            })
            .collect()
    }

    /// Bytes of every buffer: the GLB `BIN` chunk, a base64 `data:` URI or a sibling file.
    fn read_buffers(gltf: &gltf::Gltf, folder: Option<&Path>) -> Vec<Vec<u8>> {
        gltf.buffers()
            .map(|b| match b.source() {
                gltf::buffer::Source::Bin => gltf.blob.clone().expect("GLB without a BIN chunk"),
                gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                    let (_, data) = uri.split_once(";base64,").expect("data URI without base64");
                    base64::engine::general_purpose::STANDARD
                        .decode(data)
                        .expect("invalid base64 data URI")
                }
                gltf::buffer::Source::Uri(uri) => {
                    let folder = folder.expect("relative buffer URI without a folder");
                    let file = folder.join(percent_decode(uri));
                    std::fs::read(&file)
                        .unwrap_or_else(|e| panic!("cannot read {}: {e}", file.display()))
                }
            })
            .collect()
    }

    /// Decodes the `%XX` escapes of a relative URI.
    fn percent_decode(uri: &str) -> String {
        let mut out = Vec::new();
        let mut rest = uri.as_bytes();
        while let Some((&c, tail)) = rest.split_first() {
            let hex = tail.get(..2).and_then(|h| std::str::from_utf8(h).ok());
            match hex.and_then(|h| u8::from_str_radix(h, 16).ok()) {
                Some(byte) if c == b'%' => {
                    out.push(byte);
                    rest = &tail[2..];
                }
                _ => {
                    out.push(c);
                    rest = tail;
                }
            }
        }
        String::from_utf8(out).expect("URI is not UTF-8")
    }

    /// Parent of every node, from the `children` lists.
    fn parents(doc: &gltf::Document) -> Vec<Option<usize>> {
        let mut parents = vec![None; doc.nodes().len()];
        for node in doc.nodes() {
            for child in node.children() {
                parents[child.index()] = Some(node.index());
            }
        }
        parents
    }

    /// A node's rest transform: its `matrix`, else its TRS (defaults: 0, identity, 1).
    fn rest_local(node: &gltf::Node) -> Local {
        let f = |v: &[f32]| -> Vec<f64> { v.iter().map(|&x| f64::from(x)).collect() };
        match node.transform() {
            gltf::scene::Transform::Matrix { matrix } => {
                Local::Matrix(std::array::from_fn(|i| f64::from(matrix[i / 4][i % 4])))
            }
            gltf::scene::Transform::Decomposed {
                translation,
                rotation,
                scale,
            } => {
                let (t, r, s) = (f(&translation), f(&rotation), f(&scale));
                Local::Trs {
                    t: [t[0], t[1], t[2]],
                    r: math::normalize([r[0], r[1], r[2], r[3]]),
                    s: [s[0], s[1], s[2]],
                }
            }
        }
    }

    /// Skinned mesh instances in node order, each with its triangle primitives.
    fn read_bodies(doc: &gltf::Document, buffers: &[Vec<u8>]) -> Vec<Body> {
        doc.nodes()
            .filter_map(|node| {
                let (mesh, skin) = (node.mesh()?, node.skin()?);
                let reader = skin.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
                let joints: Vec<usize> = skin.joints().map(|j| j.index()).collect();
                // Without inverseBindMatrices every IBM is the identity.
                let ibm = match reader.read_inverse_bind_matrices() {
                    Some(it) => it
                        .map(|m| std::array::from_fn(|i| f64::from(m[i / 4][i % 4])))
                        .collect(),
                    None => vec![math::IDENTITY; joints.len()],
                };
                let weights = node.weights().or(mesh.weights()).unwrap_or(&[]);
                let mut body = Body {
                    node: node.index(),
                    joints,
                    ibm,
                    positions: Vec::new(),
                    influences: Vec::new(),
                    targets: Vec::new(),
                    default_weights: weights.iter().map(|&w| f64::from(w)).collect(),
                };
                for prim in mesh.primitives() {
                    read_primitive(&prim, buffers, &mut body);
                }
                (!body.positions.is_empty()).then_some(body)
            })
            .collect()
    }

    /// Appends a triangle primitive's positions and influences (other modes are not surfaces).
    fn read_primitive(prim: &gltf::Primitive, buffers: &[Vec<u8>], body: &mut Body) {
        use gltf::mesh::Mode;
        if !matches!(
            prim.mode(),
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            return;
        }
        let reader = prim.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
        let first = body.positions.len();
        let positions = reader.read_positions().expect("primitive without POSITION");
        body.positions.extend(positions.map(|p| p.map(f64::from)));
        body.influences.resize(body.positions.len(), Vec::new());
        // Target k of this primitive extends the body's target k (zeros without POSITION).
        for (k, (displaced, _, _)) in reader.read_morph_targets().enumerate() {
            if body.targets.len() <= k {
                body.targets.push(vec![[0.0; 3]; first]);
            }
            let target = &mut body.targets[k];
            match displaced {
                Some(it) => target.extend(it.map(|d| d.map(f64::from))),
                None => target.resize(body.positions.len(), [0.0; 3]),
            }
        }
        if body.default_weights.is_empty() {
            body.default_weights = vec![0.0; body.targets.len()];
        }
        // Every JOINTS_n / WEIGHTS_n set adds four influences per vertex.
        for set in 0.. {
            let (Some(joints), Some(weights)) = (reader.read_joints(set), reader.read_weights(set))
            else {
                break;
            };
            let rows = joints.into_u16().zip(weights.into_f32());
            for (row, (j, w)) in body.influences[first..].iter_mut().zip(rows) {
                let pairs = j.iter().zip(&w).filter(|&(_, &w)| w != 0.0);
                row.extend(pairs.map(|(&j, &w)| (usize::from(j), f64::from(w))));
            }
        }
    }

    /// A node animation's channels, with their keys read by the `gltf` crate.
    fn read_animation(anim: &gltf::Animation, buffers: &[Vec<u8>]) -> Animation {
        let channels = anim
            .channels()
            .filter_map(|ch| {
                let reader = ch.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
                let times: Vec<f64> = reader.read_inputs()?.map(f64::from).collect();
                let (path, values): (Path3, Vec<Vec<f64>>) = match reader.read_outputs()? {
                    ReadOutputs::Translations(it) => (Path3::Translation, widen(it)),
                    ReadOutputs::Scales(it) => (Path3::Scale, widen(it)),
                    ReadOutputs::Rotations(r) => (Path3::Rotation, widen(r.into_f32())),
                    ReadOutputs::MorphTargetWeights(w) => {
                        // One value holds one weight per target of the node's mesh.
                        let mesh = ch.target().node().mesh()?;
                        let n = mesh.primitives().next()?.morph_targets().count();
                        let flat: Vec<f64> = w.into_f32().map(f64::from).collect();
                        (
                            Path3::Weights,
                            flat.chunks(n).map(<[f64]>::to_vec).collect(),
                        )
                    }
                };
                let interp = match ch.sampler().interpolation() {
                    gltf::animation::Interpolation::Linear => Interp::Linear,
                    gltf::animation::Interpolation::Step => Interp::Step,
                    gltf::animation::Interpolation::CubicSpline => Interp::CubicSpline,
                };
                Some(Channel {
                    node: ch.target().node().index(),
                    path,
                    interp,
                    times,
                    values,
                })
            })
            .collect();
        Animation { channels }
    }

    fn widen<const N: usize>(it: impl Iterator<Item = [f32; N]>) -> Vec<Vec<f64>> {
        it.map(|v| v.iter().map(|&x| f64::from(x)).collect())
            .collect()
    }
}

/// What one comparison covered and the worst disagreement found.
#[derive(Debug, Default)]
struct Outcome {
    bodies: usize,
    vertices: usize,
    animations: usize,
    frames: usize,
    /// Vertices without any positive weight (undefined by glTF), not compared.
    unweighted: usize,
    max_rel: f64,
    worst: String,
}

impl std::fmt::Display for Outcome {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} bodies, {} vertices, {} animations, {} frames, max error {:.3e} of the bbox diagonal",
            self.bodies, self.vertices, self.animations, self.frames, self.max_rel
        )?;
        if self.unweighted > 0 {
            write!(f, " ({} unweighted vertex-frames skipped)", self.unweighted)?;
        }
        Ok(())
    }
}

/// Compares the crate's LBS to the reference on every frame the crate samples for every
/// animation, plus the rest pose and one instant before / after each animation's keys.
fn check_rig(label: &str, rig: &Rig, reference: &Reference) -> Outcome {
    assert_eq!(
        rig.bodies.len(),
        reference.bodies.len(),
        "{label}: body count"
    );
    for (i, (b, r)) in rig.bodies.iter().zip(&reference.bodies).enumerate() {
        assert_eq!(b.node, r.node, "{label}: node of body {i}");
        assert_eq!(
            b.vertex_count(),
            r.positions.len(),
            "{label}: vertices of body {i}"
        );
    }
    assert_eq!(
        rig.animations.len(),
        reference.animations.len(),
        "{label}: animation count"
    );
    let pre = Precomputed::new(rig, Method::Lbs);
    let mut out = Outcome {
        bodies: rig.bodies.len(),
        vertices: rig.vertex_count(),
        animations: rig.animations.len(),
        ..Outcome::default()
    };
    compare_frame(rig, &pre, reference, None, 0, 0.0, &mut out);
    for (a, anim) in reference.animations.iter().enumerate() {
        let times = frames::sample_times(rig, Some(a), None).expect("frames");
        let (start, end) = anim.range();
        let span = (times[0], times[times.len() - 1]);
        let covers = (span.0 - start).abs() <= 1e-9 && (span.1 - end).abs() <= 1e-9;
        assert!(
            covers,
            "{label}: animation {a} sampled over {span:?}, keys span [{start}, {end}]"
        );
        let outside = [start - 0.5, end + 0.5];
        for (i, &t) in times.iter().chain(&outside).enumerate() {
            compare_frame(rig, &pre, reference, Some(a), i, t, &mut out);
        }
    }
    out
}

/// Compares one frame vertex by vertex and records the worst relative error.
fn compare_frame(
    rig: &Rig,
    pre: &Precomputed,
    reference: &Reference,
    animation: Option<usize>,
    index: usize,
    t: f64,
    out: &mut Outcome,
) {
    let frame = frames::evaluate(rig, pre, animation, index, t);
    let want = reference.pose(animation, t);
    let diagonal = bbox_diagonal(want.iter().flatten().flatten()).max(1e-300);
    out.frames += 1;
    for (b, (got, want)) in frame.bodies.iter().zip(&want).enumerate() {
        for (v, (g, w)) in got.positions.iter().zip(want).enumerate() {
            let Some(w) = w else {
                out.unweighted += 1;
                continue;
            };
            let g = [g.x, g.y, g.z];
            let rel = distance(g, *w) / diagonal;
            // A NaN from the crate counts as an infinite error.
            let rel = if rel.is_nan() { f64::INFINITY } else { rel };
            if rel > out.max_rel {
                out.max_rel = rel;
                out.worst = format!(
                    "animation {animation:?} frame {index} (t = {t}) body {b} vertex {v}: \
                     crate {g:?}, reference {w:?}, bbox diagonal {diagonal}"
                );
            }
        }
    }
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    a.iter()
        .zip(&b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

fn bbox_diagonal<'a>(points: impl Iterator<Item = &'a [f64; 3]>) -> f64 {
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in points {
        for i in 0..3 {
            lo[i] = lo[i].min(p[i]);
            hi[i] = hi[i].max(p[i]);
        }
    }
    distance(lo, hi)
}

/// Loads `path` with the crate and with the reference, and compares them.
fn check_file(path: &Path) -> Outcome {
    let label = path.display().to_string();
    let rig = rig::load(path).unwrap_or_else(|e| panic!("{label}: the crate cannot load it: {e}"));
    check_rig(&label, &rig, &Reference::from_file(path))
}

/// Checks every file, prints one line per file, then fails on any error above tolerance.
fn check_files(files: &[PathBuf]) {
    let mut failures = Vec::new();
    for file in files {
        let out = check_file(file);
        println!("{}: {out}", file.display());
        if out.max_rel >= TOLERANCE {
            failures.push(format!("{}: {}", file.display(), out.worst));
        }
    }
    assert!(
        failures.is_empty(),
        "LBS differs from the reference by more than {TOLERANCE} of the bbox diagonal:\n{}",
        failures.join("\n")
    );
}

/// `*.glb` and `*.gltf` files directly in `dir`, sorted.
fn gltf_files(dir: &Path) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "glb" || e == "gltf"))
        .collect();
    files.sort();
    files
}

#[test]
fn lbs_matches_reference_on_sample_characters() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/gltf-samples");
    assert!(
        root.is_dir(),
        "the glTF sample characters are missing: expected them in {} (one folder per character)",
        root.display()
    );
    let mut folders: Vec<PathBuf> = std::fs::read_dir(&root)
        .expect("cannot list the samples folder")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_dir())
        .collect();
    folders.sort();
    let files: Vec<PathBuf> = folders.iter().flat_map(|d| gltf_files(d)).collect();
    assert!(
        !files.is_empty(),
        "no .glb / .gltf file under {}",
        root.display()
    );
    check_files(&files);
}

#[test]
fn lbs_matches_reference_on_generated_rigs() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("rigs");
    let files: Vec<PathBuf> = gltf_files(&dir)
        .into_iter()
        .filter(|p| p.extension().is_some_and(|e| e == "glb"))
        .collect();
    if files.is_empty() {
        println!("note: no generated rig in {} yet; skipped", dir.display());
        return;
    }
    check_files(&files);
}

/// Builders of small skinned glTF documents for the corner cases.
mod fixture {
    use base64::Engine;
    use serde_json::{json, Value};

    pub const FLOAT: u32 = 5126;
    pub const UNSIGNED_BYTE: u32 = 5121;
    pub const UNSIGNED_SHORT: u32 = 5123;

    /// A glTF document under construction: one binary buffer (embedded as a base64 data URI)
    /// with its buffer views and accessors.
    #[derive(Default)]
    pub struct Builder {
        bin: Vec<u8>,
        views: Vec<Value>,
        accessors: Vec<Value>,
    }

    impl Builder {
        /// Appends a 4-byte aligned buffer view, interleaved when `stride` is given.
        pub fn view(&mut self, bytes: &[u8], stride: Option<usize>) -> usize {
            self.bin.resize(self.bin.len().next_multiple_of(4), 0);
            let mut v =
                json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()});
            if let Some(s) = stride {
                v["byteStride"] = json!(s);
            }
            self.bin.extend_from_slice(bytes);
            self.views.push(v);
            self.views.len() - 1
        }

        /// Appends an accessor of `count` elements of `ty` at `offset` in `view`.
        pub fn accessor(
            &mut self,
            view: usize,
            offset: usize,
            ctype: u32,
            count: usize,
            ty: &str,
        ) -> usize {
            self.accessors.push(json!({
                "bufferView": view, "byteOffset": offset, "componentType": ctype,
                "count": count, "type": ty,
            }));
            self.accessors.len() - 1
        }

        /// Appends an accessor of `count` elements of `ty` without a buffer view (all zeros
        /// until a `sparse` property substitutes some).
        pub fn viewless(&mut self, ctype: u32, count: usize, ty: &str) -> usize {
            self.accessors
                .push(json!({"componentType": ctype, "count": count, "type": ty}));
            self.accessors.len() - 1
        }

        /// Sets a property (`min`, `normalized`, `sparse`...) of accessor `index`.
        pub fn set(&mut self, index: usize, key: &str, value: Value) {
            self.accessors[index][key] = value;
        }

        /// A tightly packed FLOAT accessor holding `values`.
        pub fn floats(&mut self, values: &[f32], ty: &str) -> usize {
            let width = match ty {
                "SCALAR" => 1,
                "VEC3" => 3,
                "VEC4" => 4,
                "MAT4" => 16,
                _ => panic!("unsupported accessor type {ty}"),
            };
            let view = self.view(&le_bytes(values), None);
            self.accessor(view, 0, FLOAT, values.len() / width, ty)
        }

        /// The finished `.gltf` JSON with `root`'s scene, nodes, meshes, skins and animations.
        pub fn finish(self, mut root: Value) -> Vec<u8> {
            let data = base64::engine::general_purpose::STANDARD.encode(&self.bin);
            root["asset"] = json!({"version": "2.0"});
            root["buffers"] = json!([{
                "byteLength": self.bin.len(),
                "uri": format!("data:application/octet-stream;base64,{data}"),
            }]);
            root["bufferViews"] = Value::Array(self.views);
            root["accessors"] = Value::Array(self.accessors);
            serde_json::to_vec_pretty(&root).expect("JSON")
        }
    }

    pub fn le_bytes(values: &[f32]) -> Vec<u8> {
        values.iter().flat_map(|v| v.to_le_bytes()).collect()
    }
}

/// The corner-case character: a vertical strip of 14 vertices skinned to a chain of three
/// joints, with its encodings and animations.
mod strip {
    use super::fixture::{self, Builder};
    use serde_json::{json, Value};

    /// Component type of JOINTS_0.
    #[derive(Clone, Copy, Debug, Default, PartialEq)]
    pub enum Joints {
        U8,
        #[default]
        U16,
    }

    /// Component type of WEIGHTS_0 (integers are normalized).
    #[derive(Clone, Copy, Debug, Default, PartialEq)]
    pub enum Weights {
        #[default]
        F32,
        U8,
        U16,
    }

    /// How the vertex attributes are stored.
    #[derive(Clone, Copy, Debug, Default)]
    pub struct Encoding {
        pub joints: Joints,
        pub weights: Weights,
        /// POSITION, JOINTS_0 and WEIGHTS_0 interleaved in one view with `byteStride`.
        pub interleaved: bool,
        /// POSITION given as a wrong base corrected by a sparse accessor.
        pub sparse_positions: bool,
        /// Each vertex's weights are multiplied by `0.55 + 0.1 · (v mod 7)` (sum ≠ 1).
        pub unnormalized: bool,
        /// Two morph targets ([`morph_targets`]) with the mesh's default weights 0.5 and -0.25.
        pub morphs: bool,
    }

    /// One key track of an animation sampler.
    pub struct Track {
        pub node: usize,
        pub path: &'static str,
        pub interpolation: &'static str,
        pub times: Vec<f32>,
        pub values: Vec<f32>,
    }

    pub const VERTICES: usize = 14;
    /// Vertices that the sparse morph target moves.
    const MORPHED: [usize; 2] = [3, 8];
    /// Vertices that the sparse accessor corrects.
    const SPARSE: [usize; 3] = [1, 6, 11];

    /// Bind position of vertex `v`: two vertices per level, levels every 0.5 along y.
    pub fn position(v: usize) -> [f32; 3] {
        let (level, side) = (v / 2, v % 2);
        let x = if side == 0 { -0.25 } else { 0.25 };
        let z = 0.05 * level as f32 * if side == 0 { 1.0 } else { -1.0 };
        [x, 0.5 * level as f32, z]
    }

    /// Joints and weights of vertex `v`: blended between the joints (at y = 0, 1, 2) around it.
    fn influence(v: usize, enc: &Encoding) -> ([u16; 4], [f32; 4]) {
        let y = position(v)[1];
        let k = (y.floor() as u16).min(2);
        let f = if k == 2 { 0.0 } else { y - f32::from(k) };
        let scale = if enc.unnormalized {
            0.55 + 0.1 * (v % 7) as f32
        } else {
            1.0
        };
        (
            [k, (k + 1).min(2), 0, 0],
            [(1.0 - f) * scale, f * scale, 0.0, 0.0],
        )
    }

    fn joint_bytes(j: [u16; 4], kind: Joints) -> Vec<u8> {
        match kind {
            Joints::U8 => j.iter().map(|&x| x as u8).collect(),
            Joints::U16 => j.iter().flat_map(|x| x.to_le_bytes()).collect(),
        }
    }

    /// Weights as stored: f32, or normalized integers `round(w · max)`.
    fn weight_bytes(w: [f32; 4], kind: Weights) -> Vec<u8> {
        match kind {
            Weights::F32 => fixture::le_bytes(&w),
            Weights::U8 => w
                .iter()
                .map(|&x| (x * 255.0).round().min(255.0) as u8)
                .collect(),
            Weights::U16 => w
                .iter()
                .flat_map(|&x| ((x * 65535.0).round().min(65535.0) as u16).to_le_bytes())
                .collect(),
        }
    }

    fn joint_type(kind: Joints) -> u32 {
        match kind {
            Joints::U8 => fixture::UNSIGNED_BYTE,
            Joints::U16 => fixture::UNSIGNED_SHORT,
        }
    }

    fn weight_type(kind: Weights) -> u32 {
        match kind {
            Weights::F32 => fixture::FLOAT,
            Weights::U8 => fixture::UNSIGNED_BYTE,
            Weights::U16 => fixture::UNSIGNED_SHORT,
        }
    }

    /// The stored position of vertex `v`: wrong for the sparse-corrected ones.
    fn stored_position(v: usize, enc: &Encoding) -> [f32; 3] {
        if enc.sparse_positions && SPARSE.contains(&v) {
            [9.0, -9.0, 9.0]
        } else {
            position(v)
        }
    }

    /// Writes POSITION, JOINTS_0 and WEIGHTS_0; returns their accessors.
    fn attributes(b: &mut Builder, enc: &Encoding) -> (usize, usize, usize) {
        // Per vertex: the bytes of [position, joints, weights].
        let rows: Vec<[Vec<u8>; 3]> = (0..VERTICES)
            .map(|v| {
                let (j, w) = influence(v, enc);
                let p = fixture::le_bytes(&stored_position(v, enc));
                [p, joint_bytes(j, enc.joints), weight_bytes(w, enc.weights)]
            })
            .collect();
        let (jt, wt) = (joint_type(enc.joints), weight_type(enc.weights));
        let accessors = if enc.interleaved {
            // One view, one vertex per `stride` bytes: [position | joints | weights].
            let (jn, wn) = (rows[0][1].len(), rows[0][2].len());
            let stride = 12 + jn + wn;
            let bytes: Vec<u8> = rows.iter().flat_map(|r| r.concat()).collect();
            let view = b.view(&bytes, Some(stride));
            let pos = b.accessor(view, 0, fixture::FLOAT, VERTICES, "VEC3");
            let joints = b.accessor(view, 12, jt, VERTICES, "VEC4");
            (pos, joints, b.accessor(view, 12 + jn, wt, VERTICES, "VEC4"))
        } else {
            // One tightly packed view per attribute.
            let column = |b: &mut Builder, k: usize| {
                let bytes: Vec<u8> = rows.iter().flat_map(|r| r[k].clone()).collect();
                b.view(&bytes, None)
            };
            let (pv, jv, wv) = (column(b, 0), column(b, 1), column(b, 2));
            let pos = b.accessor(pv, 0, fixture::FLOAT, VERTICES, "VEC3");
            (
                pos,
                b.accessor(jv, 0, jt, VERTICES, "VEC4"),
                b.accessor(wv, 0, wt, VERTICES, "VEC4"),
            )
        };
        finish_attributes(b, enc, accessors)
    }

    /// Adds min / max (required on POSITION), `normalized` and the sparse correction.
    fn finish_attributes(
        b: &mut Builder,
        enc: &Encoding,
        acc: (usize, usize, usize),
    ) -> (usize, usize, usize) {
        let (lo, hi) = (0..VERTICES).map(position).fold(
            ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]),
            |(lo, hi), p| {
                (
                    std::array::from_fn(|i| lo[i].min(p[i])),
                    std::array::from_fn(|i| hi[i].max(p[i])),
                )
            },
        );
        b.set(acc.0, "min", json!(lo));
        b.set(acc.0, "max", json!(hi));
        if enc.weights != Weights::F32 {
            b.set(acc.2, "normalized", json!(true));
        }
        if enc.sparse_positions {
            // Sparse substitution: values[i] replaces element indices[i] of the base.
            let indices: Vec<u8> = SPARSE
                .iter()
                .flat_map(|&v| (v as u16).to_le_bytes())
                .collect();
            let values: Vec<f32> = SPARSE.iter().flat_map(|&v| position(v)).collect();
            let iv = b.view(&indices, None);
            let vv = b.view(&fixture::le_bytes(&values), None);
            b.set(
                acc.0,
                "sparse",
                json!({
                    "count": SPARSE.len(),
                    "indices": {"bufferView": iv, "componentType": fixture::UNSIGNED_SHORT},
                    "values": {"bufferView": vv},
                }),
            );
        }
        acc
    }

    fn triangles(b: &mut Builder) -> usize {
        let idx: Vec<u16> = (0..(VERTICES / 2 - 1) as u16)
            .flat_map(|l| {
                let (a, c) = (2 * l, 2 * l + 2);
                [a, a + 1, c, a + 1, c + 1, c]
            })
            .collect();
        let view = b.view(
            &idx.iter()
                .flat_map(|i| i.to_le_bytes())
                .collect::<Vec<u8>>(),
            None,
        );
        b.accessor(view, 0, fixture::UNSIGNED_SHORT, idx.len(), "SCALAR")
    }

    /// Joint nodes 1 (root, at the origin), 2 and 3 (each 1 above its parent), bound at
    /// rest. Node 0, the mesh node, is added by [`document`].
    pub fn joints() -> Vec<Value> {
        vec![
            json!({"name": "root", "children": [2]}),
            json!({"name": "mid", "translation": [0.0, 1.0, 0.0], "children": [3]}),
            json!({"name": "tip", "translation": [0.0, 1.0, 0.0]}),
        ]
    }

    /// Two morph targets: the first a dense accessor swelling every level sideways, the second
    /// an accessor without a buffer view (zeros) whose sparse values lift [`MORPHED`].
    fn morph_targets(b: &mut Builder) -> Value {
        let swell: Vec<f32> = (0..VERTICES)
            .flat_map(|v| {
                let out = if v % 2 == 0 { -1.0 } else { 1.0 };
                [0.1 * out * (v / 2) as f32, 0.0, 0.02 * v as f32]
            })
            .collect();
        let dense = b.floats(&swell, "VEC3");
        let indices: Vec<u8> = MORPHED.iter().map(|&v| v as u8).collect();
        let lift: Vec<f32> = MORPHED
            .iter()
            .flat_map(|&v| [0.0, 0.3, 0.05 * v as f32])
            .collect();
        let (iv, vv) = (
            b.view(&indices, None),
            b.view(&fixture::le_bytes(&lift), None),
        );
        let sparse = b.viewless(fixture::FLOAT, VERTICES, "VEC3");
        b.set(
            sparse,
            "sparse",
            json!({
                "count": MORPHED.len(),
                "indices": {"bufferView": iv, "componentType": fixture::UNSIGNED_BYTE},
                "values": {"bufferView": vv},
            }),
        );
        json!([{"POSITION": dense}, {"POSITION": sparse}])
    }

    fn animation(b: &mut Builder, tracks: &[Track]) -> Value {
        let mut samplers = Vec::new();
        let mut channels = Vec::new();
        for (i, t) in tracks.iter().enumerate() {
            let input = b.floats(&t.times, "SCALAR");
            b.set(input, "min", json!([t.times[0]]));
            b.set(input, "max", json!([t.times[t.times.len() - 1]]));
            let ty = match t.path {
                "rotation" => "VEC4",
                "weights" => "SCALAR",
                _ => "VEC3",
            };
            let output = b.floats(&t.values, ty);
            samplers
                .push(json!({"input": input, "output": output, "interpolation": t.interpolation}));
            channels.push(json!({"sampler": i, "target": {"node": t.node, "path": t.path}}));
        }
        json!({"name": "test", "samplers": samplers, "channels": channels})
    }

    /// The full document: node 0 carries the mesh and the skin (with a transform that glTF
    /// says to ignore), `joints` follow from node 1; `tracks` make one animation.
    pub fn document(enc: Encoding, joints: Vec<Value>, tracks: &[Track]) -> Vec<u8> {
        let mut b = Builder::default();
        let (pos, jnt, wgt) = attributes(&mut b, &enc);
        let indices = triangles(&mut b);
        // IBM of joint k: the inverse of its bind pose, a translation by k along y.
        let ibm: Vec<f32> = (0..3)
            .flat_map(|k| {
                [
                    1.,
                    0.,
                    0.,
                    0.,
                    0.,
                    1.,
                    0.,
                    0.,
                    0.,
                    0.,
                    1.,
                    0.,
                    0.,
                    -(k as f32),
                    0.,
                    1.,
                ]
            })
            .collect();
        let ibm = b.floats(&ibm, "MAT4");
        let mut nodes =
            vec![json!({"name": "body", "mesh": 0, "skin": 0, "translation": [5.0, -3.0, 2.0]})];
        nodes.extend(joints);
        let roots = scene_roots(&nodes);
        let mut root = json!({
            "scene": 0,
            "scenes": [{"nodes": roots}],
            "nodes": nodes,
            "meshes": [{"primitives": [{
                "attributes": {"POSITION": pos, "JOINTS_0": jnt, "WEIGHTS_0": wgt},
                "indices": indices,
            }]}],
            "skins": [{"joints": [1, 2, 3], "inverseBindMatrices": ibm}],
        });
        if enc.morphs {
            root["meshes"][0]["primitives"][0]["targets"] = morph_targets(&mut b);
            root["meshes"][0]["weights"] = json!([0.5, -0.25]);
        }
        if !tracks.is_empty() {
            root["animations"] = json!([animation(&mut b, tracks)]);
        }
        b.finish(root)
    }

    /// Nodes that are nobody's child.
    fn scene_roots(nodes: &[Value]) -> Vec<usize> {
        let children: Vec<u64> = nodes
            .iter()
            .filter_map(|n| n["children"].as_array())
            .flatten()
            .filter_map(Value::as_u64)
            .collect();
        (0..nodes.len())
            .filter(|&i| !children.contains(&(i as u64)))
            .collect()
    }

    /// A LINEAR rotation of node 2 (a quarter turn about z) and translation of node 1.
    pub fn default_tracks() -> Vec<Track> {
        let h = std::f32::consts::FRAC_1_SQRT_2;
        vec![
            Track {
                node: 2,
                path: "rotation",
                interpolation: "LINEAR",
                times: vec![0.0, 1.0],
                values: vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, h, h],
            },
            Track {
                node: 1,
                path: "translation",
                interpolation: "LINEAR",
                times: vec![0.0, 0.5, 1.0],
                values: vec![0.0, 0.0, 0.0, 0.3, 0.1, 0.0, 0.0, -0.2, 0.5],
            },
        ]
    }
}

/// Loads an in-memory document with the crate and the reference and requires agreement.
fn check_bytes(label: &str, bytes: &[u8]) -> Outcome {
    let rig = rig::load_from_bytes(Path::new(label), bytes)
        .unwrap_or_else(|e| panic!("{label}: the crate cannot load it: {e}"));
    let out = check_rig(label, &rig, &Reference::from_bytes(bytes, None));
    println!("{label}: {out}");
    assert!(out.max_rel < TOLERANCE, "{label}: {}", out.worst);
    assert_eq!(out.unweighted, 0, "{label}: every vertex is weighted");
    out
}

/// Reference positions of `bytes` at time `t` of its first animation (rest pose without one).
fn reference_pose(bytes: &[u8], t: f64) -> Vec<[f64; 3]> {
    let r = Reference::from_bytes(bytes, None);
    let anim = (!r.animations.is_empty()).then_some(0);
    r.pose(anim, t)
        .concat()
        .into_iter()
        .map(|p| p.expect("weighted"))
        .collect()
}

fn assert_same_poses(a: &[u8], b: &[u8], times: &[f64], what: &str) {
    for &t in times {
        let (pa, pb) = (reference_pose(a, t), reference_pose(b, t));
        for (v, (x, y)) in pa.iter().zip(&pb).enumerate() {
            assert!(
                distance(*x, *y) < 1e-9,
                "{what}: t = {t}, vertex {v}: {x:?} vs {y:?}"
            );
        }
    }
}

#[test]
fn reference_math_matches_hand_values() {
    let h = std::f64::consts::FRAC_1_SQRT_2;
    // Halfway between identity and a quarter turn about z: an eighth turn.
    let q = math::slerp([0.0, 0.0, 0.0, 1.0], [0.0, 0.0, h, h], 0.5);
    let eighth = (std::f64::consts::PI / 8.0).sin_cos();
    assert!(distance([q[2], q[3], q[0]], [eighth.0, eighth.1, 0.0]) < 1e-15);
    // The shorter arc: -b is the same rotation as b.
    let q2 = math::slerp([0.0, 0.0, 0.0, 1.0], [0.0, 0.0, -h, -h], 0.5);
    assert!(math::dot(q, q2) > 1.0 - 1e-15);
    // Hermite with zero tangents is the smoothstep 3s² - 2s³.
    let p = math::hermite(&[0.0], &[0.0], &[1.0], &[0.0], 2.0, 0.25);
    assert!((p[0] - (3.0 * 0.0625 - 2.0 * 0.015625)).abs() < 1e-15);
    // Tangents are per second: a unit out-tangent over a 2 s interval, at s = 1/2, adds
    // td · (s³ - 2s² + s) = 2 · 0.125.
    let p = math::hermite(&[0.0], &[1.0], &[0.0], &[0.0], 2.0, 0.5);
    assert!((p[0] - 0.25).abs() < 1e-15);
    // T · R · S applied to x: scaled by 2, turned a quarter about z, moved by (1, 2, 3).
    let m = math::trs([1.0, 2.0, 3.0], [0.0, 0.0, h, h], [2.0, 5.0, 7.0]);
    assert!(distance(math::apply(&m, [1.0, 0.0, 0.0]), [1.0, 4.0, 3.0]) < 1e-15);
}

#[test]
fn cubicspline_rotation_channel() {
    use strip::Track;
    // Keys [in-tangent, value, out-tangent]; tangents are deliberately not zero.
    let rot = |a: f32, tan: f32| {
        let (s, c) = (a / 2.0).sin_cos();
        vec![
            tan,
            0.0,
            -tan,
            0.5 * tan,
            s,
            0.0,
            0.0,
            c,
            -tan,
            tan,
            0.0,
            0.2 * tan,
        ]
    };
    let tracks = vec![
        Track {
            node: 2,
            path: "rotation",
            interpolation: "CUBICSPLINE",
            times: vec![0.0, 0.8, 2.0],
            values: [rot(0.0, 0.3), rot(1.2, -0.5), rot(-0.7, 0.8)].concat(),
        },
        Track {
            node: 3,
            path: "translation",
            interpolation: "CUBICSPLINE",
            times: vec![0.2, 1.0],
            values: vec![
                0., 0., 0., 0., 1., 0., 1., 0., 2., //
                0., -3., 0., 0.4, 1.2, 0.1, 0., 0., 0.,
            ],
        },
    ];
    let bytes = strip::document(strip::Encoding::default(), strip::joints(), &tracks);
    let out = check_bytes("cubicspline.gltf", &bytes);
    assert!(out.frames > 60);
}

#[test]
fn step_channels() {
    use strip::Track;
    let h = std::f32::consts::FRAC_1_SQRT_2;
    let tracks = vec![
        Track {
            node: 2,
            path: "rotation",
            interpolation: "STEP",
            times: vec![0.0, 0.5, 1.5],
            values: vec![0., 0., 0., 1., 0., 0., h, h, h, 0., 0., h],
        },
        Track {
            node: 3,
            path: "translation",
            interpolation: "STEP",
            times: vec![0.25, 1.0],
            values: vec![0., 1., 0., 0.5, 1.5, -0.5],
        },
        Track {
            node: 1,
            path: "scale",
            interpolation: "STEP",
            times: vec![0.0, 0.75],
            values: vec![1., 1., 1., 1.5, 0.5, 2.0],
        },
    ];
    let bytes = strip::document(strip::Encoding::default(), strip::joints(), &tracks);
    check_bytes("step.gltf", &bytes);
    // STEP holds each key until the next one.
    assert_eq!(reference_pose(&bytes, 0.26), reference_pose(&bytes, 0.49));
    assert_ne!(reference_pose(&bytes, 0.49), reference_pose(&bytes, 0.5));
}

#[test]
fn node_with_matrix() {
    let mut joints = strip::joints();
    // Root joint: a quarter turn about z, then a move by +1 along x (column-major).
    joints[0]["matrix"] =
        serde_json::json!([0., 1., 0., 0., -1., 0., 0., 0., 0., 0., 1., 0., 1., 0., 0., 1.]);
    // An armature parent: scale (2, 3, 4) and a move by +1 along z.
    joints.push(serde_json::json!({
        "name": "armature", "children": [1],
        "matrix": [2., 0., 0., 0., 0., 3., 0., 0., 0., 0., 4., 0., 0., 0., 1., 1.],
    }));
    // Only node 2 is animated: glTF forbids animating a node given by `matrix`.
    let mut tracks = strip::default_tracks();
    tracks.retain(|t| t.node == 2);
    let bytes = strip::document(strip::Encoding::default(), joints, &tracks);
    check_bytes("matrix.gltf", &bytes);
    // By hand: vertices 0 and 1, (∓0.25, 0, 0), follow the root joint only (IBM = identity):
    // turned to (0, ∓0.25, 0), moved to (1, ∓0.25, 0), scaled and moved to (2, ∓0.75, 1).
    let rig = rig::load_from_bytes(Path::new("matrix.gltf"), &bytes).expect("loads");
    let pre = Precomputed::new(&rig, Method::Lbs);
    let rest = frames::evaluate(&rig, &pre, None, 0, 0.0);
    for (v, want) in [(0, [2.0, -0.75, 1.0]), (1, [2.0, 0.75, 1.0])] {
        let p = rest.bodies[0].positions[v];
        assert!(distance([p.x, p.y, p.z], want) < 1e-6, "vertex {v}: {p:?}");
        let r = reference_pose(&bytes, -1.0)[v];
        assert!(distance(r, want) < 1e-6, "reference vertex {v}: {r:?}");
    }
}

#[test]
fn nested_joints_with_non_uniform_scale() {
    use strip::Track;
    let mut joints = strip::joints();
    let (s, c) = (15f32.to_radians().sin(), 15f32.to_radians().cos());
    joints[0]["rotation"] = serde_json::json!([s, 0.0, 0.0, c]);
    joints[0]["scale"] = serde_json::json!([2.0, 0.5, 1.0]);
    joints[1]["scale"] = serde_json::json!([1.0, 3.0, 0.5]);
    // Axis (1, 1, 0)/√2 at 0°, 120° and 250°; the last key is negated, so that the shorter
    // arc needs the sign flip.
    let k = std::f32::consts::FRAC_1_SQRT_2;
    let axis_angle = |deg: f32, sign: f32| {
        let (s, c) = (deg.to_radians() / 2.0).sin_cos();
        [k * s, k * s, 0.0, c].map(|x| sign * x)
    };
    let tracks = vec![
        Track {
            node: 2,
            path: "rotation",
            interpolation: "LINEAR",
            times: vec![0.0, 0.6, 1.4],
            values: [
                axis_angle(0.0, 1.0),
                axis_angle(120.0, 1.0),
                axis_angle(250.0, -1.0),
            ]
            .concat(),
        },
        Track {
            node: 3,
            path: "scale",
            interpolation: "LINEAR",
            times: vec![0.0, 1.4],
            values: vec![1.0, 1.0, 1.0, 0.5, 2.0, 1.5],
        },
    ];
    let bytes = strip::document(strip::Encoding::default(), joints, &tracks);
    check_bytes("nonuniform.gltf", &bytes);
}

#[test]
fn weights_not_summing_to_one_are_renormalized() {
    let tracks = strip::default_tracks();
    let enc = strip::Encoding {
        unnormalized: true,
        ..strip::Encoding::default()
    };
    let bytes = strip::document(enc, strip::joints(), &tracks);
    check_bytes("unnormalized.gltf", &bytes);
    let plain = strip::document(strip::Encoding::default(), strip::joints(), &tracks);
    assert_same_poses(
        &bytes,
        &plain,
        &[0.0, 0.3, 0.75, 1.0],
        "renormalized weights",
    );
}

#[test]
fn u8_joints_and_normalized_integer_weights() {
    use strip::{Joints, Weights};
    let cases = [
        (Joints::U8, Weights::U8),
        (Joints::U8, Weights::U16),
        (Joints::U16, Weights::U8),
        (Joints::U8, Weights::F32),
    ];
    for (joints, weights) in cases {
        let enc = strip::Encoding {
            joints,
            weights,
            ..strip::Encoding::default()
        };
        let bytes = strip::document(enc, strip::joints(), &strip::default_tracks());
        check_bytes(
            &format!("joints-{joints:?}-weights-{weights:?}.gltf"),
            &bytes,
        );
    }
}

#[test]
fn sparse_accessor_on_position() {
    let enc = strip::Encoding {
        sparse_positions: true,
        ..strip::Encoding::default()
    };
    let tracks = strip::default_tracks();
    let bytes = strip::document(enc, strip::joints(), &tracks);
    check_bytes("sparse.gltf", &bytes);
    let plain = strip::document(strip::Encoding::default(), strip::joints(), &tracks);
    assert_same_poses(&bytes, &plain, &[0.0, 0.6], "sparse POSITION");
}

#[test]
fn interleaved_vertex_buffer() {
    use strip::{Joints, Weights};
    let tracks = strip::default_tracks();
    let plain = strip::document(strip::Encoding::default(), strip::joints(), &tracks);
    for (joints, weights) in [(Joints::U16, Weights::F32), (Joints::U8, Weights::U8)] {
        let enc = strip::Encoding {
            joints,
            weights,
            interleaved: true,
            ..strip::Encoding::default()
        };
        let bytes = strip::document(enc, strip::joints(), &tracks);
        check_bytes(&format!("interleaved-{joints:?}-{weights:?}.gltf"), &bytes);
        if weights == Weights::F32 {
            assert_same_poses(&bytes, &plain, &[0.0, 0.6], "interleaved");
        }
    }
}

/// The strip with [`strip::Encoding::morphs`] and the skeleton's tracks plus `extra`.
fn morphed_strip(extra: Vec<strip::Track>, skeleton_moves: bool) -> Vec<u8> {
    let enc = strip::Encoding {
        morphs: true,
        ..strip::Encoding::default()
    };
    let mut tracks = if skeleton_moves {
        strip::default_tracks()
    } else {
        Vec::new()
    };
    tracks.extend(extra);
    strip::document(enc, strip::joints(), &tracks)
}

/// Vertex 3 (bind position (0.25, 0.5, -0.05)) morphed by the weights `w` of the strip's two
/// targets, which move it by (0.1, 0, 0.06) and (0, 0.3, 0.15), by hand.
fn vertex_3_morphed(w: [f64; 2]) -> [f64; 3] {
    [
        0.25 + 0.1 * w[0],
        0.5 + 0.3 * w[1],
        -0.05 + 0.06 * w[0] + 0.15 * w[1],
    ]
}

/// The crate's position of vertex 3 at time `t` of the first animation (rest pose without one).
fn crate_vertex_3(bytes: &[u8], t: f64) -> [f64; 3] {
    let rig = rig::load_from_bytes(Path::new("morphs.gltf"), bytes).expect("the crate loads it");
    let pre = Precomputed::new(&rig, Method::Lbs);
    let animation = (!rig.animations.is_empty()).then_some(0);
    let p = frames::evaluate(&rig, &pre, animation, 0, t).bodies[0].positions[3];
    [p.x, p.y, p.z]
}

/// Morph targets (glTF 2.0 §3.7.2.2), a dense one and a sparse one without a buffer view, at
/// the mesh's default weights (0.5, -0.25): the crate agrees with the reference on every frame
/// of the skeleton's animation, and at the rest pose (the bind pose: skinning is the identity)
/// vertex 3 is its bind position plus the weighted displacements, by hand.
#[test]
fn morph_targets_at_the_default_weights() {
    let bytes = morphed_strip(Vec::new(), true);
    check_bytes("morphs-default-weights.gltf", &bytes);
    let at_rest = crate_vertex_3(&morphed_strip(Vec::new(), false), 0.0);
    let want = vertex_3_morphed([0.5, -0.25]);
    assert!(distance(at_rest, want) < 1e-6, "{at_rest:?} vs {want:?}");
    // The targets move the surface: the plain strip's poses differ.
    let plain = strip::document(
        strip::Encoding::default(),
        strip::joints(),
        &strip::default_tracks(),
    );
    let (a, b) = (reference_pose(&bytes, 0.6), reference_pose(&plain, 0.6));
    assert!(distance(a[3], b[3]) > 0.05, "{:?} vs {:?}", a[3], b[3]);
}

/// DQS and CoR skin the morphed shape too: at the bind pose (every skinning the identity)
/// each method gives the bind positions plus the weighted displacements.
#[test]
fn every_skinning_reads_the_morphed_shape() {
    let bytes = morphed_strip(Vec::new(), false);
    let rig = rig::load_from_bytes(Path::new("morphs.gltf"), &bytes).expect("loads");
    let lbs = frames::evaluate(&rig, &Precomputed::new(&rig, Method::Lbs), None, 0, 0.0);
    for method in [Method::Dqs, Method::Cor] {
        let posed = frames::evaluate(&rig, &Precomputed::new(&rig, method), None, 0, 0.0);
        let p = posed.bodies[0].positions[3];
        let want = vertex_3_morphed([0.5, -0.25]);
        assert!(
            distance([p.x, p.y, p.z], want) < 1e-6,
            "{method}: {p} vs {want:?}"
        );
        for (a, b) in posed.bodies[0]
            .positions
            .iter()
            .zip(&lbs.bodies[0].positions)
        {
            assert!((a - b).norm() < 1e-9, "{method}: {a} vs LBS {b}");
        }
    }
}

/// A node's `weights` override its mesh's (glTF 2.0 §3.7.2.2).
#[test]
fn node_weights_override_the_mesh_weights() {
    let bytes = morphed_strip(Vec::new(), false);
    let mut doc: serde_json::Value = serde_json::from_slice(&bytes).expect("JSON");
    doc["nodes"][0]["weights"] = serde_json::json!([1.0, 1.0]);
    let bytes = serde_json::to_vec(&doc).expect("JSON");
    check_bytes("morphs-node-weights.gltf", &bytes);
    let got = crate_vertex_3(&bytes, 0.0);
    let want = vertex_3_morphed([1.0, 1.0]);
    assert!(distance(got, want) < 1e-6, "{got:?} vs {want:?}");
}

/// Animated morph weights, sampled LINEAR, STEP and CUBICSPLINE (with tangents), alongside the
/// skeleton's tracks: the crate agrees with the reference on every frame; and without the
/// skeleton's tracks, LINEAR weights halfway between keys (0, 0) and (1, 0.5) give vertex 3's
/// position at (0.5, 0.25), by hand.
#[test]
fn morph_weight_channels() {
    let weights = |interpolation: &'static str| {
        let values = if interpolation == "CUBICSPLINE" {
            // Per key: in-tangents, values, out-tangents (2 weights each).
            vec![
                0.0, 0.0, 0.0, 0.0, 1.0, 0.3, //
                0.5, -0.5, 1.0, 0.5, -2.0, 0.7, //
                0.1, 0.1, 0.2, -1.0, 0.0, 0.0,
            ]
        } else {
            vec![0.0, 0.0, 1.0, 0.5, 0.2, -1.0]
        };
        strip::Track {
            node: 0,
            path: "weights",
            interpolation,
            times: vec![0.0, 0.4, 1.0],
            values,
        }
    };
    for interpolation in ["LINEAR", "STEP", "CUBICSPLINE"] {
        let bytes = morphed_strip(vec![weights(interpolation)], true);
        check_bytes(&format!("morph-weights-{interpolation}.gltf"), &bytes);
    }
    let bytes = morphed_strip(vec![weights("LINEAR")], false);
    let got = crate_vertex_3(&bytes, 0.2);
    let want = vertex_3_morphed([0.5, 0.25]);
    assert!(distance(got, want) < 1e-6, "{got:?} vs {want:?}");
}
