//! Renders OBJ frames written by `contact-skin pose` side by side into a PNG: an orthographic,
//! flat-shaded z-buffer rasterizer, enough for the README's pictures and for looking at results
//! on a machine without a viewer.
//!
//! ```text
//! cargo run --release --example render -- OUT.png [--view X,Y,Z] [--size PIXELS] [--columns N] A.obj B.obj ...
//! ```
//! Every panel shares one camera and scale, so the panels compare directly. Objects (`o` lines)
//! get distinct colours.

use nalgebra::{Point3, Vector3};
use std::error::Error;

struct Mesh {
    vertices: Vec<Point3<f64>>,
    faces: Vec<([usize; 3], usize)>,
}

fn read_obj(path: &str) -> Result<Mesh, Box<dyn Error>> {
    let text = std::fs::read_to_string(path)?;
    let (mut vertices, mut faces, mut object) = (Vec::new(), Vec::new(), 0usize);
    let mut seen_object = false;
    for line in text.lines() {
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let c: Vec<f64> = it.take(3).map(str::parse).collect::<Result<_, _>>()?;
                vertices.push(Point3::new(c[0], c[1], c[2]));
            }
            Some("o") => {
                object += usize::from(seen_object);
                seen_object = true;
            }
            Some("f") => {
                let idx: Vec<usize> = it
                    .map(|t| t.split('/').next().unwrap_or("0").parse::<usize>())
                    .collect::<Result<_, _>>()?;
                for k in 1..idx.len().saturating_sub(1) {
                    faces.push(([idx[0] - 1, idx[k] - 1, idx[k + 1] - 1], object));
                }
            }
            _ => {}
        }
    }
    Ok(Mesh { vertices, faces })
}

const COLORS: [[f64; 3]; 6] = [
    [0.85, 0.55, 0.45],
    [0.45, 0.65, 0.85],
    [0.55, 0.8, 0.5],
    [0.85, 0.75, 0.4],
    [0.7, 0.55, 0.85],
    [0.6, 0.6, 0.6],
];

struct Camera {
    right: Vector3<f64>,
    up: Vector3<f64>,
    forward: Vector3<f64>,
    center: Point3<f64>,
    scale: f64,
    size: usize,
}

impl Camera {
    fn new(meshes: &[Mesh], view: Vector3<f64>, size: usize) -> Self {
        let forward = -view.normalize();
        let world_up = if forward.y.abs() > 0.9 {
            Vector3::z()
        } else {
            Vector3::y()
        };
        let right = forward.cross(&world_up).normalize();
        let up = right.cross(&forward);
        let all = meshes.iter().flat_map(|m| m.vertices.iter());
        let (mut lo, mut hi) = (
            Vector3::repeat(f64::INFINITY),
            Vector3::repeat(f64::NEG_INFINITY),
        );
        for p in all {
            lo = lo.inf(&p.coords);
            hi = hi.sup(&p.coords);
        }
        let center = Point3::from((lo + hi) * 0.5);
        let mut extent: f64 = 1e-9;
        for m in meshes {
            for p in &m.vertices {
                let d = p - center;
                extent = extent.max(d.dot(&right).abs()).max(d.dot(&up).abs());
            }
        }
        Self {
            right,
            up,
            forward,
            center,
            scale: 0.45 * size as f64 / extent,
            size,
        }
    }

    fn project(&self, p: &Point3<f64>) -> [f64; 3] {
        let d = p - self.center;
        let half = self.size as f64 * 0.5;
        [
            half + d.dot(&self.right) * self.scale,
            half - d.dot(&self.up) * self.scale,
            d.dot(&self.forward),
        ]
    }
}

fn render_panel(mesh: &Mesh, cam: &Camera, image: &mut [u8], width: usize, origin: (usize, usize)) {
    let (x0, y0) = origin;
    let n = cam.size;
    let mut depth = vec![f64::INFINITY; n * n];
    let light = (-cam.forward + cam.up * 0.6 + cam.right * 0.3).normalize();
    for &(f, object) in &mesh.faces {
        let [a, b, c] = f.map(|i| mesh.vertices[i]);
        let normal = (b - a).cross(&(c - a));
        let Some(normal) = normal.try_normalize(1e-300) else {
            continue;
        };
        let shade = 0.25 + 0.75 * normal.dot(&light).abs();
        let color = COLORS[object % COLORS.len()].map(|c| (c * shade * 255.0).min(255.0) as u8);
        let [pa, pb, pc] = [a, b, c].map(|p| cam.project(&p));
        let area = (pb[0] - pa[0]) * (pc[1] - pa[1]) - (pb[1] - pa[1]) * (pc[0] - pa[0]);
        if area.abs() < 1e-12 {
            continue;
        }
        let xmin = pa[0].min(pb[0]).min(pc[0]).floor().max(0.0) as usize;
        let xmax = (pa[0].max(pb[0]).max(pc[0]).ceil() as usize).min(n - 1);
        let ymin = pa[1].min(pb[1]).min(pc[1]).floor().max(0.0) as usize;
        let ymax = (pa[1].max(pb[1]).max(pc[1]).ceil() as usize).min(n - 1);
        for y in ymin..=ymax {
            for x in xmin..=xmax {
                let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                let w0 = ((pb[0] - px) * (pc[1] - py) - (pb[1] - py) * (pc[0] - px)) / area;
                let w1 = ((pc[0] - px) * (pa[1] - py) - (pc[1] - py) * (pa[0] - px)) / area;
                let w2 = 1.0 - w0 - w1;
                if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                    continue;
                }
                let z = w0 * pa[2] + w1 * pb[2] + w2 * pc[2];
                if z < depth[y * n + x] {
                    depth[y * n + x] = z;
                    let at = 3 * ((y0 + y) * width + x0 + x);
                    image[at..at + 3].copy_from_slice(&color);
                }
            }
        }
    }
}

fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let out = args
        .first()
        .ok_or("usage: render OUT.png [--view X,Y,Z] [--size N] A.obj ...")?
        .clone();
    let (mut view, mut size, mut inputs) = (Vector3::new(0.0, 0.0, 1.0), 400usize, Vec::new());
    let mut columns = usize::MAX;
    let mut i = 1;
    while i < args.len() {
        match args[i].as_str() {
            "--view" => {
                let v: Vec<f64> = args
                    .get(i + 1)
                    .ok_or("--view X,Y,Z")?
                    .split(',')
                    .map(str::parse)
                    .collect::<Result<_, _>>()?;
                view = Vector3::new(v[0], v[1], v[2]);
                i += 1;
            }
            "--columns" => {
                columns = args
                    .get(i + 1)
                    .ok_or("--columns N")?
                    .parse::<usize>()?
                    .max(1);
                i += 1;
            }
            "--size" => {
                size = args.get(i + 1).ok_or("--size N")?.parse()?;
                i += 1;
            }
            path => inputs.push(read_obj(path)?),
        }
        i += 1;
    }
    if inputs.is_empty() {
        return Err("no OBJ given".into());
    }
    let cam = Camera::new(&inputs, view, size);
    let columns = columns.min(inputs.len());
    let rows = inputs.len().div_ceil(columns);
    let (width, height) = (size * columns, size * rows);
    let mut image = vec![255u8; width * height * 3];
    for (k, mesh) in inputs.iter().enumerate() {
        render_panel(
            mesh,
            &cam,
            &mut image,
            width,
            ((k % columns) * size, (k / columns) * size),
        );
    }
    let file = std::io::BufWriter::new(std::fs::File::create(&out)?);
    let mut encoder = png::Encoder::new(file, width as u32, height as u32);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.write_header()?.write_image_data(&image)?;
    println!("wrote {out} ({} panels, {width}x{height})", inputs.len());
    Ok(())
}
