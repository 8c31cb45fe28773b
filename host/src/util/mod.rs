//! The neutral base every group of the host may use and that uses no group: whether this
//! processor runs the tracer as built ([`cpu`]), the machine's name and the shared waits
//! ([`sys`]), quantities as text ([`units`]), the cluster's shared secret
//! ([`secret`]), input made safe to print in messages ([`text`]), usage errors (exit code 2,
//! [`usage`]). Atomic file writes are
//! `strahl_formats::fs`, below every group.

pub mod cpu;
pub mod secret;
pub mod sys;
pub mod text;
pub mod units;
pub mod usage;
