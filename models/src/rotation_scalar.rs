//! Rotations as plain `f64` arrays (row-major matrices acting on column vectors), for host-side
//! work such as reading dataset files and density control, beside the differentiable batched
//! ops of [`crate::rotation`].

const IDENTITY: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// The rotation of a quaternion `(w, x, y, z)`, normalised here; zero gives the identity.
pub fn quaternion_matrix(q: [f64; 4]) -> [[f64; 3]; 3] {
    let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    if n == 0.0 || !n.is_finite() {
        return IDENTITY;
    }
    let [w, x, y, z] = q.map(|v| v / n);
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

/// Rotation matrix of an axis-angle vector (Rodrigues).
pub fn axis_angle_matrix(v: [f64; 3]) -> [[f64; 3]; 3] {
    let angle = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if angle < 1e-12 {
        return IDENTITY;
    }
    let [x, y, z] = v.map(|c| c / angle);
    let (s, c) = angle.sin_cos();
    let t = 1.0 - c;
    [
        [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
        [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
        [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
    ]
}

/// Axis-angle of a rotation matrix.
pub fn matrix_axis_angle(r: &[[f64; 3]; 3]) -> [f64; 3] {
    let cos = ((r[0][0] + r[1][1] + r[2][2] - 1.0) / 2.0).clamp(-1.0, 1.0);
    let angle = cos.acos();
    let v = [r[2][1] - r[1][2], r[0][2] - r[2][0], r[1][0] - r[0][1]];
    if angle < 1e-8 {
        return [v[0] / 2.0, v[1] / 2.0, v[2] / 2.0];
    }
    if std::f64::consts::PI - angle < 1e-4 {
        // Near π: the axis from the largest diagonal entry of (R + I) / 2.
        let k = (0..3)
            .max_by(|&a, &b| r[a][a].total_cmp(&r[b][b]))
            .expect("three");
        let mut axis = [0.0; 3];
        axis[k] = ((r[k][k] + 1.0) / 2.0).max(0.0).sqrt();
        for j in 0..3 {
            if j != k {
                axis[j] = (r[k][j] + r[j][k]) / (4.0 * axis[k]);
            }
        }
        let n = axis.iter().map(|a| a * a).sum::<f64>().sqrt();
        return axis.map(|a| a / n * angle);
    }
    let s = angle / (2.0 * angle.sin());
    v.map(|c| c * s)
}
