//! Checkpoints: the whole state of all ranks as one serial state (every
//! particle in id order, Gear rows, the contact history keyed by ids), so that
//! a run restarts from it on any number of ranks and replays bit for bit.
//!
//! File format (little endian):
//!
//! | bytes | what |
//! |---|---|
//! | 8 | magic `TALUSCKP` |
//! | 4 | format version ([`FORMAT_VERSION`]) |
//! | 8 | payload length L |
//! | 4 | CRC-32 (IEEE) of the payload |
//! | L | bincode (fixed-width integers) of [`Checkpoint`] |
//!
//! A checkpoint is written to `NAME.partial`, synced and renamed over `NAME`
//! ([`crate::durable::write_atomic`]), so a kill during the write leaves the
//! previous checkpoint. Reading checks magic, version, the length against the
//! file's size and the checksum before decoding, and decodes with the payload
//! length as the allocation limit: a truncated, corrupt or foreign file is
//! refused with its name, never an allocation abort or a silent wrong state.

use crate::durable::write_atomic;
use crate::error::TalusError;
use crate::integrate::GearState;
use crate::neighbor::{History, NeighborList};
use crate::sim::{Simulation, State};
use bincode::Options;
use std::io::Write;
use std::path::Path;

const MAGIC: &[u8; 8] = b"TALUSCKP";
/// Version of the checkpoint layout; bump it when `State` changes shape.
pub const FORMAT_VERSION: u32 = 4; // 3: contact history carries a rolling spring torque; 4: the list keeps no R*, m* per pair
const HEADER: usize = 8 + 4 + 8 + 4;

/// What a checkpoint holds: the case text's hash and the whole state.
#[derive(serde::Serialize, serde::Deserialize)]
pub struct Checkpoint {
    pub case_hash: u64,
    /// Ranks of the run that wrote it (for information).
    pub ranks: usize,
    pub state: State,
    pub history: History,
}

fn codec() -> impl Options {
    bincode::DefaultOptions::new().with_fixint_encoding().reject_trailing_bytes()
}

/// Hash of the case text, without its `[parallel]` and `[compare]` sections:
/// how the work is split does not change results, so a checkpoint restarts
/// under any.
pub fn case_hash(sim: &Simulation) -> u64 {
    // the parallel and compare sections change no result: left out whole (not
    // reset to their defaults, which a later version may change)
    let mut case = toml::Value::try_from(sim.case()).unwrap_or(toml::Value::Boolean(false));
    if let Some(t) = case.as_table_mut() {
        t.remove("parallel");
        t.remove("compare");
    }
    let text = toml::to_string(&case).unwrap_or_default();
    text.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3))
}

/// Encode a checkpoint as the bytes of a checkpoint file.
pub fn encode(ck: &Checkpoint) -> Result<Vec<u8>, TalusError> {
    let mut out = Vec::new();
    encode_into(ck, &mut out, false).map_err(|e| TalusError::Run(e.to_string()))?;
    Ok(out)
}

/// Write a checkpoint file's bytes to `w`, its payload encoded straight into
/// the writer: the header's length and checksum come from a first encoding
/// into a sink that only counts and checksums. No copy of the payload is held
/// in memory (H1-paper, 100,000 spheres: two copies of 36 MB were, and the
/// end-of-run checkpoint was the run's peak of resident memory). `pause`:
/// halfway through the payload, the test hook [`pause_for_tests`] runs.
pub fn encode_into(ck: &Checkpoint, w: &mut impl Write, pause: bool) -> std::io::Result<()> {
    // a bincode error from a writer is that writer's own error
    let io = |e: bincode::Error| match *e {
        bincode::ErrorKind::Io(e) => e,
        other => std::io::Error::other(format!("encoding a checkpoint: {other}")),
    };
    let mut sum = Sum { crc: crc32fast::Hasher::new(), len: 0 };
    codec().serialize_into(&mut sum, ck).map_err(io)?;
    w.write_all(MAGIC)?;
    w.write_all(&FORMAT_VERSION.to_le_bytes())?;
    w.write_all(&sum.len.to_le_bytes())?;
    w.write_all(&sum.crc.finalize().to_le_bytes())?;
    let pause_at = if pause { sum.len / 2 } else { u64::MAX };
    let mut out = Paused { w, written: 0, pause_at };
    codec().serialize_into(&mut out, ck).map_err(io)?;
    debug_assert_eq!(out.written, sum.len, "both encodings of a checkpoint give the same bytes");
    Ok(())
}

/// A sink that counts and checksums what is written to it.
struct Sum {
    crc: crc32fast::Hasher,
    len: u64,
}

impl Write for Sum {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.crc.update(b);
        self.len += b.len() as u64;
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// A writer that runs the test hook [`pause_for_tests`] once, when `pause_at`
/// bytes have gone through it.
struct Paused<'a, W: Write> {
    w: &'a mut W,
    written: u64,
    pause_at: u64,
}

impl<W: Write> Write for Paused<'_, W> {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        let n = self.w.write(b)?;
        let before = self.written;
        self.written += n as u64;
        if before < self.pause_at && self.written >= self.pause_at {
            pause_for_tests(self.w)?;
        }
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.w.flush()
    }
}

/// Decode the bytes of a checkpoint file; `path` names it in errors.
pub fn decode(bytes: &[u8], path: &Path) -> Result<Checkpoint, TalusError> {
    let bad = |why: String| TalusError::Input(format!("{}: {why}", path.display()));
    if bytes.len() < HEADER || &bytes[..8] != MAGIC {
        return Err(bad(format!(
            "not a talus checkpoint ({} bytes, no `TALUSCKP` header)",
            bytes.len()
        )));
    }
    let version = u32::from_le_bytes(bytes[8..12].try_into().unwrap());
    if version != FORMAT_VERSION {
        return Err(bad(format!(
            "checkpoint format version {version}; this talus reads version {FORMAT_VERSION}"
        )));
    }
    let len = u64::from_le_bytes(bytes[12..20].try_into().unwrap());
    let have = (bytes.len() - HEADER) as u64;
    if len != have {
        return Err(bad(format!(
            "truncated or damaged checkpoint: its header announces {len} bytes of data, the file holds {have}"
        )));
    }
    let crc = u32::from_le_bytes(bytes[20..24].try_into().unwrap());
    let payload = &bytes[HEADER..];
    let actual = crc32fast::hash(payload);
    if crc != actual {
        return Err(bad(format!(
            "corrupt checkpoint: checksum {actual:08x} of its data differs from the stored {crc:08x}"
        )));
    }
    codec()
        .with_limit(len)
        .deserialize(payload)
        .map_err(|e| bad(format!("checkpoint data does not decode ({e}); was it written by another version of talus?")))
}

/// Test hook: `TALUS_TEST_CHECKPOINT_PAUSE_MS` makes a checkpoint write pause
/// halfway through its temporary file, so a test can kill the run mid-write.
fn pause_for_tests(w: &mut impl Write) -> std::io::Result<()> {
    if let Some(ms) = std::env::var("TALUS_TEST_CHECKPOINT_PAUSE_MS").ok().and_then(|v| v.parse::<u64>().ok()) {
        w.flush()?;
        std::thread::sleep(std::time::Duration::from_millis(ms));
    }
    Ok(())
}

/// All ranks write one checkpoint together (a collective: gathered, rank 0 writes).
pub fn write(sim: &Simulation, path: &Path) -> Result<(), TalusError> {
    let st = sim.state();
    let history = sim.parallel().gather_history(st.nl.take_history(&st.p));
    let (p, rows) = sim.parallel().gather_particles(&st.p, &st.gear);
    let result = if sim.parallel().comm.is_root() {
        let mut gear = GearState { initialised: st.gear.initialised, ..Default::default() };
        gear.set_all(&rows);
        drop(rows);
        let state = State {
            p,
            walls: st.walls.clone(),
            nl: NeighborList { skin: st.nl.skin, builds: st.nl.builds, ..Default::default() },
            gear,
            time: st.time,
            step: st.step,
            phase: st.phase,
            phase_start: st.phase_start,
            settle_end: st.settle_end,
            pe0: st.pe0,
            forces_ready: st.forces_ready,
            contacts: st.contacts,
            clumps: st.clumps.clone(),
            analysis: st.analysis.clone(),
            inserts: st.inserts.clone(),
        };
        let ck = Checkpoint { case_hash: case_hash(sim), ranks: sim.parallel().size(), state, history };
        write_atomic(path, |w| encode_into(&ck, w, true))
    } else {
        Ok(())
    };
    sim.parallel().collective(result)
}

/// Read and check a checkpoint file.
pub fn load(path: &Path) -> Result<Checkpoint, TalusError> {
    let bytes = std::fs::read(path).map_err(|e| TalusError::io(format!("cannot read checkpoint {}", path.display()), e))?;
    decode(&bytes, path)
}

/// Replace the simulation's state by a checkpoint's (every rank reads the file
/// and keeps its own particles); refuse one written for another case.
pub fn read(sim: &mut Simulation, path: &Path) -> Result<(), TalusError> {
    // every rank reads the file: one that cannot stops them all
    let ck = sim.parallel().collective(load(path))?;
    if ck.case_hash != case_hash(sim) {
        return Err(TalusError::Input(format!(
            "{}: the checkpoint was written for a different case than {}",
            path.display(),
            sim.case().path.display()
        )));
    }
    // the case's particles, and those its phases had inserted by then
    let expected = sim.particle_count() + ck.state.inserts.inserted() - sim.state().inserts.inserted();
    if ck.state.p.len() as u64 != expected {
        return Err(TalusError::Input(format!(
            "{}: particle count differs from the case ({} in the checkpoint, {expected} expected)",
            path.display(),
            ck.state.p.len()
        )));
    }
    sim.restore(ck.state, ck.history);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Vec<u8> {
        let case = crate::case::Case::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/SC-pair.toml")).unwrap();
        let sim = Simulation::new(case).unwrap();
        let ck = Checkpoint { case_hash: case_hash(&sim), ranks: 1, state: sim.state().clone(), history: History::default() };
        encode(&ck).unwrap()
    }

    fn refused(bytes: &[u8]) -> String {
        decode(bytes, Path::new("x/checkpoint.bin")).err().expect("must be refused").to_string()
    }

    #[test]
    fn a_checkpoint_round_trips() {
        let b = sample();
        let ck = decode(&b, Path::new("c")).unwrap();
        assert_eq!(encode(&ck).unwrap(), b);
    }

    #[test]
    fn every_flipped_byte_is_refused_with_the_file_name() {
        let b = sample();
        // every byte of the header and a spread of payload bytes
        for i in (0..HEADER).chain((HEADER..b.len()).step_by(7)) {
            let mut c = b.clone();
            c[i] ^= 0x10;
            let e = refused(&c);
            assert!(e.starts_with("x/checkpoint.bin: "), "byte {i}: {e}");
        }
    }

    #[test]
    fn truncated_and_foreign_files_are_refused() {
        let b = sample();
        for n in [0, 5, HEADER, HEADER + 1, b.len() - 1] {
            assert!(refused(&b[..n]).contains("x/checkpoint.bin"), "{n} bytes accepted");
        }
        let e = refused(b"id,x,y,z,radius\n1,0,0,0,1\n");
        assert!(e.contains("not a talus checkpoint"), "{e}");
    }

    #[test]
    fn a_huge_length_field_is_refused_before_any_allocation() {
        let mut b = sample();
        b[12..20].copy_from_slice(&(1u64 << 40).to_le_bytes());
        let e = refused(&b);
        assert!(e.contains("announces 1099511627776 bytes"), "{e}");
        // a consistent header and checksum over a payload whose inner length prefix is huge
        let mut b = sample();
        let pl = HEADER + 8; // case_hash, then `ranks` (u64): corrupt the next length prefix region
        b[pl + 8..pl + 16].copy_from_slice(&(1u64 << 40).to_le_bytes());
        let crc = crc32fast::hash(&b[HEADER..]);
        b[20..24].copy_from_slice(&crc.to_le_bytes());
        let e = refused(&b);
        assert!(e.contains("does not decode"), "{e}");
    }
}
