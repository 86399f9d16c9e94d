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
    Mpi { world: mpi::topology::SimpleCommunicator, _universe: mpi::environment::Universe },
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
                return Comm::Mpi { world, _universe: u };
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
    pub fn max_f64(&self, x: &mut [f64]) {
        #[cfg(feature = "mpi")]
        if let Comm::Mpi { world, .. } = self {
            let send = x.to_vec();
            world.all_reduce_into(&send[..], x, mpi::collective::SystemOperation::max());
        }
    }

    /// Element-wise sum over ranks, in place (floating point: the order of the
    /// sum is MPI's; use `sum_exact` where the result must not depend on P).
    pub fn sum_f64(&self, x: &mut [f64]) {
        #[cfg(feature = "mpi")]
        if let Comm::Mpi { world, .. } = self {
            let send = x.to_vec();
            world.all_reduce_into(&send[..], x, mpi::collective::SystemOperation::sum());
        }
    }

    pub fn sum_u64(&self, x: &mut [u64]) {
        #[cfg(feature = "mpi")]
        if let Comm::Mpi { world, .. } = self {
            let send = x.to_vec();
            world.all_reduce_into(&send[..], x, mpi::collective::SystemOperation::sum());
        }
    }

    /// Exact element-wise sum of fixed-point values over ranks (integer
    /// addition is associative, so the result is the same for every P).
    pub fn sum_exact(&self, x: &mut [i128]) {
        #[cfg(feature = "mpi")]
        if let Comm::Mpi { world, .. } = self {
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
    pub fn all_gather_bytes(&self, mine: &[u8]) -> Vec<Vec<u8>> {
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
    pub fn exchange_f64(&self, to: &[usize], sends: &[Vec<f64>], from: &[usize], recvs: &mut [Vec<f64>]) {
        #[cfg(not(feature = "mpi"))]
        let _ = (to, sends, from, recvs);
        #[cfg(feature = "mpi")]
        let Comm::Mpi { world, .. } = self else { return };
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
    pub fn exchange_bytes(&self, out: &[Vec<u8>]) -> Vec<Vec<u8>> {
        match self {
            Comm::Serial => vec![out.first().cloned().unwrap_or_default()],
            #[cfg(feature = "mpi")]
            Comm::Mpi { world, .. } => {
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

    /// End every rank of the job (after an unrecoverable error on this one).
    pub fn abort(&self, code: i32) -> ! {
        match self {
            Comm::Serial => std::process::exit(code),
            #[cfg(feature = "mpi")]
            Comm::Mpi { world, .. } => world.abort(code),
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
