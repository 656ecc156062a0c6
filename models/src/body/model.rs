//! A parametric body as plain data, validated once so skinning can trust its shapes.

/// Which family a model belongs to (fixes the pose-vector layout).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BodyKind {
    /// SMPL: 6890 vertices, 24 joints.
    Smpl,
    /// SMPL-H: 6890 vertices, 52 joints (body + hands).
    SmplH,
    /// SMPL-X: 10475 vertices, 55 joints (body, jaw, eyes, hands).
    SmplX,
    /// The project's procedural body, with SMPL's 24-joint skeleton.
    Builtin,
}

/// Template mesh, skeleton, skinning and blend shapes. Arrays are flat, row-major, `f32`.
#[derive(Debug, Clone)]
pub struct BodyModel {
    pub kind: BodyKind,
    /// `[V, 3]` rest-pose vertices.
    pub template: Vec<f32>,
    /// `[F, 3]` triangle vertex indices.
    pub faces: Vec<u32>,
    /// `[J, V]` joint regressor (joints = regressor × shaped vertices).
    pub joint_regressor: Vec<f32>,
    /// Parent of each joint; exactly one root (`None`), parents precede children.
    pub parents: Vec<Option<usize>>,
    /// `[V, J]` skinning weights.
    pub skin_weights: Vec<f32>,
    /// `[V, 3, S]` shape directions.
    pub shape_dirs: Vec<f32>,
    /// `[V, 3, 9 (J − 1)]` pose-corrective directions, if the model has them.
    pub pose_dirs: Option<Vec<f32>>,
    /// `[V, 3, E]` expression directions, if the model has them.
    pub expression_dirs: Option<Vec<f32>>,
    pub joint_names: Vec<String>,
    /// SMPL-X's static face landmarks (`lmk_faces_idx`, `lmk_bary_coords`): the 68-point face
    /// layout's points 17–67 (brows, nose, eyes, mouth) in order, where the model has them.
    pub face_landmarks: Option<Vec<FaceLandmark>>,
}

/// A point on the mesh: a triangle (index into the faces) and barycentric weights.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaceLandmark {
    pub face: u32,
    pub weights: [f32; 3],
}

/// Why a body model is unusable; names the field and the expected shape.
#[derive(Debug, thiserror::Error)]
pub enum BodyModelError {
    #[error("{file}: key `{key}`: {problem}")]
    Field {
        file: String,
        key: String,
        problem: String,
    },
    #[error("{file}: {problem}")]
    File { file: String, problem: String },
}

impl BodyModel {
    pub fn vertex_count(&self) -> usize {
        self.template.len() / 3
    }

    pub fn joint_count(&self) -> usize {
        self.parents.len()
    }

    pub fn face_count(&self) -> usize {
        self.faces.len() / 3
    }

    /// Shape coefficients the model takes.
    pub fn shape_count(&self) -> usize {
        self.shape_dirs.len() / (3 * self.vertex_count()).max(1)
    }

    /// Expression coefficients the model takes (0 without expression directions).
    pub fn expression_count(&self) -> usize {
        self.expression_dirs
            .as_ref()
            .map_or(0, |e| e.len() / (3 * self.vertex_count()).max(1))
    }

    /// Checks every array against the others; `source` names the file in errors.
    pub fn validate(&self, source: &str) -> Result<(), BodyModelError> {
        let field = |key: &str, problem: String| BodyModelError::Field {
            file: source.to_owned(),
            key: key.to_owned(),
            problem,
        };
        let v = self.vertex_count();
        let j = self.joint_count();
        if self.template.len() != v * 3 || v == 0 {
            return Err(field(
                "v_template",
                format!(
                    "expected [V, 3] with V > 0, got {} values",
                    self.template.len()
                ),
            ));
        }
        if !self.faces.len().is_multiple_of(3) || self.faces.is_empty() {
            return Err(field(
                "f",
                format!("expected [F, 3], got {} values", self.faces.len()),
            ));
        }
        if let Some(&bad) = self.faces.iter().find(|&&f| f as usize >= v) {
            return Err(field(
                "f",
                format!("vertex index {bad} out of range for {v} vertices"),
            ));
        }
        if j == 0 || self.joint_regressor.len() != j * v {
            return Err(field(
                "J_regressor",
                format!(
                    "expected [{j}, {v}], got {} values",
                    self.joint_regressor.len()
                ),
            ));
        }
        if self.skin_weights.len() != v * j {
            return Err(field(
                "weights",
                format!(
                    "expected [{v}, {j}], got {} values",
                    self.skin_weights.len()
                ),
            ));
        }
        let roots = self.parents.iter().filter(|p| p.is_none()).count();
        if roots != 1 || self.parents[0].is_some() {
            return Err(field(
                "kintree_table",
                format!("expected joint 0 to be the only root, found {roots} roots"),
            ));
        }
        for (joint, parent) in self.parents.iter().enumerate() {
            if let Some(p) = parent
                && *p >= joint
            {
                return Err(field(
                    "kintree_table",
                    format!("joint {joint} has parent {p}: parents must precede children"),
                ));
            }
        }
        if !self.shape_dirs.len().is_multiple_of(3 * v) {
            return Err(field(
                "shapedirs",
                format!("expected [{v}, 3, S], got {} values", self.shape_dirs.len()),
            ));
        }
        if let Some(p) = &self.pose_dirs
            && p.len() != v * 3 * 9 * (j - 1)
        {
            return Err(field(
                "posedirs",
                format!("expected [{v}, 3, {}], got {} values", 9 * (j - 1), p.len()),
            ));
        }
        if let Some(e) = &self.expression_dirs
            && !e.len().is_multiple_of(3 * v)
        {
            return Err(field(
                "expression dirs",
                format!("expected [{v}, 3, E], got {} values", e.len()),
            ));
        }
        if self.joint_names.len() != j {
            return Err(field(
                "joint names",
                format!("expected {j} names, got {}", self.joint_names.len()),
            ));
        }
        if let Some(landmarks) = &self.face_landmarks {
            let faces = self.face_count();
            if let Some((i, bad)) = landmarks
                .iter()
                .enumerate()
                .find(|(_, l)| l.face as usize >= faces || l.weights.iter().any(|w| !w.is_finite()))
            {
                return Err(field(
                    "lmk_faces_idx",
                    format!(
                        "landmark {i}: face {} of {faces}, weights {:?} (a face of the mesh and \
                         finite barycentrics expected)",
                        bad.face, bad.weights
                    ),
                ));
            }
        }
        let arrays: [(&str, &[f32]); 4] = [
            ("v_template", &self.template),
            ("J_regressor", &self.joint_regressor),
            ("weights", &self.skin_weights),
            ("shapedirs", &self.shape_dirs),
        ];
        for (key, values) in arrays {
            if let Some(i) = values.iter().position(|x| !x.is_finite()) {
                return Err(field(key, format!("non-finite value at flat index {i}")));
            }
        }
        Ok(())
    }
}
