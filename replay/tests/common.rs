//! What the test files of this folder share.

/// The shipped file `weights/<name>`, whole, for the rest of the test run
/// (the replay reads blobs and golden files in place, as `'static` bytes).
pub fn read(name: &str) -> &'static [u8] {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../weights/").to_string() + name;
    Box::leak(
        std::fs::read(&path)
            .unwrap_or_else(|e| panic!("{path}: {e}"))
            .into_boxed_slice(),
    )
}
