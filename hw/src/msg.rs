//! The messages that cross links between units.

/// A patch-load request from a CTU to the global memory's arbiter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemRequest {
    pub patch: u32,
    pub cluster: u16,
    pub ctu: u16,
    /// The cycle the request was queued (for the arbiter's wait statistics).
    pub issued: u64,
}

/// A patch record delivered by the memory into a cluster's patch buffer, for one CTU.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PatchArrival {
    pub patch: u32,
    pub ctu: u16,
}

/// A (ray, patch) job for the ICU. `slot` is the ray's index within its CTU's sector; `owner`
/// the cluster whose CTU issued it (the result goes back there, even when another cluster's
/// ICU computes it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Job {
    pub ray: u32,
    pub slot: u32,
    pub patch: u32,
    pub ctu: u16,
    pub owner: u16,
}

/// Memory words a job takes on the inter-cluster link (ray id; patch id, slot, CTU, owner).
pub const JOB_WORDS: u32 = 2;

/// The balancer's order to a busy cluster's ray buffer: split off a work-item for `thief`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SplitOrder {
    pub thief: u16,
    pub jobs: u32,
}

/// A work-item on its way from a victim to a thief.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WorkItem {
    pub from: u16,
    pub to: u16,
    pub jobs: Vec<Job>,
}

/// A result computed by another cluster's ICU, on its way back to its owner.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RemoteResult {
    pub owner: u16,
    pub ctu: u16,
    pub result: JobResult,
}

/// The ICU's answer to a job: t of the hit, if any (t format, raw).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct JobResult {
    pub slot: u32,
    pub patch: u32,
    pub t: Option<i64>,
}
