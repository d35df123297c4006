//! Saved states and their bytes: one format for FMU states (`fmi2SerializeFMUstate`) and the
//! command line's checkpoints.
//!
//! A [`Snapshot`] holds the parameter and input values, whether the simulation was
//! initialised, the state declared in [`crate::model::state`] (the whole mask) and a few
//! numbers of the host (the FMI layer's lifecycle). Its bytes are plain little-endian values
//! in sections behind a header, never a pointer, ending with a checksum:
//!
//! ```text
//! "CFMUSTAT" | version u32 | sections u32 | model hash u64
//! per section: tag u32 | 0 u32 | count u64 | count × f64
//! FNV-1a 64 checksum of everything before it, u64
//! ```
//!
//! A state that is truncated, corrupted, of another version or of another model, or that
//! lacks a section, repeats one or sets a reserved word is refused with a message.

/// Everything needed to continue a simulation from where it was saved.
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    /// Numbers of the host layer (the FMI lifecycle; empty for the command line).
    pub host: Vec<f64>,
    /// Parameter and input values, by value reference.
    pub values: Vec<f64>,
    /// Whether the simulation had been initialised.
    pub initialized: bool,
    /// The state ([`crate::model::state::FULL`]; empty when not initialised).
    pub state: Vec<f64>,
}

const MAGIC: &[u8; 8] = b"CFMUSTAT";
const VERSION: u32 = 7;
const HEADER_LEN: usize = 8 + 4 + 4 + 8;
const SECTION_HEADER_LEN: usize = 4 + 4 + 8;

/// Section tags.
const HOST: u32 = 1;
const VALUES: u32 = 2;
const FLAGS: u32 = 3;
const STATE: u32 = 4;

/// FNV-1a, 64 bits.
fn checksum(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

impl Snapshot {
    /// The bytes, tagged with `model_hash` (a state only restores into the same model).
    pub fn to_bytes(&self, model_hash: u64) -> Vec<u8> {
        let flags = [self.initialized as u8 as f64];
        let sections: [(u32, &[f64]); 4] = [
            (HOST, &self.host),
            (VALUES, &self.values),
            (FLAGS, &flags),
            (STATE, &self.state),
        ];
        let numbers: usize = sections.iter().map(|(_, s)| s.len()).sum();
        let mut b = Vec::with_capacity(HEADER_LEN + sections.len() * SECTION_HEADER_LEN + 8 * numbers + 8);
        b.extend_from_slice(MAGIC);
        b.extend_from_slice(&VERSION.to_le_bytes());
        b.extend_from_slice(&(sections.len() as u32).to_le_bytes());
        b.extend_from_slice(&model_hash.to_le_bytes());
        for &(tag, values) in &sections {
            b.extend_from_slice(&tag.to_le_bytes());
            b.extend_from_slice(&0u32.to_le_bytes());
            b.extend_from_slice(&(values.len() as u64).to_le_bytes());
            for x in values {
                b.extend_from_slice(&x.to_le_bytes());
            }
        }
        let sum = checksum(&b);
        b.extend_from_slice(&sum.to_le_bytes());
        b
    }

    /// Parses bytes written by [`Snapshot::to_bytes`] for the model with `model_hash`,
    /// checking magic, version, checksum, lengths and the model.
    pub fn from_bytes(b: &[u8], model_hash: u64) -> Result<Snapshot, String> {
        if b.len() < HEADER_LEN + 8 {
            return Err(format!(
                "serialized state has {} bytes, fewer than its {}-byte header and checksum",
                b.len(),
                HEADER_LEN + 8
            ));
        }
        if &b[..8] != MAGIC {
            return Err("serialized state has a wrong magic number (not written by contact-fmu)".into());
        }
        let mut r = Reader { b, pos: 8 };
        let version = r.u32()?;
        if version != VERSION {
            return Err(format!(
                "serialized state has version {version}, this library reads version {VERSION}"
            ));
        }
        let (body, tail) = b.split_at(b.len() - 8);
        let stored = u64::from_le_bytes(tail.try_into().map_err(|_| "serialized state: no checksum")?);
        if checksum(body) != stored {
            return Err(format!(
                "serialized state of {} bytes is corrupted or truncated (checksum mismatch)",
                b.len()
            ));
        }
        let r = &mut Reader { b: body, pos: r.pos };
        let nsections = r.u32()?;
        let hash = r.u64()?;
        if hash != model_hash {
            return Err("serialized state belongs to a different model (model hash mismatch)".into());
        }
        let mut s = Snapshot {
            host: Vec::new(),
            values: Vec::new(),
            initialized: false,
            state: Vec::new(),
        };
        let mut seen = 0u32;
        for _ in 0..nsections {
            let tag = r.u32()?;
            if r.u32()? != 0 {
                return Err(format!("serialized state: section {tag} has a non-zero reserved word"));
            }
            let count = r.u64()?;
            let available = (body.len() - r.pos) / 8;
            if count > available as u64 {
                return Err(format!(
                    "serialized state: section {tag} claims {count} numbers, {available} are present"
                ));
            }
            let values: Vec<f64> = (0..count as usize).map(|_| r.f64()).collect::<Result<_, _>>()?;
            match tag {
                HOST => s.host = values,
                VALUES => s.values = values,
                FLAGS => {
                    let [flag] = values[..] else {
                        return Err("serialized state: the flags section must hold one number".into());
                    };
                    if flag != 0.0 && flag != 1.0 {
                        return Err(format!("serialized state: initialised flag {flag} is not 0 or 1"));
                    }
                    s.initialized = flag == 1.0;
                }
                STATE => s.state = values,
                _ => return Err(format!("serialized state: unknown section {tag}")),
            }
            if seen & (1 << tag) != 0 {
                return Err(format!("serialized state: section {tag} appears twice"));
            }
            seen |= 1 << tag;
        }
        if seen != (1 << HOST) | (1 << VALUES) | (1 << FLAGS) | (1 << STATE) {
            return Err("serialized state lacks a section".into());
        }
        if r.pos != body.len() {
            return Err(format!(
                "serialized state has {} bytes after its last section",
                body.len() - r.pos
            ));
        }
        Ok(s)
    }
}

/// Little-endian reads with bounds checks.
struct Reader<'a> {
    b: &'a [u8],
    pos: usize,
}

impl Reader<'_> {
    fn take<const N: usize>(&mut self) -> Result<[u8; N], String> {
        let s = self
            .b
            .get(self.pos..self.pos + N)
            .ok_or("serialized state is truncated")?;
        self.pos += N;
        s.try_into().map_err(|_| "serialized state is truncated".to_string())
    }
    fn u32(&mut self) -> Result<u32, String> {
        self.take::<4>().map(u32::from_le_bytes)
    }
    fn u64(&mut self) -> Result<u64, String> {
        self.take::<8>().map(u64::from_le_bytes)
    }
    fn f64(&mut self) -> Result<f64, String> {
        self.take::<8>().map(f64::from_le_bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Snapshot {
        Snapshot {
            host: vec![2.0, 0.0],
            values: vec![1.5, -2.0, 3.25],
            initialized: true,
            state: vec![0.1, 0.2, f64::MIN_POSITIVE],
        }
    }

    #[test]
    fn round_trip_is_exact() {
        let s = sample();
        assert_eq!(Snapshot::from_bytes(&s.to_bytes(7), 7).unwrap(), s);
    }

    #[test]
    fn every_truncation_and_every_flipped_byte_is_refused() {
        let b = sample().to_bytes(7);
        for n in 0..b.len() {
            assert!(Snapshot::from_bytes(&b[..n], 7).is_err(), "truncated to {n} bytes");
        }
        for i in 0..b.len() {
            let mut c = b.clone();
            c[i] ^= 0x10;
            assert!(Snapshot::from_bytes(&c, 7).is_err(), "byte {i} flipped");
        }
        assert!(Snapshot::from_bytes(&b, 8).unwrap_err().contains("different model"));
    }

    /// `b` with its checksum written anew (as a crafted state would carry it).
    fn resealed(mut b: Vec<u8>) -> Vec<u8> {
        b.truncate(b.len() - 8);
        let sum = checksum(&b);
        b.extend_from_slice(&sum.to_le_bytes());
        b
    }

    #[test]
    fn a_repeated_section_or_a_reserved_word_set_is_refused_with_a_sound_checksum() {
        let s = sample();
        let b = s.to_bytes(7);
        // the values section (tag, reserved, count, 3 numbers) written a second time, the
        // section count raised to 5: every section is there, the second copy differs
        let start = HEADER_LEN + SECTION_HEADER_LEN + 8 * s.host.len();
        let end = start + SECTION_HEADER_LEN + 8 * s.values.len();
        let mut again = b[start..end].to_vec();
        again[SECTION_HEADER_LEN..SECTION_HEADER_LEN + 8].copy_from_slice(&9.0f64.to_le_bytes());
        let mut twice = b[..end].to_vec();
        twice.extend_from_slice(&again);
        twice.extend_from_slice(&b[end..]);
        twice[12..16].copy_from_slice(&5u32.to_le_bytes());
        let err = Snapshot::from_bytes(&resealed(twice), 7).unwrap_err();
        assert!(err.contains("section 2 appears twice"), "{err}");

        let mut reserved = b.clone();
        reserved[HEADER_LEN + 4] = 1;
        let err = Snapshot::from_bytes(&resealed(reserved), 7).unwrap_err();
        assert!(err.contains("reserved word"), "{err}");
        // (the sealing itself keeps a sound state sound)
        assert_eq!(Snapshot::from_bytes(&resealed(b), 7).unwrap(), s);
    }
}
