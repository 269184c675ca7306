//! A cluster: one ICU, K CTUs, a ray buffer and a patch buffer, with the links between them
//! (one per section of the partition).

use crate::link::Link;
use crate::msg::{Job, JobResult, PatchArrival};
use crate::units::ctu::Ctu;
use crate::units::icu::Icu;
use crate::units::patch_buffer::PatchBuffer;
use crate::units::ray_buffer::RayBuffer;

/// One cluster.
#[derive(Clone, Debug)]
pub struct Cluster {
    pub ctus: Vec<Ctu>,
    pub icu: Icu,
    pub ray_buffer: RayBuffer,
    pub patch_buffer: PatchBuffer,
    /// CTU k → ray buffer.
    pub job_links: Vec<Link<Job>>,
    /// ICU → CTU k.
    pub result_links: Vec<Link<JobResult>>,
    /// Patch buffer → CTU k.
    pub arrival_links: Vec<Link<PatchArrival>>,
}

impl Cluster {
    /// A cluster of the given CTUs; every inner link is a skid buffer (capacity 2).
    pub fn new(ctus: Vec<Ctu>, icu: Icu, ray_buffer: RayBuffer) -> Self {
        let k = ctus.len();
        Cluster {
            ctus,
            icu,
            ray_buffer,
            patch_buffer: PatchBuffer::default(),
            job_links: (0..k).map(|_| Link::new(2)).collect(),
            result_links: (0..k).map(|_| Link::new(2)).collect(),
            arrival_links: (0..k).map(|_| Link::new(2)).collect(),
        }
    }

    /// True when the cluster has finished and holds nothing.
    pub fn drained(&self) -> bool {
        self.ctus.iter().all(Ctu::done)
            && self.icu.is_empty()
            && self.ray_buffer.queue.is_empty()
            && self.links_empty()
    }

    /// True when every inner link is empty.
    pub fn links_empty(&self) -> bool {
        self.job_links.iter().all(Link::is_empty)
            && self.result_links.iter().all(Link::is_empty)
            && self.arrival_links.iter().all(Link::is_empty)
    }

    /// Commits every link of the cluster (the clock edge).
    pub fn commit(&mut self) {
        self.ray_buffer.queue.commit();
        for l in &mut self.job_links {
            l.commit();
        }
        for l in &mut self.result_links {
            l.commit();
        }
        for l in &mut self.arrival_links {
            l.commit();
        }
    }
}
