//! Building blocks for the synthetic scenes' rigid geometry: boxes and quads with per-vertex
//! texture coordinates in metres (so a repeating texture keeps its real-world scale on any size
//! of box) and per-vertex colours, merged into one mesh per object.

use glam::DVec3;

/// A triangle mesh with one texture coordinate and one colour per vertex.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MeshBuilder {
    pub positions: Vec<[f32; 3]>,
    pub faces: Vec<[u32; 3]>,
    /// Texture coordinates in metres along the face (divide by the texture's tile size).
    pub coords: Vec<[f32; 2]>,
    pub colours: Vec<[f32; 3]>,
}

impl MeshBuilder {
    /// A quad with corners `origin`, `origin + u`, `origin + u + v`, `origin + v`, facing
    /// `u × v`.
    pub fn quad(&mut self, origin: DVec3, u: DVec3, v: DVec3, colour: [f32; 3]) {
        let base = self.positions.len() as u32;
        let (lu, lv) = (u.length(), v.length());
        for (corner, uv) in [
            (origin, [0.0, 0.0]),
            (origin + u, [lu, 0.0]),
            (origin + u + v, [lu, lv]),
            (origin + v, [0.0, lv]),
        ] {
            self.positions.push(corner.as_vec3().to_array());
            self.coords.push([uv[0] as f32, uv[1] as f32]);
            self.colours.push(colour);
        }
        self.faces.push([base, base + 1, base + 2]);
        self.faces.push([base, base + 2, base + 3]);
    }

    /// An axis-aligned box from `min` to `max`, faces pointing outwards; `bottom` false leaves
    /// the underside open (boxes standing on the ground).
    pub fn cuboid(&mut self, min: DVec3, max: DVec3, colour: [f32; 3], bottom: bool) {
        let d = max - min;
        let (x, y, z) = (DVec3::X * d.x, DVec3::Y * d.y, DVec3::Z * d.z);
        // +x, -x, +z, -z, +y, -y; u runs horizontally on the sides.
        self.quad(min + x + z, -z, y, colour);
        self.quad(min, z, y, colour);
        self.quad(min + z, x, y, colour);
        self.quad(min + x, -x, y, colour);
        self.quad(min + y + z, x, -z, colour);
        if bottom {
            self.quad(min, x, z, colour);
        }
    }

    /// A box centred at `centre` with half extents `half`, rotated by `rotation` (columns are
    /// the box's axes in the world).
    pub fn oriented_box(
        &mut self,
        centre: DVec3,
        half: DVec3,
        rotation: glam::DMat3,
        colour: [f32; 3],
    ) {
        let start = self.positions.len();
        self.cuboid(-half, half, colour, true);
        for p in &mut self.positions[start..] {
            let q = rotation * DVec3::from(p.map(f64::from)) + centre;
            *p = q.as_vec3().to_array();
        }
    }

    pub fn append(&mut self, other: &MeshBuilder) {
        let base = self.positions.len() as u32;
        self.positions.extend_from_slice(&other.positions);
        self.coords.extend_from_slice(&other.coords);
        self.colours.extend_from_slice(&other.colours);
        self.faces
            .extend(other.faces.iter().map(|f| f.map(|i| i + base)));
    }

    /// Texture coordinates divided by `tile` metres.
    pub fn coords_per_tile(&self, tile: f32) -> Vec<[f32; 2]> {
        self.coords
            .iter()
            .map(|c| [c[0] / tile, c[1] / tile])
            .collect()
    }
}
