//! The messages that cross links between units (each has a `Default`, the value a link's
//! unused slots hold).

/// A patch-load request from a CTU to the global memory's arbiter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MemRequest {
    pub patch: u32,
    pub cluster: u16,
    pub ctu: u16,
    /// The cycle the request was queued (for the arbiter's wait statistics).
    pub issued: u64,
}

/// A patch record delivered by the memory into a cluster's patch buffer, for one CTU.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
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
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SplitOrder {
    pub thief: u16,
    pub jobs: u32,
}

/// A work-item on its way from a victim to a thief: jobs (`job_source = "ctu"`) or a
/// descriptor split off a waiting one (`"bundle"`).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct WorkItem {
    pub from: u16,
    pub to: u16,
    pub jobs: Vec<Job>,
    pub desc: Option<Descriptor>,
}

/// A bundle of jobs (`job_source = "bundle"`): `patch` against the rays at positions
/// `lo..hi` of list `list` of the owner CTU's ray pool ([`crate::units::ray_pool`]). The
/// ray buffer expands it into jobs, one per cycle; a split hands the back part to a thief.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Descriptor {
    pub patch: u32,
    pub ctu: u16,
    pub owner: u16,
    pub list: u8,
    pub lo: u32,
    pub hi: u32,
}

impl Descriptor {
    /// The jobs it stands for.
    pub fn jobs(&self) -> u32 {
        self.hi - self.lo
    }

    /// Words it takes on the inter-cluster link with its ray ids: the descriptor (patch
    /// id; CTU, owner, count) and one word per ray id.
    pub fn link_words(&self) -> u64 {
        DESCRIPTOR_WORDS as u64 + self.jobs() as u64 * RAY_ID_WORDS as u64
    }
}

/// Memory words of a descriptor on the inter-cluster link (patch id; CTU, owner, count).
pub const DESCRIPTOR_WORDS: u32 = 2;

/// Memory words of one ray id moved with a split descriptor (the thief needs the ids: the
/// owner's ray pool is not in its cluster).
pub const RAY_ID_WORDS: u32 = 1;

/// A result computed by another cluster's ICU, on its way back to its owner.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RemoteResult {
    pub owner: u16,
    pub ctu: u16,
    pub result: JobResult,
}

/// The ICU's answer to a job: t of the hit, if any (t format, raw).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct JobResult {
    pub slot: u32,
    pub patch: u32,
    pub t: Option<i64>,
}
