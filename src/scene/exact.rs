//! Fixed-length arrays read exactly: serde reads `[T; N]` from the first `N` elements of a
//! TOML array and drops the rest without a word (a 4-element inertia, a position with a
//! fourth number, a third group in a pair), so these fields are read as a list and refused
//! unless it has `N` elements.

use serde::de::{Deserializer, Error};
use serde::Deserialize;

/// `[T; N]` from an array of exactly `N` elements.
pub fn array<'de, D: Deserializer<'de>, T: Deserialize<'de>, const N: usize>(d: D) -> Result<[T; N], D::Error> {
    let v = Vec::<T>::deserialize(d)?;
    let n = v.len();
    v.try_into()
        .map_err(|_| D::Error::invalid_length(n, &format!("an array of length {N}").as_str()))
}

/// `Option<[T; N]>` from an array of exactly `N` elements (absent: `None`, with
/// `#[serde(default)]`).
pub fn option_array<'de, D: Deserializer<'de>, T: Deserialize<'de>, const N: usize>(
    d: D,
) -> Result<Option<[T; N]>, D::Error> {
    array(d).map(Some)
}
