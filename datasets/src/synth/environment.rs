//! Static surroundings for the synthetic people: a furnished room (monocular human-in-room
//! captures), a street with road, sidewalks, a zebra crossing and buildings (driving), a paved
//! yard with crates (static 3DGS). Every surface carries a procedural texture at real-world
//! scale, so photometric methods and SfM have features to lock onto.

use super::mesh::MeshBuilder;
use super::rng::Rng;
use crate::render::Texture;
use glam::{DMat3, DVec3};

/// How a prop is coloured.
#[derive(Debug, Clone)]
pub enum Surface {
    /// The mesh's per-vertex colours.
    Colours,
    /// A repeating texture; the mesh's coordinates are already divided by its tile size.
    Textured(Texture),
}

/// One static object.
#[derive(Debug, Clone)]
pub struct Prop {
    pub name: String,
    pub mesh: MeshBuilder,
    pub surface: Surface,
}

impl Prop {
    fn textured(name: &str, mut mesh: MeshBuilder, texture: Texture, tile: f32) -> Self {
        mesh.coords = mesh.coords_per_tile(tile);
        Self {
            name: name.into(),
            mesh,
            surface: Surface::Textured(texture.repeating()),
        }
    }
}

/// A wooden cabinet standing on the floor, its footprint centred at `footprint_centre`, `size`
/// metres (width, height, depth), turned by `yaw` radians about +y: furniture that hides part
/// of a person from a camera.
pub fn cabinet(seed: u64, footprint_centre: DVec3, size: DVec3, yaw: f64) -> Prop {
    let mut rng = Rng(seed ^ 0x0000_CAB1);
    let colour = super::identity::colour_between(&mut rng, 0.3, 0.6);
    let mut mesh = MeshBuilder::default();
    mesh.oriented_box(
        footprint_centre + DVec3::Y * (0.5 * size.y),
        0.5 * size,
        DMat3::from_rotation_y(yaw),
        [1.0; 3],
    );
    let (texture, tile) = crate_wood(colour, seed);
    Prop::textured("cabinet", mesh, texture, tile)
}

/// A flat, plainly painted rectangle (`origin`, edges `u` and `v`; it faces `u × v`): a surface
/// with no texture at all, where photometric reconstruction has nothing to lock onto.
pub fn plain_panel(origin: DVec3, u: DVec3, v: DVec3, colour: [f32; 3]) -> Prop {
    let mut mesh = MeshBuilder::default();
    mesh.quad(origin, u, v, colour);
    Prop {
        name: "plain panel".into(),
        mesh,
        surface: Surface::Colours,
    }
}

/// Static geometry and what shows where it is missing.
#[derive(Debug, Clone, Default)]
pub struct Environment {
    pub props: Vec<Prop>,
    pub background: [f32; 3],
}

/// Smooth value noise in [0, 1] with unit cell size, tiling with period `period` cells.
fn value_noise(x: f64, y: f64, period: i64, seed: u64) -> f64 {
    let hash = |i: i64, j: i64| {
        let mut r = Rng(seed
            ^ (i.rem_euclid(period) as u64).wrapping_mul(0x9E37_79B9)
            ^ (j.rem_euclid(period) as u64).wrapping_mul(0x85EB_CA6B_0000));
        r.next()
    };
    let (i, j) = (x.floor() as i64, y.floor() as i64);
    let (fx, fy) = (x - x.floor(), y - y.floor());
    let s = |t: f64| t * t * (3.0 - 2.0 * t);
    let (sx, sy) = (s(fx), s(fy));
    let top = hash(i, j) * (1.0 - sx) + hash(i + 1, j) * sx;
    let bottom = hash(i, j + 1) * (1.0 - sx) + hash(i + 1, j + 1) * sx;
    top * (1.0 - sy) + bottom * sy
}

fn shade(c: [f32; 3], k: f64) -> [f32; 3] {
    c.map(|x| (x as f64 * k).clamp(0.0, 1.0) as f32)
}

/// A tile of `size` texels; `f` gets (u, v) in [0, 1) with v down the rows' reverse.
fn tile(size: usize, f: impl Fn(f64, f64) -> [f32; 3]) -> Texture {
    Texture::from_fn(size, size, |u, v| f(u as f64, v as f64))
}

/// Wooden planks 0.15 m wide and 1.2 m long in a 1.2 m tile, staggered, with grain.
fn wood_floor(seed: u64) -> (Texture, f32) {
    let base = [0.42f32, 0.25, 0.12];
    let texture = tile(256, |u, v| {
        let (x, y) = (u * 1.2, v * 1.2);
        let row = (x / 0.15).floor();
        let offset = (row * 0.37).fract() * 1.2;
        let along = (y + offset).rem_euclid(1.2);
        let plank = Rng(seed ^ (row as u64) << 8 ^ ((y + offset) / 1.2).floor() as u64).next();
        let seam = (x / 0.15).fract() < 0.03 || along < 0.006;
        let grain = value_noise(x * 120.0, y * 6.0, 144, seed);
        let k = if seam {
            0.4
        } else {
            0.75 + 0.35 * plank + 0.2 * grain
        };
        shade(base, k)
    });
    (texture, 1.2)
}

/// Wallpaper: a paint colour with a lattice of diamonds and fine noise in a 0.5 m tile.
fn wallpaper(colour: [f32; 3], seed: u64) -> (Texture, f32) {
    let texture = tile(128, |u, v| {
        let (du, dv) = ((u - 0.5).abs(), (v - 0.5).abs());
        let diamond = (du + dv - 0.3).abs() < 0.035;
        let k = if diamond { 0.7 } else { 1.0 }
            * (0.9 + 0.2 * value_noise(u * 32.0, v * 32.0, 32, seed));
        shade(colour, k)
    });
    (texture, 0.5)
}

/// Crate: planks with a darker frame in a 0.6 m tile.
fn crate_wood(colour: [f32; 3], seed: u64) -> (Texture, f32) {
    let texture = tile(128, |u, v| {
        let frame = !(0.08..0.92).contains(&u) || !(0.08..0.92).contains(&v);
        let diagonal = (u - v).abs() < 0.06;
        let board = (v * 5.0).fract() < 0.06;
        let k = if frame || diagonal {
            0.6
        } else if board {
            0.5
        } else {
            0.9 + 0.25 * value_noise(u * 40.0, v * 4.0, 40, seed)
        };
        shade(colour, k)
    });
    (texture, 0.6)
}

/// Asphalt with white edge lines and a dashed centre line: u across the 7 m road, v along it,
/// in a 7 m tile (3 m dashes, 4 m gaps).
fn road(seed: u64) -> (Texture, f32) {
    let texture = tile(512, |u, v| {
        let x = u * 7.0;
        let y = v * 7.0;
        let edge = (0.15..0.3).contains(&x) || (6.7..6.85).contains(&x);
        let centre = (3.42..3.58).contains(&x) && y < 3.0;
        if edge || centre {
            return [0.75; 3];
        }
        let n = value_noise(u * 400.0, v * 400.0, 400, seed);
        shade([0.09, 0.09, 0.1], 0.8 + 0.4 * n)
    });
    (texture, 7.0)
}

/// Paving slabs 0.5 m square in a 1 m tile.
fn paving(colour: [f32; 3], seed: u64) -> (Texture, f32) {
    let texture = tile(128, |u, v| {
        let joint = (u * 2.0).fract() < 0.03 || (v * 2.0).fract() < 0.03;
        let slab = Rng(seed ^ ((u * 2.0) as u64) << 4 ^ (v * 2.0) as u64).next();
        let k = if joint {
            0.55
        } else {
            0.85 + 0.2 * slab + 0.15 * value_noise(u * 24.0, v * 24.0, 24, seed)
        };
        shade(colour, k)
    });
    (texture, 1.0)
}

/// A facade bay 3 m square: wall colour with one window (dark glass, light frame).
fn facade(colour: [f32; 3], seed: u64) -> (Texture, f32) {
    let texture = tile(128, |u, v| {
        let inside = (0.25..0.75).contains(&u) && (0.3..0.8).contains(&v);
        let frame = (0.22..0.78).contains(&u) && (0.27..0.83).contains(&v);
        if inside {
            let mullion = (u - 0.5).abs() < 0.015;
            return if mullion {
                [0.8; 3]
            } else {
                shade([0.05, 0.08, 0.12], 0.8 + 0.6 * v)
            };
        }
        if frame {
            return [0.8; 3];
        }
        shade(
            colour,
            0.85 + 0.3 * value_noise(u * 30.0, v * 30.0, 30, seed),
        )
    });
    (texture, 3.0)
}

/// A furnished room `size` metres square and `height` tall centred on the origin, floor at
/// y = 0, the middle left free for a person and a camera walking around them.
pub fn room(seed: u64, size: f64, height: f64) -> Environment {
    let mut rng = Rng(seed ^ 0x0000_4005);
    let h = 0.5 * size;
    let mut props = Vec::new();
    let mut floor = MeshBuilder::default();
    floor.quad(
        DVec3::new(-h, 0.0, h),
        DVec3::new(2.0 * h, 0.0, 0.0),
        DVec3::new(0.0, 0.0, -2.0 * h),
        [1.0; 3],
    );
    let (texture, tile_size) = wood_floor(seed);
    props.push(Prop::textured("floor", floor, texture, tile_size));
    let mut walls = MeshBuilder::default();
    let corners = [
        DVec3::new(-h, 0.0, -h),
        DVec3::new(h, 0.0, -h),
        DVec3::new(h, 0.0, h),
        DVec3::new(-h, 0.0, h),
    ];
    for k in 0..4 {
        // Facing inwards: walk the corners anticlockwise seen from above.
        walls.quad(
            corners[k],
            corners[(k + 1) % 4] - corners[k],
            DVec3::Y * height,
            [1.0; 3],
        );
    }
    let paint = super::identity::colour_between(&mut rng, 0.35, 0.8);
    let (texture, tile_size) = wallpaper(paint, seed);
    props.push(Prop::textured("walls", walls, texture, tile_size));
    let mut ceiling = MeshBuilder::default();
    ceiling.quad(
        DVec3::new(-h, height, -h),
        DVec3::new(2.0 * h, 0.0, 0.0),
        DVec3::new(0.0, 0.0, 2.0 * h),
        [0.8; 3],
    );
    props.push(Prop {
        name: "ceiling".into(),
        mesh: ceiling,
        surface: Surface::Colours,
    });
    // Furniture along the walls: a table, a shelf and crates.
    let mut furniture = MeshBuilder::default();
    let wood = super::identity::colour_between(&mut rng, 0.25, 0.6);
    let (tx, tz) = (h - 0.9, rng.range(-1.0, 1.0));
    furniture.cuboid(
        DVec3::new(tx - 0.45, 0.72, tz - 0.7),
        DVec3::new(tx + 0.45, 0.76, tz + 0.7),
        wood,
        true,
    );
    for (dx, dz) in [(-0.4, -0.65), (0.4, -0.65), (-0.4, 0.65), (0.4, 0.65)] {
        furniture.cuboid(
            DVec3::new(tx + dx - 0.03, 0.0, tz + dz - 0.03),
            DVec3::new(tx + dx + 0.03, 0.72, tz + dz + 0.03),
            shade(wood, 0.7),
            false,
        );
    }
    let shelf = super::identity::colour_between(&mut rng, 0.3, 0.7);
    furniture.cuboid(
        DVec3::new(-h + 0.05, 0.0, -1.2),
        DVec3::new(-h + 0.45, 1.9, -0.2),
        shelf,
        false,
    );
    for level in 1..4 {
        let y = level as f64 * 0.45;
        furniture.cuboid(
            DVec3::new(-h + 0.44, y, -1.15),
            DVec3::new(-h + 0.47, y + 0.3, -0.25),
            super::identity::colour_between(&mut rng, 0.2, 0.8),
            false,
        );
    }
    props.push(Prop {
        name: "furniture".into(),
        mesh: furniture,
        surface: Surface::Colours,
    });
    props.push(crates(
        &mut rng,
        seed,
        &[(-h + 0.6, h - 0.7), (h - 0.8, -h + 0.7)],
    ));
    Environment {
        props,
        background: [0.0; 3],
    }
}

/// Crates of random size and yaw near each `(x, z)`.
fn crates(rng: &mut Rng, seed: u64, places: &[(f64, f64)]) -> Prop {
    let mut mesh = MeshBuilder::default();
    for &(x, z) in places {
        let side = rng.range(0.35, 0.6);
        let yaw = rng.range(0.0, std::f64::consts::FRAC_PI_2);
        mesh.oriented_box(
            DVec3::new(x, 0.5 * side, z),
            DVec3::splat(0.5 * side),
            DMat3::from_rotation_y(yaw),
            [1.0; 3],
        );
        let top = rng.range(0.25, 0.4);
        mesh.oriented_box(
            DVec3::new(x, side + 0.5 * top, z),
            DVec3::splat(0.5 * top),
            DMat3::from_rotation_y(yaw + 0.4),
            [1.0; 3],
        );
    }
    let (texture, tile_size) = crate_wood([0.62, 0.45, 0.26], seed);
    Prop::textured("crates", mesh, texture, tile_size)
}

/// Where the street's zebra crossing is (z, metres).
pub const CROSSING_Z: f64 = 24.0;
/// Half the road's width.
pub const ROAD_HALF_WIDTH: f64 = 3.5;
/// Sidewalk kerb height.
pub const KERB: f64 = 0.15;

/// A straight street along +z from z = -10 to `length`: a 7 m road with lane markings, 3 m
/// sidewalks raised by a kerb, a zebra crossing at [`CROSSING_Z`] and buildings on both sides.
pub fn street(seed: u64, length: f64) -> Environment {
    let mut rng = Rng(seed ^ 0x57_8EE7);
    let mut props = Vec::new();
    let (z0, z1) = (-10.0, length);
    let mut road_mesh = MeshBuilder::default();
    road_mesh.quad(
        DVec3::new(-ROAD_HALF_WIDTH, 0.0, z0),
        DVec3::new(0.0, 0.0, z1 - z0),
        DVec3::new(2.0 * ROAD_HALF_WIDTH, 0.0, 0.0),
        [1.0; 3],
    );
    // The road texture's u runs across the road: swap the quad's coordinates.
    for c in &mut road_mesh.coords {
        *c = [c[1], c[0]];
    }
    let (texture, tile_size) = road(seed);
    props.push(Prop::textured("road", road_mesh, texture, tile_size));
    let mut zebra = MeshBuilder::default();
    let mut x = -ROAD_HALF_WIDTH + 0.5;
    while x < ROAD_HALF_WIDTH - 0.5 {
        zebra.quad(
            DVec3::new(x, 0.004, CROSSING_Z + 2.0),
            DVec3::new(0.5, 0.0, 0.0),
            DVec3::new(0.0, 0.0, -4.0),
            [0.8; 3],
        );
        x += 1.0;
    }
    props.push(Prop {
        name: "crossing".into(),
        mesh: zebra,
        surface: Surface::Colours,
    });
    let mut walks = MeshBuilder::default();
    for side in [-1.0, 1.0] {
        let (a, b) = (side * ROAD_HALF_WIDTH, side * (ROAD_HALF_WIDTH + 3.0));
        walks.cuboid(
            DVec3::new(a.min(b), 0.0, z0),
            DVec3::new(a.max(b), KERB, z1),
            [1.0; 3],
            false,
        );
    }
    let (texture, tile_size) = paving([0.6, 0.58, 0.55], seed);
    props.push(Prop::textured("sidewalks", walks, texture, tile_size));
    for side in [-1.0, 1.0] {
        let mut z = z0;
        let mut k = 0;
        while z < z1 {
            let width = rng.range(8.0, 15.0).min(z1 - z).max(3.0);
            let height = 3.0 * rng.range(2.0, 6.0).round();
            let depth = rng.range(8.0, 12.0);
            let inner = side * (ROAD_HALF_WIDTH + 3.0);
            let outer = inner + side * depth;
            let mut block = MeshBuilder::default();
            block.cuboid(
                DVec3::new(inner.min(outer), 0.0, z),
                DVec3::new(inner.max(outer), height, z + width),
                [1.0; 3],
                false,
            );
            let wall = super::identity::colour_between(&mut rng, 0.3, 0.75);
            let (texture, tile_size) = facade(wall, seed ^ k);
            props.push(Prop::textured(
                &format!("building_{}_{k}", if side < 0.0 { "right" } else { "left" }),
                block,
                texture,
                tile_size,
            ));
            z += width;
            k += 1;
        }
    }
    Environment {
        props,
        background: [0.55, 0.7, 0.9],
    }
}

/// A paved yard with crates around the middle, open to a pale sky: a static scene for 3DGS.
pub fn yard(seed: u64) -> Environment {
    let mut rng = Rng(seed ^ 0x0000_7A4D);
    let mut ground = MeshBuilder::default();
    ground.quad(
        DVec3::new(-6.0, 0.0, 6.0),
        DVec3::new(12.0, 0.0, 0.0),
        DVec3::new(0.0, 0.0, -12.0),
        [1.0; 3],
    );
    let (texture, tile_size) = paving([0.55, 0.5, 0.45], seed);
    let mut props = vec![Prop::textured("ground", ground, texture, tile_size)];
    let places: Vec<(f64, f64)> = (0..5)
        .map(|k| {
            let angle = k as f64 * 1.2566 + rng.range(-0.3, 0.3);
            let r = rng.range(0.9, 1.6);
            (r * angle.cos(), r * angle.sin())
        })
        .collect();
    props.push(crates(&mut rng, seed, &places));
    Environment {
        props,
        background: [0.75, 0.82, 0.9],
    }
}
