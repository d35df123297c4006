//! The identity of a scene: the FMU's GUID and the model hash, both derived from the scene
//! text and the crate version.
//!
//! The exporter writes the GUID into `modelDescription.xml`; the FMI runtime recomputes both
//! from `resources/scene.toml` (the GUID to check the host's, the hash to tag saved states).

use sha2::{Digest, Sha256};

/// The crate version, mixed into the GUID (and written into `generationTool` by the exporter).
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// The fingerprint of the sources this build was compiled from (16 hex digits, computed by
/// `build.rs`): equal in the command line and in a library built from the same sources.
pub const SOURCES: &str = env!("CONTACT_FMU_SOURCES");

/// What a library says of itself in its first log message, and what the exporter looks for
/// in a library file before packing it ([`crate::export::build_of`]): the version and the
/// sources' fingerprint, as one string constant (so it stands in the file as written).
pub const BUILD: &str = concat!(
    "contact-fmu ",
    env!("CARGO_PKG_VERSION"),
    " (sources ",
    env!("CONTACT_FMU_SOURCES"),
    ")"
);

/// SHA-256 of the scene text followed by the crate version.
fn digest(scene_text: &str) -> [u8; 32] {
    let mut h = Sha256::new();
    h.update(scene_text.as_bytes());
    h.update(b"\ncontact-fmu ");
    h.update(VERSION.as_bytes());
    h.finalize().into()
}

/// The FMU's GUID: `{8-4-4-4-12}` hex from the SHA-256 of the scene text and the crate
/// version (formatted as an RFC 9562 version-8 UUID), so the same scene always gets the
/// same GUID and `fmi2Instantiate` can check that the description and the scene belong
/// together.
pub fn guid(scene_text: &str) -> String {
    let mut b = digest(scene_text);
    b[6] = (b[6] & 0x0f) | 0x80;
    b[8] = (b[8] & 0x3f) | 0x80;
    let hex: String = b[..16].iter().map(|x| format!("{x:02x}")).collect();
    format!(
        "{{{}-{}-{}-{}-{}}}",
        &hex[0..8],
        &hex[8..12],
        &hex[12..16],
        &hex[16..20],
        &hex[20..32]
    )
}

/// A 64-bit fingerprint of the scene (the first bytes of the same digest), stored in
/// serialized FMU states so that a state only restores into the same model.
pub fn model_hash(scene_text: &str) -> u64 {
    let b = digest(scene_text);
    u64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn guid_is_deterministic_and_uuid_shaped() {
        let a = guid("[model]\nname = \"x\"\n");
        assert_eq!(a, guid("[model]\nname = \"x\"\n"));
        assert_ne!(a, guid("[model]\nname = \"y\"\n"));
        assert_eq!(a.len(), 38);
        let inner = &a[1..37];
        let groups: Vec<usize> = inner.split('-').map(str::len).collect();
        assert_eq!(groups, [8, 4, 4, 4, 12]);
        assert!(a.starts_with('{') && a.ends_with('}'));
        assert_eq!(&inner[14..15], "8", "version nibble");
    }
}
