//! Saved FMU states (`fmi2FMUstate`) and their serialized form.
//!
//! A state is a boxed [`SavedState`]: the simulation's [`Snapshot`] plus the FMI lifecycle
//! fields (state-machine state, time, start and stop time). Serialized, it is plain
//! little-endian values behind a header (magic, version, total length, model hash), never a
//! pointer, so bytes written by one process restore in another.

use super::lifecycle::LifeState;
use crate::simulation::Snapshot;

const SERIAL_MAGIC: &[u8; 8] = b"CFMUSTAT";
const SERIAL_VERSION: u32 = 1;
/// Bytes before the snapshot: magic 8, version 4, flags 4, total length 8, model hash 8,
/// lifecycle 4, reserved 4, four times 8 x 4, snapshot length 8.
const HEADER_LEN: usize = 8 + 4 + 4 + 8 + 8 + 4 + 4 + 8 * 4 + 8;

/// Everything `fmi2SetFMUstate` needs to put an instance back where it was.
#[derive(Debug, Clone, PartialEq)]
pub struct SavedState {
    /// Hash of the scene text: a state only restores into an instance of the same model.
    pub model_hash: u64,
    /// The state-machine state.
    pub lifecycle: LifeState,
    /// Current communication point (s).
    pub time: f64,
    /// Start time from `fmi2SetupExperiment` (s).
    pub start_time: f64,
    /// Stop time, when defined (s).
    pub stop_time: Option<f64>,
    /// End of the last successful step (s).
    pub last_successful_time: f64,
    /// Parameter values and engine state.
    pub snapshot: Snapshot,
}

impl SavedState {
    /// Wraps the parts of a state.
    pub fn new(
        model_hash: u64,
        lifecycle: LifeState,
        time: f64,
        start_time: f64,
        stop_time: Option<f64>,
        last_successful_time: f64,
        snapshot: Snapshot,
    ) -> SavedState {
        SavedState {
            model_hash,
            lifecycle,
            time,
            start_time,
            stop_time,
            last_successful_time,
            snapshot,
        }
    }

    /// The serialized bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let snap = self.snapshot.to_bytes();
        let total = HEADER_LEN + snap.len();
        let mut b = Vec::with_capacity(total);
        b.extend_from_slice(SERIAL_MAGIC);
        b.extend_from_slice(&SERIAL_VERSION.to_le_bytes());
        let flags: u32 = u32::from(self.stop_time.is_some());
        b.extend_from_slice(&flags.to_le_bytes());
        b.extend_from_slice(&(total as u64).to_le_bytes());
        b.extend_from_slice(&self.model_hash.to_le_bytes());
        b.extend_from_slice(&self.lifecycle.code().to_le_bytes());
        b.extend_from_slice(&0u32.to_le_bytes());
        for x in [
            self.time,
            self.start_time,
            self.stop_time.unwrap_or(0.0),
            self.last_successful_time,
        ] {
            b.extend_from_slice(&x.to_le_bytes());
        }
        b.extend_from_slice(&(snap.len() as u64).to_le_bytes());
        b.extend_from_slice(&snap);
        debug_assert_eq!(b.len(), total);
        b
    }

    /// Parses bytes written by [`SavedState::to_bytes`], checking magic, version and lengths.
    pub fn from_bytes(b: &[u8]) -> Result<SavedState, String> {
        if b.len() < HEADER_LEN {
            return Err(format!(
                "serialized FMU state has {} bytes, fewer than its {HEADER_LEN}-byte header",
                b.len()
            ));
        }
        if &b[0..8] != SERIAL_MAGIC {
            return Err("serialized FMU state has a wrong magic number (not written by contact-fmu)".into());
        }
        let mut r = Reader { b, pos: 8 };
        let version = r.u32();
        if version != SERIAL_VERSION {
            return Err(format!(
                "serialized FMU state has version {version}, this library reads version {SERIAL_VERSION}"
            ));
        }
        let flags = r.u32();
        let total = r.u64();
        if total != b.len() as u64 {
            return Err(format!(
                "serialized FMU state is {} bytes long but its header says {total}",
                b.len()
            ));
        }
        let model_hash = r.u64();
        let code = r.u32();
        let lifecycle = LifeState::from_code(code)
            .ok_or_else(|| format!("serialized FMU state has an unknown lifecycle code {code}"))?;
        let _reserved = r.u32();
        let time = r.f64();
        let start_time = r.f64();
        let stop = r.f64();
        let last_successful_time = r.f64();
        let snap_len = r.u64();
        if snap_len != (b.len() - HEADER_LEN) as u64 {
            return Err(format!(
                "serialized FMU state: snapshot length {snap_len} does not match the {} bytes present",
                b.len() - HEADER_LEN
            ));
        }
        let snapshot = Snapshot::from_bytes(&b[HEADER_LEN..])?;
        Ok(SavedState::new(
            model_hash,
            lifecycle,
            time,
            start_time,
            if flags & 1 != 0 { Some(stop) } else { None },
            last_successful_time,
            snapshot,
        ))
    }
}

struct Reader<'a> {
    b: &'a [u8],
    pos: usize,
}

impl Reader<'_> {
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let mut out = [0u8; N];
        out.copy_from_slice(&self.b[self.pos..self.pos + N]);
        self.pos += N;
        out
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.take())
    }
    fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> SavedState {
        SavedState::new(
            0xdead_beef_0123_4567,
            LifeState::StepComplete,
            0.125,
            0.0,
            Some(2.0),
            0.125,
            Snapshot {
                values: vec![1.0, -2.5, 1e-300],
                initialized: true,
                state: vec![0.1, f64::MIN_POSITIVE, -0.0],
            },
        )
    }

    #[test]
    fn serialization_round_trips_bit_for_bit() {
        let s = sample();
        let b = s.to_bytes();
        let back = SavedState::from_bytes(&b).unwrap();
        assert_eq!(back.to_bytes(), b);
        assert_eq!(back.lifecycle, LifeState::StepComplete);
        assert_eq!(back.stop_time, Some(2.0));
        assert_eq!(back.snapshot.state[2].to_bits(), (-0.0f64).to_bits());
        let mut no_stop = sample();
        no_stop.stop_time = None;
        assert_eq!(SavedState::from_bytes(&no_stop.to_bytes()).unwrap().stop_time, None);
    }

    #[test]
    fn damaged_bytes_are_refused_with_a_reason() {
        let b = sample().to_bytes();
        assert!(SavedState::from_bytes(&b[..b.len() - 1])
            .unwrap_err()
            .contains("header says"));
        assert!(SavedState::from_bytes(&b[..10]).unwrap_err().contains("header"));
        let mut wrong_magic = b.clone();
        wrong_magic[0] ^= 1;
        assert!(SavedState::from_bytes(&wrong_magic).unwrap_err().contains("magic"));
        let mut wrong_version = b.clone();
        wrong_version[8] = 99;
        assert!(SavedState::from_bytes(&wrong_version).unwrap_err().contains("version"));
        let mut wrong_state = b.clone();
        wrong_state[32] = 3; // lifecycle code 3 is no single state
        assert!(SavedState::from_bytes(&wrong_state).unwrap_err().contains("lifecycle"));
    }
}
