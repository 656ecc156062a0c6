//! What the test modules share: the smallest portrait capture (two identities, one held-out
//! view, `size`² face and evaluation images, the true shape as the body prior).

use splatzoo_aagaussian::data::PortraitConfig;

pub fn tiny_portrait(size: u32) -> PortraitConfig {
    PortraitConfig {
        identities: 2,
        face_size: size,
        eval_azimuths: 1,
        eval_elevations: vec![0.0],
        eval_size: size,
        body_fit: false,
        ..PortraitConfig::default()
    }
}
