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

/// A (ray, patch) job for the ICU. `slot` is the ray's index within its CTU's sector.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Job {
    pub ray: u32,
    pub slot: u32,
    pub patch: u32,
    pub ctu: u16,
}

/// The ICU's answer to a job: t of the hit, if any (t format, raw).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct JobResult {
    pub slot: u32,
    pub patch: u32,
    pub t: Option<i64>,
}
