//! Collectives that steer the run: the per-step agreement (rebuild, failure,
//! signal) and making an error on one rank an error on every rank, so all
//! ranks stop at the same step and write the same outputs.

use super::comm::Comm;
use super::Parallel;
use crate::error::TalusError;
use crate::neighbor::{top_two, Moved};

impl Parallel {
    /// Every rank's message (empty ones dropped), joined.
    #[track_caller]
    fn gather_messages(&self, mine: Option<String>) -> String {
        gather_messages(&self.comm, mine)
    }

    /// One collective per step: whether any rank needs a list rebuild for a
    /// reason of its own (`need`), how far the particles of all ranks moved
    /// since the last build (`moved`, each rank's own in; the largest and the
    /// sum of the two largest of all out, the same bits on any rank count), and
    /// whether any rank has failed (then every rank gets every rank's message).
    /// A stop asked for by a signal on any rank (see `crate::signals`) is
    /// agreed on in the same collective and kept in `stop`.
    #[track_caller]
    pub fn agree(&mut self, need: bool, moved: Moved, error: Option<String>) -> (bool, Moved, Option<String>) {
        let t = std::time::Instant::now();
        let signal = crate::signals::requested();
        // one maximum: the flags, the largest sum of a rank's own two largest
        // displacements past half their skins, the largest past the whole
        // skin (walls), and each rank's largest past half in its own slot
        // (the two largest of those give the sum of two on different ranks;
        // the other ranks' slots start at minus infinity: these can be below 0)
        let mut v = vec![f64::NEG_INFINITY; 5 + self.size()];
        v[..5].copy_from_slice(&[need as u8 as f64, error.is_some() as u8 as f64, signal.unwrap_or(0) as f64, moved.two, moved.wall]);
        v[5 + self.rank()] = moved.first;
        self.comm.max_f64(&mut v);
        if v[2] > 0.0 && self.stop.is_none() {
            self.stop = Some(v[2] as i32);
        }
        let [m1, m2] = v[5..].iter().fold([f64::NEG_INFINITY; 2], |t, &d| top_two(t, [d, f64::NEG_INFINITY]));
        let all = Moved { first: m1, two: v[3].max(m1 + m2), wall: v[4] };
        let err = (v[1] > 0.0).then(|| self.gather_messages(error));
        let dt = t.elapsed().as_secs_f64();
        self.timers.agree += dt;
        self.timers.comm_s += dt;
        (v[0] > 0.0, all, err)
    }

    /// Make a result collective: if it is an error on any rank, it is an error
    /// on every rank (with every failing rank's message).
    #[track_caller]
    pub fn collective<T>(&self, r: Result<T, TalusError>) -> Result<T, TalusError> {
        agreed(&self.comm, r)
    }
}

/// "rank r of P: " before a message under MPI; nothing with one rank.
fn label(comm: &Comm, msg: &str) -> String {
    if comm.size() > 1 { format!("rank {} of {}: {msg}", comm.rank(), comm.size()) } else { msg.to_string() }
}

/// Every rank's message (empty ones dropped), joined.
#[track_caller]
fn gather_messages(comm: &Comm, mine: Option<String>) -> String {
    let mine = mine.map(|m| label(comm, &m)).unwrap_or_default();
    let all = comm.all_gather_bytes(mine.as_bytes());
    let msgs: Vec<String> = all.iter().filter(|m| !m.is_empty()).map(|m| String::from_utf8_lossy(m).to_string()).collect();
    msgs.join("; ")
}

/// Make a result collective on a communicator (`Parallel::collective` before
/// there is a `Parallel`: reading the case, its files, making the threads): an
/// error on any rank is an error on every rank. Where every rank failed with
/// the same message (the same input read everywhere), each keeps its own error,
/// kind and all; else every rank gets every failing rank's message.
#[track_caller]
pub fn agreed<T>(comm: &Comm, r: Result<T, TalusError>) -> Result<T, TalusError> {
    let mut v = [r.is_err() as u8 as f64, 0.0];
    if comm.size() == 1 {
        return r; // the error itself, with its own kind
    }
    v[1] = -(r.is_ok() as u8 as f64); // the largest is 0 where every rank failed
    comm.max_f64(&mut v);
    if v[0] == 0.0 {
        return r;
    }
    let mine = r.as_ref().err().map(|e| e.to_string());
    let all = comm.all_gather_values(mine.clone());
    if v[1] == 0.0 && all.iter().all(|m| m == &mine) {
        return r;
    }
    Err(TalusError::Run(gather_messages(comm, mine)))
}
