//! Helpers of the loader tests ([`crate::formats`], [`crate::real_layouts`],
//! [`crate::colmap_scenes`]); the fixture writers themselves (each format's files in its real
//! layout) are the library's, `splatzoo_datasets::fixtures`, so other crates' tests use them too.

/// Whether two numbers agree to 1e-5.
pub(crate) fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-5
}
