//! Checkpoints: `checkpoint.bin` in the output folder holds everything a run needs to go on exactly as if it
//! had not stopped: the whole [`State`] (serialised generically, so fields added to it are included), the
//! stepper's warm state (the contact term's closest-point cache and active set, [`WarmState`], the linear
//! solver's starting guess, the automatic choice's picks and the step matrix's pairs between faces,
//! [`SolverWarm`]) and counters, the run's statistics so far, and the
//! state of every output by its name ([`super::outputs::Output::save`]: the frames written, the length of
//! `energy.csv`, the positions of the steps pictured, the animation's frames…). A resumed run restores all
//! this (`energy.csv` truncated to its length at the checkpoint) and continues; its outputs are byte-identical
//! to an uninterrupted run's (tests/suite/resume.rs).
//!
//! The file is written atomically (temporary file, then rename), so a kill leaves the previous checkpoint or
//! the new one. Layout: the magic line `flexsurf-checkpoint\n`, the format version (u32, little-endian), the
//! SHA-256 of the payload (32 bytes), the payload ([`postcard`], a compact, stable serde format, because the
//! state holds non-finite values a text format cannot: the contact cache starts at −∞). A checkpoint of another
//! version, with a wrong checksum, or of another run (its fingerprint) is refused with a message saying which.

use super::manifest::Folder;
use super::outputs::OutputState;
use super::RunError;
use crate::integrate::linsolve::SolverWarm;
use crate::integrate::{Counters, Stepper};
use crate::io::atomic;
use crate::potential::WarmState;
use crate::sim::RunStats;
use crate::state::State;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::io;
use std::path::{Path, PathBuf};

/// The checkpoint's file name in the output folder.
pub const CHECKPOINT: &str = "checkpoint.bin";
const MAGIC: &[u8] = b"flexsurf-checkpoint\n";
/// The checkpoint format version; bumped whenever [`Checkpoint`] or anything in it changes shape.
pub const VERSION: u32 = 11;
/// The largest checkpoint read (bytes).
const MAX_BYTES: u64 = 16 << 30;

/// Everything a run needs to continue from a step.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Checkpoint {
    /// The run's fingerprint ([`super::fingerprint`]).
    pub fingerprint: String,
    /// The state after the checkpoint's step.
    pub state: State,
    /// The stepper's warm state.
    pub warm: WarmState,
    /// The stepper's per-stage counters.
    pub counters: CountersSaved,
    /// The linear solver's warm state (starting guess, picks, the step matrix's pairs between faces).
    pub solver: SolverWarm,
    /// The run's statistics so far.
    pub stats: StatsSaved,
    /// The state of every output, by its name.
    pub outputs: Vec<(String, OutputState)>,
}

/// [`Counters`] as saved.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CountersSaved {
    /// Assembly, contact, self-contact, factorisation, solve.
    seconds: [f64; 5],
    /// Steps, solves, iterations, factorisations, re-solves, Newton corrections, unconverged steps, contact
    /// steps, self-contact records, broad-phase builds and refits, steps of an iterative solver.
    counts: [usize; 12],
    /// The largest final relative Newton residual.
    residual_max: f64,
}

impl From<Counters> for CountersSaved {
    fn from(c: Counters) -> Self {
        Self {
            seconds: [c.assembly, c.contact, c.self_contact, c.factorization, c.solve],
            counts: [
                c.steps,
                c.solves,
                c.iterations,
                c.factorizations,
                c.resolves,
                c.corrections,
                c.unconverged,
                c.contact_steps,
                c.self_contact_pairs,
                c.broad_builds,
                c.broad_refits,
                c.iterative_steps,
            ],
            residual_max: c.residual_max,
        }
    }
}

impl From<CountersSaved> for Counters {
    fn from(c: CountersSaved) -> Self {
        let [assembly, contact, self_contact, factorization, solve] = c.seconds;
        let [steps, solves, iterations, factorizations, resolves, corrections, unconverged, contact_steps, self_contact_pairs, broad_builds, broad_refits, iterative_steps] =
            c.counts;
        Counters {
            assembly,
            contact,
            self_contact,
            factorization,
            solve,
            steps,
            solves,
            iterations,
            factorizations,
            resolves,
            corrections,
            unconverged,
            contact_steps,
            residual_max: c.residual_max,
            self_contact_pairs,
            broad_builds,
            broad_refits,
            iterative_steps,
        }
    }
}

/// [`RunStats`] as saved.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StatsSaved {
    steps: usize,
    wall_seconds: f64,
    max_penetration_seen: f64,
    max_contacts: usize,
}

impl From<RunStats> for StatsSaved {
    fn from(s: RunStats) -> Self {
        Self {
            steps: s.steps,
            wall_seconds: s.wall_seconds,
            max_penetration_seen: s.max_penetration_seen,
            max_contacts: s.max_contacts,
        }
    }
}

impl From<StatsSaved> for RunStats {
    fn from(s: StatsSaved) -> Self {
        RunStats {
            steps: s.steps,
            wall_seconds: s.wall_seconds,
            max_penetration_seen: s.max_penetration_seen,
            max_contacts: s.max_contacts,
        }
    }
}

fn bad(path: &Path, message: String) -> RunError {
    RunError::Resume(format!("{}: {message}", path.display()))
}

/// The checkpoint path in `out`.
pub fn path_in(out: &Path) -> PathBuf {
    out.join(CHECKPOINT)
}

/// The warm state of `stepper`, as a checkpoint needs it.
pub fn stepper_state(
    stepper: &Stepper,
    model: &crate::model::Model,
    path: &Path,
) -> Result<(WarmState, CountersSaved), RunError> {
    let warm = stepper
        .warm_state(model)
        .map_err(|e| RunError::Io { path: path.to_path_buf(), source: io::Error::other(e) })?;
    Ok((warm, stepper.counters.into()))
}

/// Encodes `ck` (header, version, checksum, payload).
pub fn encode(ck: &Checkpoint) -> Result<Vec<u8>, String> {
    let payload = postcard::to_stdvec(ck).map_err(|e| format!("cannot encode the checkpoint: {e}"))?;
    let mut bytes = Vec::with_capacity(MAGIC.len() + 4 + 32 + payload.len());
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&VERSION.to_le_bytes());
    bytes.extend_from_slice(&Sha256::digest(&payload));
    bytes.extend_from_slice(&payload);
    Ok(bytes)
}

/// Decodes a checkpoint written by [`encode`], checking header, version and checksum.
pub fn decode(bytes: &[u8]) -> Result<Checkpoint, String> {
    let rest = bytes.strip_prefix(MAGIC).ok_or("it is not a flexsurf checkpoint")?;
    if rest.len() < 36 {
        return Err("it is truncated".into());
    }
    let (version, rest) = rest.split_at(4);
    let version = u32::from_le_bytes([version[0], version[1], version[2], version[3]]);
    if version != VERSION {
        return Err(format!("it is of format version {version}; this flexsurf reads version {VERSION}"));
    }
    let (sum, payload) = rest.split_at(32);
    if Sha256::digest(payload).as_slice() != sum {
        return Err("its checksum does not match (the file is damaged)".into());
    }
    postcard::from_bytes(payload).map_err(|e| format!("cannot decode it: {e}"))
}

/// Writes `ck` into `out` atomically.
pub fn write(out: &Path, ck: &Checkpoint) -> Result<(), RunError> {
    let path = path_in(out);
    let bytes = encode(ck).map_err(|e| RunError::Io { path: path.clone(), source: io::Error::other(e) })?;
    atomic::write_atomic(&path, &bytes).map_err(|source| RunError::Io { path, source })
}

/// Reads the checkpoint in `out` and checks it belongs to the run `fingerprint`.
pub fn read(out: &Path, fingerprint: &str) -> Result<Checkpoint, RunError> {
    let path = path_in(out);
    let bytes = crate::io::input::read_bytes_limited(&path, MAX_BYTES).map_err(|e| {
        // A missing checkpoint: say why by the folder's manifest (resuming a complete run was "No such file").
        let why =
            std::fs::symlink_metadata(&path).is_err().then(|| Folder::why_no_checkpoint(out, fingerprint)).flatten();
        bad(&path, why.unwrap_or_else(|| format!("cannot read the checkpoint to resume from: {e}")))
    })?;
    let ck = decode(&bytes).map_err(|e| bad(&path, format!("cannot resume from this checkpoint: {e}")))?;
    if ck.fingerprint != fingerprint {
        return Err(bad(
            &path,
            "cannot resume: the checkpoint is of another scene or other settings (the scene, a file it reads or a \
             command-line override changed)"
                .into(),
        ));
    }
    Ok(ck)
}

/// The checkpoint `ck` (read by [`read`], of this run's fingerprint) checked against `scene` before use: the
/// size of every vector against the model's node count (and the display mesh's vertex count), finiteness, the
/// steps and counts against the run's. The checksum only detects damage, and a forged file with a valid one
/// must give this error, never a panic or a run that silently goes wrong.
pub fn validated(ck: Checkpoint, scene: &crate::scene::Scene) -> Result<Checkpoint, RunError> {
    let path = PathBuf::from(CHECKPOINT);
    check_against(&ck, scene).map_err(|e| {
        bad(
            &path,
            format!("cannot resume: the checkpoint does not fit the scene ({e}); it is damaged or not this run's"),
        )
    })?;
    Ok(ck)
}

fn all_finite(v: &[crate::math::Vec3]) -> bool {
    v.iter().all(|p| crate::math::finite(*p))
}

fn check_against(ck: &Checkpoint, scene: &crate::scene::Scene) -> Result<(), String> {
    let n = scene.state.x.len();
    let st = &ck.state;
    for (name, v) in [("x", &st.x), ("x_prev", &st.x_prev), ("v", &st.v), ("v_prev", &st.v_prev)] {
        if v.len() != n {
            return Err(format!("the state's `{name}` has {} nodes, the model {n}", v.len()));
        }
        if !all_finite(v) {
            return Err(format!("the state's `{name}` holds a non-finite value"));
        }
    }
    if st.step == 0 || st.step >= scene.steps || !(st.time.is_finite() && st.time >= 0.0) {
        return Err(format!(
            "its step {} (t = {} s) is not one inside the run's {} steps",
            st.step, st.time, scene.steps
        ));
    }
    if ck.solver.guess.len() != n || !all_finite(&ck.solver.guess) {
        return Err(format!("the solver's guess is not {n} finite values"));
    }
    // The terms' states are checked by each term as it restores them (`Term::restore`), the outputs' states by
    // each output as it starts from them (`Output::start`).
    let stats = &ck.stats;
    if stats.steps > st.step || !(stats.wall_seconds.is_finite() && stats.max_penetration_seen.is_finite()) {
        return Err("its run statistics do not fit its step".into());
    }
    if ck.counters.seconds.iter().any(|s| !s.is_finite()) {
        return Err("its counters hold a non-finite value".into());
    }
    Ok(())
}
