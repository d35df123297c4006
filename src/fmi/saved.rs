//! Saved FMU states (`fmi2FMUstate`, `fmi3FMUState`) and their serialized form.
//!
//! A state is a boxed [`SavedState`]: the simulation's [`Snapshot`] (parameter values and
//! the model's state, see `crate::model::state`) plus the FMI lifecycle fields (state-machine
//! state, start and stop time) carried in the snapshot's host numbers. Serialized, it is the
//! one checkpoint format of [`crate::checkpoint`] (plain little-endian numbers behind a
//! header, with the model hash and a checksum), so bytes written by one process restore in
//! another, and damaged bytes are refused. The two FMI versions write the same format; an FMI
//! 3.0 state has a fifth host number, 3, so that each version tells the other's states apart.

use super::lifecycle::{LifeState, Version};
use crate::checkpoint::Snapshot;

/// Host numbers in the snapshot of FMI 2.0: lifecycle code, start time, stop flag, stop time;
/// FMI 3.0 adds its version number, [`FMI3_MARK`].
const HOST_LEN: usize = 4;

/// The fifth host number of an FMI 3.0 state.
const FMI3_MARK: f64 = 3.0;

/// Everything `fmi2SetFMUstate` needs to put an instance back where it was.
#[derive(Debug, Clone, PartialEq)]
pub struct SavedState {
    /// Hash of the scene text: a state only restores into an instance of the same model.
    pub model_hash: u64,
    /// The FMI version of the instance that saved it.
    pub version: Version,
    /// The state-machine state.
    pub lifecycle: LifeState,
    /// Start time from `fmi2SetupExperiment` (s).
    pub start_time: f64,
    /// Stop time, when defined (s).
    pub stop_time: Option<f64>,
    /// Parameter values and the model's state (its time is the communication point).
    pub snapshot: Snapshot,
}

impl SavedState {
    /// Wraps the parts of a state.
    pub fn new(
        model_hash: u64,
        version: Version,
        lifecycle: LifeState,
        start_time: f64,
        stop_time: Option<f64>,
        snapshot: Snapshot,
    ) -> SavedState {
        SavedState {
            model_hash,
            version,
            lifecycle,
            start_time,
            stop_time,
            snapshot,
        }
    }

    /// The serialized bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut s = self.snapshot.clone();
        s.host = vec![
            f64::from(self.lifecycle.code()),
            self.start_time,
            self.stop_time.is_some() as u8 as f64,
            self.stop_time.unwrap_or(0.0),
        ];
        if self.version == Version::Fmi3 {
            s.host.push(FMI3_MARK);
        }
        s.to_bytes(self.model_hash)
    }

    /// Parses bytes written by [`SavedState::to_bytes`] for the model with `model_hash`.
    pub fn from_bytes(b: &[u8], model_hash: u64) -> Result<SavedState, String> {
        let mut snapshot = Snapshot::from_bytes(b, model_hash).map_err(|e| format!("FMU state: {e}"))?;
        let host = std::mem::take(&mut snapshot.host);
        let (version, [code, start_time, has_stop, stop]) = match host[..] {
            [a, b, c, d] => (Version::Fmi2, [a, b, c, d]),
            [a, b, c, d, FMI3_MARK] => (Version::Fmi3, [a, b, c, d]),
            _ => {
                return Err(format!(
                    "FMU state: {} host numbers, expected {HOST_LEN} (FMI 2.0) or {} (FMI 3.0)",
                    host.len(),
                    HOST_LEN + 1
                ))
            }
        };
        let lifecycle = (code.fract() == 0.0 && (0.0..=f64::from(u32::MAX)).contains(&code))
            .then(|| LifeState::from_code(code as u32))
            .flatten()
            .ok_or_else(|| format!("FMU state has an unknown lifecycle code {code}"))?;
        if !start_time.is_finite() || !stop.is_finite() || (has_stop != 0.0 && has_stop != 1.0) {
            return Err("FMU state: start or stop time is not a finite number".into());
        }
        let stop_time = (has_stop == 1.0).then_some(stop);
        check_lifecycle(lifecycle, start_time, stop_time, &snapshot)?;
        Ok(SavedState::new(
            model_hash, version, lifecycle, start_time, stop_time, snapshot,
        ))
    }
}

/// Refuses lifecycle fields no instance saves: the fatal state (no state is saved there), a
/// model initialised before initialisation mode ended or not initialised after it, a time
/// before the start time or past the stop time (by more than a step ending there may pass it).
fn check_lifecycle(
    lifecycle: LifeState,
    start_time: f64,
    stop_time: Option<f64>,
    snapshot: &Snapshot,
) -> Result<(), String> {
    let initialised = match lifecycle {
        LifeState::Fatal => return Err("FMU state in the fatal state: no state is saved there".into()),
        LifeState::Instantiated | LifeState::InitializationMode => Some(false),
        LifeState::Error => None,
        _ => Some(true),
    };
    if initialised.is_some_and(|i| i != snapshot.initialized) {
        return Err(format!(
            "FMU state in the {} state holds a model that is {}initialised",
            lifecycle.name(),
            if snapshot.initialized { "" } else { "not " }
        ));
    }
    // (an initialised model's state begins with its time)
    let Some(&time) = snapshot.state.first().filter(|_| snapshot.initialized) else {
        return Ok(());
    };
    let past_stop = stop_time.is_some_and(|stop| time > stop + 1e-9 * stop.abs().max(time - start_time));
    if time < start_time || past_stop {
        return Err(format!(
            "FMU state at t = {time} outside its experiment's times (start {start_time}, stop {})",
            stop_time.map_or("none".to_string(), |s| s.to_string())
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> SavedState {
        SavedState::new(
            0xdead_beef_0123_4567,
            Version::Fmi2,
            LifeState::StepComplete,
            0.0,
            Some(2.0),
            Snapshot {
                host: Vec::new(),
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
        let back = SavedState::from_bytes(&b, s.model_hash).unwrap();
        assert_eq!(back.to_bytes(), b);
        assert_eq!(back.lifecycle, LifeState::StepComplete);
        assert_eq!(back.stop_time, Some(2.0));
        assert_eq!(back.snapshot.state[2].to_bits(), (-0.0f64).to_bits());
        let mut no_stop = sample();
        no_stop.stop_time = None;
        assert_eq!(
            SavedState::from_bytes(&no_stop.to_bytes(), s.model_hash)
                .unwrap()
                .stop_time,
            None
        );
    }

    #[test]
    fn the_versions_are_told_apart() {
        let mut s = sample();
        let two = s.to_bytes();
        s.version = Version::Fmi3;
        let three = s.to_bytes();
        assert_eq!(three.len(), two.len() + 8, "one more host number");
        let back = SavedState::from_bytes(&three, s.model_hash).unwrap();
        assert_eq!(back.version, Version::Fmi3);
        assert_eq!(back.to_bytes(), three);
        assert_eq!(
            SavedState::from_bytes(&two, s.model_hash).unwrap().version,
            Version::Fmi2
        );
        let mut snap = s.snapshot.clone();
        snap.host = vec![4.0, 0.0, 0.0, 0.0, 2.0];
        assert!(SavedState::from_bytes(&snap.to_bytes(s.model_hash), s.model_hash)
            .unwrap_err()
            .contains("host numbers"));
    }

    #[test]
    fn damaged_bytes_are_refused_with_a_reason() {
        let s = sample();
        let b = s.to_bytes();
        let h = s.model_hash;
        assert!(SavedState::from_bytes(&b[..b.len() - 1], h)
            .unwrap_err()
            .contains("checksum"));
        assert!(SavedState::from_bytes(&b[..10], h).unwrap_err().contains("header"));
        let mut wrong_magic = b.clone();
        wrong_magic[0] ^= 1;
        assert!(SavedState::from_bytes(&wrong_magic, h).unwrap_err().contains("magic"));
        let mut wrong_version = b.clone();
        wrong_version[8] = 99;
        assert!(SavedState::from_bytes(&wrong_version, h)
            .unwrap_err()
            .contains("version"));
        let mut flipped = b.clone();
        flipped[40] ^= 4;
        assert!(SavedState::from_bytes(&flipped, h).unwrap_err().contains("checksum"));
        assert!(SavedState::from_bytes(&b, h ^ 1)
            .unwrap_err()
            .contains("different model"));
        let mut bad_lifecycle = sample();
        bad_lifecycle.snapshot.host = Vec::new();
        let mut snap = bad_lifecycle.snapshot.clone();
        snap.host = vec![3.0, 0.0, 0.0, 0.0]; // lifecycle code 3 is no single state
        assert!(SavedState::from_bytes(&snap.to_bytes(h), h)
            .unwrap_err()
            .contains("lifecycle"));
    }

    /// Lifecycle fields no instance writes, in bytes that pass every check of the format (a
    /// host that crafts them, or a damage the checksum misses), are refused: before, the
    /// fatal state was restored (every later call refused), and a model initialised in the
    /// instantiated state or a time past the stop time left an instance no step could move.
    #[test]
    fn lifecycle_fields_no_instance_saves_are_refused() {
        let h = sample().model_hash;
        let refused = |s: SavedState| SavedState::from_bytes(&s.to_bytes(), h).unwrap_err();
        let mut s = sample();
        s.lifecycle = LifeState::Fatal;
        assert!(refused(s).contains("fatal"));
        for lifecycle in [LifeState::Instantiated, LifeState::InitializationMode] {
            let mut s = sample();
            s.lifecycle = lifecycle;
            assert!(refused(s).contains("is initialised"), "{lifecycle:?}");
        }
        for lifecycle in [LifeState::StepComplete, LifeState::Terminated] {
            let mut s = sample();
            s.lifecycle = lifecycle;
            s.snapshot.initialized = false;
            s.snapshot.state.clear();
            assert!(refused(s).contains("not initialised"), "{lifecycle:?}");
        }
        // (the state's time is 0.1)
        let mut s = sample();
        s.stop_time = Some(0.05);
        assert!(refused(s).contains("outside its experiment's times"));
        let mut s = sample();
        s.start_time = 0.2;
        assert!(refused(s).contains("outside its experiment's times"));
        // what instances do save is read back: the error state with a model initialised or
        // not, a step that ended a rounding error past the stop time
        for initialized in [true, false] {
            let mut s = sample();
            s.lifecycle = LifeState::Error;
            s.snapshot.initialized = initialized;
            if !initialized {
                s.snapshot.state.clear();
            }
            assert!(SavedState::from_bytes(&s.to_bytes(), h).is_ok());
        }
        let mut s = sample();
        s.stop_time = Some(0.1 - 1e-12);
        assert!(SavedState::from_bytes(&s.to_bytes(), h).is_ok());
        let mut s = sample();
        s.lifecycle = LifeState::Instantiated;
        s.snapshot.initialized = false;
        s.snapshot.state.clear();
        assert!(SavedState::from_bytes(&s.to_bytes(), h).is_ok());
    }
}
