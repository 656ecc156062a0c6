//! Procedural identities for the built-in body: shape coefficients, skin tone, hair, clothing
//! (top with or without sleeves, trousers or shorts, shoes, solid/striped/checked fabric) and a
//! face (eyes, brows, mouth), baked into a texture in the body's UV atlas. Colours are functions
//! of the rest-pose surface point, so patterns are continuous across UV seams.

use super::rng::Rng;
use crate::image_io::hsv;
use crate::render::Texture;
use splatzoo_models::body::BuiltinBody;
use splatzoo_models::body::builtin::SHAPE_COUNT;

/// Linear-RGB skin albedos from light to dark.
const SKIN_TONES: [[f32; 3]; 6] = [
    [0.80, 0.56, 0.45],
    [0.70, 0.46, 0.34],
    [0.58, 0.36, 0.24],
    [0.45, 0.27, 0.17],
    [0.30, 0.17, 0.10],
    [0.17, 0.10, 0.06],
];

const HAIR_COLOURS: [[f32; 3]; 5] = [
    [0.02, 0.015, 0.01],
    [0.08, 0.04, 0.02],
    [0.25, 0.13, 0.05],
    [0.55, 0.40, 0.20],
    [0.45, 0.45, 0.45],
];

#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Fabric {
    Solid,
    /// Horizontal stripes of the second colour, `period` metres apart.
    Stripes {
        other: [f32; 3],
        period: f64,
    },
    /// Checks of the second colour, `period` metres square.
    Checks {
        other: [f32; 3],
        period: f64,
    },
}

#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Garment {
    pub colour: [f32; 3],
    pub fabric: Fabric,
}

#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Identity {
    /// Shape coefficients for the built-in body.
    pub betas: Vec<f64>,
    pub skin: [f32; 3],
    pub hair: [f32; 3],
    /// Hair reaching down the back of the head to this height (rest pose, metres); above the
    /// brow only for short hair.
    pub hair_length: f64,
    pub top: Garment,
    pub long_sleeves: bool,
    pub bottom: Garment,
    pub trousers: bool,
    pub shoes: [f32; 3],
}

fn colour(rng: &mut Rng) -> [f32; 3] {
    let hue = rng.next();
    let saturation = rng.range(0.2, 0.85);
    hsv(hue, saturation, rng.range(0.15, 0.85))
}

/// A muted colour of random hue with value in [lo, hi] (walls, furniture, facades).
pub(crate) fn colour_between(rng: &mut Rng, lo: f64, hi: f64) -> [f32; 3] {
    let hue = rng.next();
    let saturation = rng.range(0.1, 0.5);
    hsv(hue, saturation, rng.range(lo, hi))
}

fn garment(rng: &mut Rng) -> Garment {
    let base = colour(rng);
    let fabric = match (rng.next() * 3.0) as u32 {
        0 => Fabric::Solid,
        1 => Fabric::Stripes {
            other: colour(rng),
            period: rng.range(0.02, 0.08),
        },
        _ => Fabric::Checks {
            other: colour(rng),
            period: rng.range(0.03, 0.09),
        },
    };
    Garment {
        colour: base,
        fabric,
    }
}

impl Identity {
    /// The identity of `seed`.
    pub fn sample(seed: u64) -> Self {
        let mut rng = Rng(seed ^ 0x005E_ED1D);
        let betas = (0..SHAPE_COUNT).map(|_| 0.8 * rng.normal()).collect();
        let skin = rng.pick(&SKIN_TONES);
        let skin = skin.map(|c| (c as f64 * rng.range(0.92, 1.08)) as f32);
        Self {
            betas,
            skin,
            hair: rng.pick(&HAIR_COLOURS),
            hair_length: rng.range(0.30, 0.47),
            top: garment(&mut rng),
            long_sleeves: rng.next() < 0.5,
            bottom: garment(&mut rng),
            trousers: rng.next() < 0.7,
            shoes: colour(&mut rng).map(|c| c * 0.5),
        }
    }

    fn garment_at(g: &Garment, p: [f64; 3]) -> [f32; 3] {
        let cell = |v: f64, period: f64| (v / period).floor() as i64;
        match g.fabric {
            Fabric::Solid => g.colour,
            Fabric::Stripes { other, period } => {
                if cell(p[1], period).rem_euclid(2) == 0 {
                    g.colour
                } else {
                    other
                }
            }
            Fabric::Checks { other, period } => {
                let k = cell(p[0], period) + cell(p[1], period) + cell(p[2], period);
                if k.rem_euclid(2) == 0 {
                    g.colour
                } else {
                    other
                }
            }
        }
    }

    /// Albedo of the rest-pose surface point `p` on the bone `part` of `body`.
    pub fn albedo_at(&self, body: &BuiltinBody, part: u8, p: [f64; 3]) -> [f32; 3] {
        let landmark = |name: &str| {
            let v = body.landmark(name).expect("built-in landmark") as usize;
            let t = &body.model.template;
            [t[3 * v] as f64, t[3 * v + 1] as f64, t[3 * v + 2] as f64]
        };
        let dist = |a: [f64; 3], b: [f64; 3]| {
            ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
        };
        match part {
            15 => {
                for eye in ["left_eye", "right_eye"] {
                    let e = landmark(eye);
                    let d = dist(p, e);
                    if d < 0.006 {
                        return [0.03, 0.025, 0.02];
                    }
                    if d < 0.012 {
                        return [0.75, 0.75, 0.72];
                    }
                    let brow = [e[0], e[1] + 0.02, e[2]];
                    if (p[1] - brow[1]).abs() < 0.004
                        && (p[0] - brow[0]).abs() < 0.016
                        && p[2] > brow[2] - 0.03
                    {
                        return self.hair.map(|c| c * 0.8);
                    }
                }
                let m = landmark("mouth");
                if ((p[0] - m[0]) / 0.022).powi(2) + ((p[1] - m[1]) / 0.006).powi(2) < 1.0
                    && p[2] > m[2] - 0.03
                {
                    return [0.45, 0.12, 0.10];
                }
                let front = p[2] > 0.06 && p[1] < 0.47 && p[0].abs() < 0.07;
                let hair = p[1] > 0.47 || (!front && p[1] > self.hair_length && p[2] < 0.07);
                if hair { self.hair } else { self.skin }
            }
            12 => {
                if self.hair_length < 0.34 && p[2] < -0.02 {
                    self.hair
                } else {
                    self.skin
                }
            }
            20..=23 => self.skin,
            7 | 8 | 10 | 11 => self.shoes,
            16 | 17 => Self::garment_at(&self.top, p),
            18 | 19 => {
                if self.long_sleeves {
                    Self::garment_at(&self.top, p)
                } else {
                    self.skin
                }
            }
            1 | 2 => Self::garment_at(&self.bottom, p),
            4 | 5 => {
                if self.trousers || p[1] > -0.62 {
                    Self::garment_at(&self.bottom, p)
                } else {
                    self.skin
                }
            }
            0 if p[1] < -0.16 => Self::garment_at(&self.bottom, p),
            _ => Self::garment_at(&self.top, p),
        }
    }

    /// The identity painted into a `size`² texture in the built-in body's UV atlas. Texels no
    /// triangle covers are filled from their neighbours so bilinear lookups at chart borders do
    /// not pick up the background.
    pub fn bake_texture(&self, body: &BuiltinBody, size: usize) -> Texture {
        let t = &body.model.template;
        let vertex = |v: u32| {
            let v = v as usize;
            [t[3 * v] as f64, t[3 * v + 1] as f64, t[3 * v + 2] as f64]
        };
        let mut texels = vec![[0.0f32; 3]; size * size];
        let mut painted = vec![false; size * size];
        for (f, face) in body.model.faces.chunks(3).enumerate() {
            let labels = [0, 1, 2].map(|k| body.part_of_vertex[face[k] as usize]);
            let part = if labels[1] == labels[2] {
                labels[1]
            } else {
                labels[0]
            };
            let corners: [[f64; 2]; 3] = std::array::from_fn(|k| {
                let c = body.uv.faces[3 * f + k] as usize;
                [
                    body.uv.coords[2 * c] as f64 * size as f64,
                    (1.0 - body.uv.coords[2 * c + 1] as f64) * size as f64,
                ]
            });
            let positions = [0, 1, 2].map(|k| vertex(face[k]));
            let [a, b, c] = corners;
            let area = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
            if area.abs() < 1e-12 {
                continue;
            }
            let x0 = corners
                .iter()
                .map(|p| p[0])
                .fold(f64::MAX, f64::min)
                .floor()
                .max(0.0) as usize;
            let x1 =
                (corners.iter().map(|p| p[0]).fold(f64::MIN, f64::max).ceil() as usize).min(size);
            let y0 = corners
                .iter()
                .map(|p| p[1])
                .fold(f64::MAX, f64::min)
                .floor()
                .max(0.0) as usize;
            let y1 =
                (corners.iter().map(|p| p[1]).fold(f64::MIN, f64::max).ceil() as usize).min(size);
            for y in y0..y1 {
                for x in x0..x1 {
                    let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                    let edge = |p: [f64; 2], q: [f64; 2]| {
                        (q[0] - p[0]) * (py - p[1]) - (q[1] - p[1]) * (px - p[0])
                    };
                    let l = [edge(b, c) / area, edge(c, a) / area, edge(a, b) / area];
                    if l.iter().any(|&w| w < -1e-9) {
                        continue;
                    }
                    let p: [f64; 3] = std::array::from_fn(|k| {
                        l[0] * positions[0][k] + l[1] * positions[1][k] + l[2] * positions[2][k]
                    });
                    texels[y * size + x] = self.albedo_at(body, part, p);
                    painted[y * size + x] = true;
                }
            }
        }
        // Dilate painted texels outwards a few rings.
        for _ in 0..4 {
            let before = painted.clone();
            let source = texels.clone();
            for y in 0..size {
                for x in 0..size {
                    if before[y * size + x] {
                        continue;
                    }
                    let mut sum = [0.0f32; 3];
                    let mut n = 0;
                    for (dx, dy) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
                        let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                        if nx >= 0
                            && ny >= 0
                            && (nx as usize) < size
                            && (ny as usize) < size
                            && before[ny as usize * size + nx as usize]
                        {
                            let s = source[ny as usize * size + nx as usize];
                            for k in 0..3 {
                                sum[k] += s[k];
                            }
                            n += 1;
                        }
                    }
                    if n > 0 {
                        texels[y * size + x] = sum.map(|s| s / n as f32);
                        painted[y * size + x] = true;
                    }
                }
            }
        }
        Texture {
            width: size,
            height: size,
            texels,
            repeat: false,
        }
    }
}
