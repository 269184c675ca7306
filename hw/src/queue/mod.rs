//! The queue level of timing: the paper's queueing network as an event model
//! ([`net`]) driven by each CTU's walk ([`walk`]), which the CTU itself produces against an
//! ideal environment. Its per-ray results are the untimed model's; it estimates the cycles,
//! each ICU's jobs and the balancer's work-items in a fraction of the cycle model's time.

pub mod net;
pub mod walk;
