//! Linear-RGB textures sampled bilinearly, v pointing up (as OBJ and SMPL UVs do).

/// An RGB texture, row 0 at the top.
#[derive(Debug, Clone)]
pub struct Texture {
    pub width: usize,
    pub height: usize,
    /// `[H, W]` texels.
    pub texels: Vec<[f32; 3]>,
    /// Tile the texture outside [0, 1]² (ground planes, walls) instead of clamping to the edge
    /// (UV atlases).
    pub repeat: bool,
}

impl Texture {
    /// A texture from a function of (u, v) ∈ [0, 1]² evaluated at texel centres.
    pub fn from_fn(width: usize, height: usize, f: impl Fn(f32, f32) -> [f32; 3]) -> Self {
        let texels = (0..height)
            .flat_map(|row| {
                let v = 1.0 - (row as f32 + 0.5) / height as f32;
                let f = &f;
                (0..width).map(move |col| f((col as f32 + 0.5) / width as f32, v))
            })
            .collect();
        Self {
            width,
            height,
            texels,
            repeat: false,
        }
    }

    /// The same texture, tiled outside [0, 1]².
    pub fn repeating(self) -> Self {
        Self {
            repeat: true,
            ..self
        }
    }

    /// Bilinear sample at (u, v), clamped to the edge or tiled.
    pub fn sample(&self, u: f32, v: f32) -> [f32; 3] {
        let (w, h) = (self.width, self.height);
        let (x0, y0, x1, y1, fx, fy);
        if self.repeat {
            let x = (u - u.floor()) * w as f32 - 0.5;
            let y = (1.0 - v - (1.0 - v).floor()) * h as f32 - 0.5;
            let (xf, yf) = (x.floor(), y.floor());
            (fx, fy) = (x - xf, y - yf);
            x0 = (xf as i64).rem_euclid(w as i64) as usize;
            y0 = (yf as i64).rem_euclid(h as i64) as usize;
            (x1, y1) = ((x0 + 1) % w, (y0 + 1) % h);
        } else {
            let x = (u * w as f32 - 0.5).clamp(0.0, (w - 1) as f32);
            let y = ((1.0 - v) * h as f32 - 0.5).clamp(0.0, (h - 1) as f32);
            (x0, y0) = (x.floor() as usize, y.floor() as usize);
            (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
            (fx, fy) = (x - x0 as f32, y - y0 as f32);
        }
        let t = |cx: usize, cy: usize| self.texels[cy * self.width + cx];
        let mut out = [0.0; 3];
        for (c, o) in out.iter_mut().enumerate() {
            let top = t(x0, y0)[c] * (1.0 - fx) + t(x1, y0)[c] * fx;
            let bottom = t(x0, y1)[c] * (1.0 - fx) + t(x1, y1)[c] * fx;
            *o = top * (1.0 - fy) + bottom * fy;
        }
        out
    }
}
