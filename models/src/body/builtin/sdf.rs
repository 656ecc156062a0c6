//! Signed distance primitives and their smooth union: the implicit surface the built-in body is
//! meshed from. Each primitive carries the skeleton joints it may be skinned to and a target edge
//! length, so the mesher can put detail where the body has it (face, hands) and not elsewhere.

pub type V3 = [f64; 3];

pub fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
pub fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
pub fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
pub fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}
pub fn normalize(a: V3) -> V3 {
    let n = norm(a);
    if n > 0.0 { scale(a, 1.0 / n) } else { a }
}

/// A solid's shape.
#[derive(Debug, Clone, Copy)]
pub enum Solid {
    /// Axis-aligned ellipsoid.
    Ellipsoid { centre: V3, radii: V3 },
    /// A cone between two spheres (a capsule when the radii match).
    RoundCone { a: V3, b: V3, ra: f64, rb: f64 },
}

impl Solid {
    /// Signed distance (exact for the round cone; the usual first-order bound for ellipsoids).
    pub fn distance(&self, p: V3) -> f64 {
        match *self {
            Solid::Ellipsoid { centre, radii } => {
                let q = sub(p, centre);
                let k0 = norm([q[0] / radii[0], q[1] / radii[1], q[2] / radii[2]]);
                let k1 = norm([
                    q[0] / (radii[0] * radii[0]),
                    q[1] / (radii[1] * radii[1]),
                    q[2] / (radii[2] * radii[2]),
                ]);
                if k1 == 0.0 {
                    -radii[0].min(radii[1]).min(radii[2])
                } else {
                    k0 * (k0 - 1.0) / k1
                }
            }
            Solid::RoundCone { a, b, ra, rb } => round_cone(p, a, b, ra, rb),
        }
    }

    /// Axis-aligned bounds, grown by `margin`.
    pub fn bounds(&self, margin: f64) -> (V3, V3) {
        match *self {
            Solid::Ellipsoid { centre, radii } => (
                sub(centre, add(radii, [margin; 3])),
                add(centre, add(radii, [margin; 3])),
            ),
            Solid::RoundCone { a, b, ra, rb } => {
                let r = ra.max(rb) + margin;
                let lo = [a[0].min(b[0]) - r, a[1].min(b[1]) - r, a[2].min(b[2]) - r];
                let hi = [a[0].max(b[0]) + r, a[1].max(b[1]) + r, a[2].max(b[2]) + r];
                (lo, hi)
            }
        }
    }
}

/// Exact distance to the convex hull of spheres (a, ra) and (b, rb).
fn round_cone(p: V3, a: V3, b: V3, ra: f64, rb: f64) -> f64 {
    let ba = sub(b, a);
    let l2 = dot(ba, ba);
    let rr = ra - rb;
    let a2 = l2 - rr * rr;
    let il2 = 1.0 / l2;
    let pa = sub(p, a);
    let y = dot(pa, ba);
    let z = y - l2;
    let xv = sub(scale(pa, l2), scale(ba, y));
    let x2 = dot(xv, xv);
    let y2 = y * y * l2;
    let z2 = z * z * l2;
    let k = rr.signum() * rr * rr * x2;
    if z.signum() * a2 * z2 > k {
        return (x2 + z2).sqrt() * il2 - rb;
    }
    if y.signum() * a2 * y2 < k {
        return (x2 + y2).sqrt() * il2 - ra;
    }
    ((x2 * a2 * il2).sqrt() + y * rr) * il2 - ra
}

/// One primitive of the body.
#[derive(Debug, Clone)]
pub struct Primitive {
    pub solid: Solid,
    /// Joints whose bones may own this primitive's surface (nearest bone wins).
    pub joints: Vec<usize>,
    /// Edge length wanted on this primitive's surface, metres.
    pub edge: f64,
}

/// Polynomial smooth minimum with blend radius `k` (0 is the plain minimum).
fn smooth_min(a: f64, b: f64, k: f64) -> f64 {
    if k <= 0.0 {
        return a.min(b);
    }
    let h = (k - (a - b).abs()).max(0.0) / k;
    a.min(b) - h * h * k * 0.25
}

/// A smooth union of primitives.
#[derive(Debug, Clone)]
pub struct Body {
    pub primitives: Vec<Primitive>,
    pub blend: f64,
    /// Each primitive's bounds grown by [`Body::cull_margin`]: outside them it cannot change
    /// the union within the margin of the surface.
    cull: Vec<(V3, V3)>,
}

impl Body {
    pub fn new(primitives: Vec<Primitive>, blend: f64) -> Self {
        let margin = Self::cull_margin(blend);
        let cull = primitives.iter().map(|p| p.solid.bounds(margin)).collect();
        Self {
            primitives,
            blend,
            cull,
        }
    }

    /// Distances are exact (as a smooth union) within this band; beyond it only the sign is.
    fn cull_margin(blend: f64) -> f64 {
        3.0 * blend + 0.03
    }

    /// Signed distance of the union (negative inside). Primitives whose grown bounds miss `p`
    /// are at least the cull margin away and are skipped; a point outside every bound gets the
    /// margin (positive, outside).
    pub fn distance(&self, p: V3) -> f64 {
        let mut d = f64::INFINITY;
        for (prim, (lo, hi)) in self.primitives.iter().zip(&self.cull) {
            if (0..3).any(|k| p[k] < lo[k] || p[k] > hi[k]) {
                continue;
            }
            let di = prim.solid.distance(p);
            d = if d.is_finite() {
                smooth_min(d, di, self.blend)
            } else {
                di
            };
        }
        if d.is_finite() {
            d.min(Self::cull_margin(self.blend))
        } else {
            Self::cull_margin(self.blend)
        }
    }

    /// Index of the primitive nearest to `p` (the one that shapes the surface there).
    pub fn nearest(&self, p: V3) -> usize {
        let mut best = (f64::INFINITY, 0);
        for (i, prim) in self.primitives.iter().enumerate() {
            let d = prim.solid.distance(p);
            if d < best.0 {
                best = (d, i);
            }
        }
        best.1
    }

    /// Central-difference gradient of the distance.
    pub fn gradient(&self, p: V3) -> V3 {
        let h = 1e-5;
        let mut g = [0.0; 3];
        for (axis, gi) in g.iter_mut().enumerate() {
            let mut lo = p;
            let mut hi = p;
            lo[axis] -= h;
            hi[axis] += h;
            *gi = (self.distance(hi) - self.distance(lo)) / (2.0 * h);
        }
        g
    }

    /// Moves `p` onto the zero set by Newton steps along the gradient.
    pub fn project(&self, mut p: V3) -> V3 {
        for _ in 0..4 {
            let d = self.distance(p);
            let g = self.gradient(p);
            let g2 = dot(g, g);
            if g2 < 1e-12 || d.abs() < 1e-7 {
                break;
            }
            p = sub(p, scale(g, d / g2));
        }
        p
    }

    /// Bounds of the whole body, grown by `margin`.
    pub fn bounds(&self, margin: f64) -> (V3, V3) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for prim in &self.primitives {
            let (l, h) = prim.solid.bounds(margin + self.blend);
            for k in 0..3 {
                lo[k] = lo[k].min(l[k]);
                hi[k] = hi[k].max(h[k]);
            }
        }
        (lo, hi)
    }
}
