//! The communicator: the only place that calls MPI. `Comm::Serial` is a run
//! without MPI (one process, every collective a no-op); `Comm::Mpi` wraps
//! rsmpi's world communicator. Everything physics needs from other ranks goes
//! through the handful of operations here.
//!
//! MPI is the cargo feature `mpi` (on by default). Without it (a library or
//! Python wheel built where no MPI is installed) only `Comm::Serial` exists and
//! a run started by mpirun says so and runs serially on every rank.

// without MPI every collective leaves its buffer as it is
#![cfg_attr(not(feature = "mpi"), allow(unused_variables))]

#[cfg(feature = "mpi")]
use mpi::datatype::PartitionMut;
#[cfg(feature = "mpi")]
use mpi::traits::*;

pub enum Comm {
    Serial,
    #[cfg(feature = "mpi")]
    Mpi { world: mpi::topology::SimpleCommunicator, _universe: mpi::environment::Universe, check: Option<SequenceCheck> },
}

/// The rule that keeps ranks from waiting on each other forever: every rank
/// makes the same collectives in the same order. Checked at run time where
/// `TALUS_CHECK_COLLECTIVES` is set (the MPI tests set it) and in every debug
/// build: before each collective the ranks compare its number in the run, its
/// name and the line that called it. A mismatch ends the job naming each
/// rank's collective and caller. Where `TALUS_COLLECTIVE_TIMEOUT` is set too,
/// a rank whose partners do not join within that many seconds ends the job
/// naming the collective it waits in (no limit unless set: rank 0 writing a
/// large checkpoint keeps the others waiting, rightly).
#[cfg(feature = "mpi")]
pub struct SequenceCheck {
    /// Collectives made so far on this rank.
    count: std::cell::Cell<u64>,
    /// Seconds a rank waits for the others to join before it gives up.
    timeout: f64,
}

/// One collective as the sequence check sees it: its name and the caller's line.
#[cfg(feature = "mpi")]
#[derive(Clone, Copy)]
struct Site {
    op: &'static str,
    at: &'static std::panic::Location<'static>,
}

#[cfg(feature = "mpi")]
impl Site {
    fn text(&self, n: u64) -> String {
        format!("collective #{n} `{}` called from {}:{}", self.op, self.at.file(), self.at.line())
    }

    /// A fingerprint of the name and the calling line (FNV-1a).
    fn key(&self) -> u64 {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in self.op.bytes().chain(self.at.file().bytes()).chain(self.at.line().to_le_bytes()) {
            h = (h ^ b as u64).wrapping_mul(0x0100_0000_01b3);
        }
        h
    }
}

/// Whether this process checks the ranks' sequences of collectives.
#[cfg(feature = "mpi")]
fn sequence_check() -> Option<SequenceCheck> {
    let on = match std::env::var("TALUS_CHECK_COLLECTIVES") {
        Ok(v) => !matches!(v.as_str(), "" | "0" | "no" | "off"),
        Err(_) => cfg!(debug_assertions),
    };
    let timeout = std::env::var("TALUS_COLLECTIVE_TIMEOUT").ok().and_then(|v| v.parse::<f64>().ok()).filter(|t| *t > 0.0);
    on.then(|| SequenceCheck { count: std::cell::Cell::new(0), timeout: timeout.unwrap_or(f64::INFINITY) })
}

/// Whether this process was started by an MPI launcher (mpirun / srun).
pub fn launched_by_mpi() -> bool {
    ["OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE", "MPI_LOCALNRANKS"]
        .iter()
        .any(|k| std::env::var_os(k).is_some())
}

impl Comm {
    /// MPI when launched by mpirun, else serial (P = 1 needs no mpirun).
    pub fn init() -> Comm {
        #[cfg(feature = "mpi")]
        if launched_by_mpi() {
            if let Some(u) = mpi::initialize() {
                let world = u.world();
                return Comm::Mpi { world, _universe: u, check: sequence_check() };
            }
        }
        #[cfg(not(feature = "mpi"))]
        if launched_by_mpi() {
            eprintln!("talus: warning: built without the `mpi` feature; every rank runs the whole case serially");
        }
        Comm::Serial
    }

    pub fn rank(&self) -> usize {
        match self {
            Comm::Serial => 0,
            #[cfg(feature = "mpi")]
            Comm::Mpi { world, .. } => world.rank() as usize,
        }
    }

    pub fn size(&self) -> usize {
        match self {
            Comm::Serial => 1,
            #[cfg(feature = "mpi")]
            Comm::Mpi { world, .. } => world.size() as usize,
        }
    }

    pub fn is_root(&self) -> bool {
        self.rank() == 0
    }

    /// Element-wise maximum over ranks, in place.
    #[track_caller]
    pub fn max_f64(&self, x: &mut [f64]) {
        #[cfg(feature = "mpi")]
        if let Comm::Mpi { world, .. } = self {
            self.check_sequence("max_f64");
            let send = x.to_vec();
            world.all_reduce_into(&send[..], x, mpi::collective::SystemOperation::max());
        }
    }

    /// Element-wise sum over ranks, in place (floating point: the order of the
    /// sum is MPI's; use `sum_exact` where the result must not depend on P).
    #[track_caller]
    pub fn sum_f64(&self, x: &mut [f64]) {
        #[cfg(feature = "mpi")]
        if let Comm::Mpi { world, .. } = self {
            self.check_sequence("sum_f64");
            let send = x.to_vec();
            world.all_reduce_into(&send[..], x, mpi::collective::SystemOperation::sum());
        }
    }

    #[track_caller]
    pub fn sum_u64(&self, x: &mut [u64]) {
        #[cfg(feature = "mpi")]
        if let Comm::Mpi { world, .. } = self {
            self.check_sequence("sum_u64");
            let send = x.to_vec();
            world.all_reduce_into(&send[..], x, mpi::collective::SystemOperation::sum());
        }
    }

    /// Exact element-wise sum of fixed-point values over ranks (integer
    /// addition is associative, so the result is the same for every P).
    #[track_caller]
    pub fn sum_exact(&self, x: &mut [i128]) {
        #[cfg(feature = "mpi")]
        if let Comm::Mpi { world, .. } = self {
            self.check_sequence("sum_exact");
            let send: Vec<i64> = x.iter().flat_map(|v| [(*v >> 64) as i64, *v as u64 as i64]).collect();
            let p = world.size() as usize;
            let mut all = vec![0i64; send.len() * p];
            world.all_gather_into(&send[..], &mut all[..]);
            for v in x.iter_mut() {
                *v = 0;
            }
            for r in 0..p {
                for (k, v) in x.iter_mut().enumerate() {
                    let hi = all[r * send.len() + 2 * k] as i128;
                    let lo = all[r * send.len() + 2 * k + 1] as u64 as i128;
                    *v = v.wrapping_add((hi << 64) | lo);
                }
            }
        }
    }

    /// Every rank's value, on every rank, in rank order. Without other ranks
    /// the value comes back as it is, moved: a gather of the whole state
    /// (checkpoints, snapshots, the state hash) makes no second copy of it there.
    #[track_caller]
    pub fn all_gather_values<T: serde::Serialize + for<'a> serde::Deserialize<'a>>(&self, mine: T) -> Vec<T> {
        match self {
            Comm::Serial => vec![mine],
            #[cfg(feature = "mpi")]
            Comm::Mpi { .. } => {
                let bytes = super::bin(&mine);
                drop(mine);
                self.all_gather_bytes(&bytes).into_iter().map(|b| super::unbin(&b)).collect()
            }
        }
    }

    /// Every rank's bytes, on every rank, in rank order.
    #[track_caller]
    pub fn all_gather_bytes(&self, mine: &[u8]) -> Vec<Vec<u8>> {
        #[cfg(feature = "mpi")]
        self.check_sequence("all_gather_bytes");
        self.gather_bytes_unchecked(mine)
    }

    /// `all_gather_bytes` without the sequence check (the check's own report uses it).
    fn gather_bytes_unchecked(&self, mine: &[u8]) -> Vec<Vec<u8>> {
        match self {
            Comm::Serial => vec![mine.to_vec()],
            #[cfg(feature = "mpi")]
            Comm::Mpi { world, .. } => {
                let p = world.size() as usize;
                let n = mine.len() as i32;
                let mut counts = vec![0i32; p];
                world.all_gather_into(&n, &mut counts[..]);
                let displs: Vec<i32> = counts.iter().scan(0, |a, &c| { let d = *a; *a += c; Some(d) }).collect();
                let total: i32 = counts.iter().sum();
                let mut buf = vec![0u8; total as usize];
                {
                    let mut part = PartitionMut::new(&mut buf[..], &counts[..], &displs[..]);
                    world.all_gather_varcount_into(mine, &mut part);
                }
                (0..p).map(|r| buf[displs[r] as usize..(displs[r] + counts[r]) as usize].to_vec()).collect()
            }
        }
    }

    /// Non-blocking point-to-point exchange (Isend / Irecv) of f64 buffers whose
    /// sizes both sides know: `sends[k]` goes to `to[k]`, `recvs[k]` is filled from
    /// `from[k]`. Returns when all have completed.
    /// Every rank calls it at the same point of the step (the sequence check
    /// counts it as a collective).
    #[track_caller]
    pub fn exchange_f64(&self, to: &[usize], sends: &[Vec<f64>], from: &[usize], recvs: &mut [Vec<f64>]) {
        #[cfg(not(feature = "mpi"))]
        let _ = (to, sends, from, recvs);
        #[cfg(feature = "mpi")]
        let Comm::Mpi { world, .. } = self else { return };
        #[cfg(feature = "mpi")]
        self.check_sequence("exchange_f64");
        #[cfg(feature = "mpi")]
        mpi::request::multiple_scope(to.len() + from.len(), |scope, coll| {
            for (k, buf) in recvs.iter_mut().enumerate() {
                coll.add(world.process_at_rank(from[k] as i32).immediate_receive_into(scope, &mut buf[..]));
            }
            for (k, buf) in sends.iter().enumerate() {
                coll.add(world.process_at_rank(to[k] as i32).immediate_send(scope, &buf[..]));
            }
            let mut done = Vec::new();
            coll.wait_all(&mut done);
        });
    }

    /// Exchange byte messages of sizes the receivers do not know: sizes go
    /// first (all-to-all), then the messages (Isend / Irecv) between the ranks
    /// that have something to say. `out[r]` is for rank r; returns what each
    /// rank sent to this one.
    #[track_caller]
    pub fn exchange_bytes(&self, out: &[Vec<u8>]) -> Vec<Vec<u8>> {
        match self {
            Comm::Serial => vec![out.first().cloned().unwrap_or_default()],
            #[cfg(feature = "mpi")]
            Comm::Mpi { world, .. } => {
                self.check_sequence("exchange_bytes");
                let p = world.size() as usize;
                let me = world.rank() as usize;
                let sizes: Vec<u64> = (0..p).map(|r| out[r].len() as u64).collect();
                let mut incoming = vec![0u64; p];
                world.all_to_all_into(&sizes[..], &mut incoming[..]);
                let mut recv: Vec<Vec<u8>> = incoming.iter().map(|&n| vec![0u8; n as usize]).collect();
                recv[me] = out[me].clone();
                let senders: Vec<usize> = (0..p).filter(|&r| r != me && incoming[r] > 0).collect();
                let targets: Vec<usize> = (0..p).filter(|&r| r != me && !out[r].is_empty()).collect();
                mpi::request::multiple_scope(senders.len() + targets.len(), |scope, coll| {
                    for (r, buf) in recv.iter_mut().enumerate() {
                        if r != me && incoming[r] > 0 {
                            coll.add(world.process_at_rank(r as i32).immediate_receive_into(scope, &mut buf[..]));
                        }
                    }
                    for &r in &targets {
                        coll.add(world.process_at_rank(r as i32).immediate_send(scope, &out[r][..]));
                    }
                    let mut done = Vec::new();
                    coll.wait_all(&mut done);
                });
                recv
            }
        }
    }

    /// The sequence check (see `SequenceCheck`): this rank's next collective
    /// is `op`, called from the caller's line. Nothing without the check.
    #[cfg(feature = "mpi")]
    #[track_caller]
    fn check_sequence(&self, op: &'static str) {
        self.check_site(Site { op, at: std::panic::Location::caller() });
    }

    #[cfg(feature = "mpi")]
    fn check_site(&self, site: Site) {
        let Comm::Mpi { world, check: Some(c), .. } = self else { return };
        let n = c.count.get() + 1;
        c.count.set(n);
        let mine = [n, site.key()];
        let p = world.size() as usize;
        let mut all = vec![0u64; 2 * p];
        wait_all_gather(world, &mine, &mut all, c.timeout, || site.text(n));
        if all.chunks(2).all(|r| r == mine) {
            return;
        }
        // every rank is in this check: each says where it is, rank 0 reports
        let texts = self.gather_bytes_unchecked(site.text(n).as_bytes());
        let lines: Vec<String> = texts.iter().enumerate().map(|(r, t)| format!("rank {r}: {}", String::from_utf8_lossy(t))).collect();
        if world.rank() == 0 {
            say(&format!(
                "talus: error: the ranks' collectives differ (a collective reached on some ranks only; every rank must make the same collectives in the same order): {}; ending the job",
                lines.join("; ")
            ));
        } else {
            std::thread::sleep(std::time::Duration::from_millis(500));
        }
        world.abort(70)
    }

    /// End every rank of the job (after an unrecoverable error on this one).
    pub fn abort(&self, code: i32) -> ! {
        match self {
            Comm::Serial => std::process::exit(code),
            #[cfg(feature = "mpi")]
            Comm::Mpi { world, .. } => world.abort(code),
        }
    }
}

/// The gather of the sequence check, waited for at most `timeout` seconds:
/// a rank whose partners never join says where it waits and ends the job.
#[cfg(feature = "mpi")]
fn wait_all_gather(world: &mpi::topology::SimpleCommunicator, send: &[u64], recv: &mut [u64], timeout: f64, what: impl Fn() -> String) {
    let start = std::time::Instant::now();
    mpi::request::scope(|scope| {
        let mut req = world.immediate_all_gather_into(scope, send, recv);
        let mut polls = 0u64;
        loop {
            match req.test() {
                Ok(_) => break,
                Err(r) => req = r,
            }
            polls += 1;
            if polls < 100 {
                std::hint::spin_loop();
                continue;
            }
            let waited = start.elapsed().as_secs_f64();
            if waited > timeout {
                say(&format!(
                    "talus: error: rank {} of {} waited {waited:.0} s in {} for the other ranks to join (TALUS_COLLECTIVE_TIMEOUT); ending the job",
                    world.rank(),
                    world.size(),
                    what()
                ));
                world.abort(75);
            }
            if waited < 1.0 {
                std::thread::yield_now();
            } else {
                std::thread::sleep(std::time::Duration::from_millis(1));
            }
        }
    });
}

/// A rank that ends (MPI_Finalize) while another waits in a collective is a
/// collective on some ranks only: the sequence check sees it here.
impl Drop for Comm {
    fn drop(&mut self) {
        #[cfg(feature = "mpi")]
        {
            self.check_site(Site { op: "MPI_Finalize (the end of the run)", at: std::panic::Location::caller() });
        }
    }
}

/// End the whole MPI job from anywhere (a panic hook): MPI_Abort on the world
/// communicator; without MPI, exit.
pub fn abort_world(code: i32) -> ! {
    #[cfg(feature = "mpi")]
    unsafe {
        mpi::ffi::MPI_Abort(mpi::ffi::RSMPI_COMM_WORLD, code);
    }
    std::process::exit(code)
}

/// One line to stderr in one write: under mpirun each write of a rank is
/// forwarded on its own, so a line written in pieces (as `eprintln!` writes
/// its format's parts) can be cut by mpirun's own messages, such as the
/// banner of the abort that follows it.
pub fn say(line: &str) {
    use std::io::Write as _;
    let _ = std::io::stderr().lock().write_all(format!("{line}\n").as_bytes());
}
