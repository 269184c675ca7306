//! The machine's waveform: every unit's signals and every link's handshake, reported to a
//! [`Probe`] after each edge. Scope names are built once; the order of the calls is the
//! waveform's signal order.

use super::links::{probe_link, Section};
use super::Machine;
use crate::trace::Probe;

impl Machine<'_> {
    /// Reports every unit's signals to `p` (scope names are built once, not per cycle).
    pub fn probe(&mut self, p: &mut dyn Probe) {
        if self.scopes.is_none() {
            self.scopes = Some(Scopes::new(self));
        }
        let sc = self.scopes.as_ref().expect("built above");
        let now = self.cycle;
        p.cycle(now);
        let t_frac = self.scene.formats.t.frac_bits;
        let t_bits = self.scene.formats.t.bits();
        p.bits(
            &sc.memory,
            "port_busy",
            1,
            self.memory.port_busy(now) as u64,
        );
        p.bits(&sc.memory, "in_flight", 16, self.memory.inflight() as u64);
        p.bits(&sc.memory, "grants", 32, self.memory.stats.grants);
        p.bits(
            &sc.arbiter,
            "last_grant",
            16,
            self.memory.last_grant.min(0xFFFF) as u64,
        );
        self.links.probe(p, Section::Arbiter);
        if self.cfg.balance.enabled {
            p.bits(
                &sc.balancer,
                "split_orders",
                32,
                self.balancer.stats.split_orders,
            );
            p.bits(
                &sc.balancer,
                "jobs_moved",
                32,
                self.balancer.stats.jobs_moved,
            );
            p.bits(&sc.balancer, "retries", 32, self.balancer.stats.retries);
        }
        for (c, cl) in self.clusters.iter().enumerate() {
            let cs = &sc.clusters[c];
            if self.cfg.balance.enabled {
                p.bits(
                    &cs.balance,
                    "work_request",
                    1,
                    self.balancer.requesting(c) as u64,
                );
                p.bits(
                    &cs.balance,
                    "jobs_inbound",
                    16,
                    self.balancer.inbound(c) as u64,
                );
                self.links.probe(p, Section::Balance(c));
            }
            probe_link(p, &cs.patch_buffer, &cl.patch_buffer.store);
            probe_link(p, &cs.ray_buffer, &cl.ray_buffer.queue);
            for (j, ctu) in cl.ctus.iter().enumerate() {
                let s = &cs.ctus[j];
                p.text(s, "state", ctu.state.name());
                p.bits(s, "shell", 16, ctu.shell() as u64);
                p.bits(s, "remaining_rays", 32, ctu.remaining() as u64);
                p.bits(s, "outstanding_jobs", 32, ctu.outstanding());
                p.bits(s, "pending_loads", 16, ctu.pending_loads() as u64);
                p.bits(s, "jobs_issued", 32, ctu.stats.jobs_issued);
                self.links.probe(p, Section::Ctu(c, j));
            }
            p.bits(&cs.icu, "jobs_in", 32, cl.icu.stats.jobs_in);
            for n in 0..cl.icu.depth() {
                let st = cl.icu.stage_job(n);
                let ss = &cs.stages[n];
                p.bits(ss, "valid", 1, st.is_some() as u64);
                p.bits(ss, "ray", 32, st.map_or(0, |(j, _)| j.ray as u64));
                p.bits(ss, "patch", 24, st.map_or(0, |(j, _)| j.patch as u64));
                // t is shown in the result stage only (`stage_job` gives it there alone).
                let t = st.and_then(|(_, t)| t).unwrap_or(0);
                p.fixed(ss, "t", t_bits, t_frac, t);
            }
        }
    }
}

/// The dotted scope names of every unit, built once per machine.
#[derive(Clone, Debug)]
pub(super) struct Scopes {
    memory: String,
    balancer: String,
    arbiter: String,
    clusters: Vec<ClusterScopes>,
}

#[derive(Clone, Debug)]
struct ClusterScopes {
    balance: String,
    patch_buffer: String,
    ray_buffer: String,
    /// Per CTU (its links' scopes are the links' own, see links.rs).
    ctus: Vec<String>,
    icu: String,
    stages: Vec<String>,
}

impl Scopes {
    fn new(m: &Machine) -> Self {
        let k = m.cfg.machine.ctus_per_cluster as usize;
        Scopes {
            memory: "machine.memory".into(),
            balancer: "machine.balancer".into(),
            arbiter: "machine.memory.arbiter".into(),
            clusters: (0..m.clusters.len())
                .map(|c| {
                    let base = format!("machine.cluster_{c}");
                    ClusterScopes {
                        balance: format!("{base}.balance"),
                        patch_buffer: format!("{base}.patch_buffer"),
                        ray_buffer: format!("{base}.ray_buffer"),
                        ctus: (0..k).map(|j| format!("{base}.ctu_{j}")).collect(),
                        icu: format!("{base}.icu"),
                        stages: (0..m.clusters[c].icu.depth())
                            .map(|n| format!("{base}.icu.stage_{n}"))
                            .collect(),
                    }
                })
                .collect(),
        }
    }
}
