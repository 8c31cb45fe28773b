//! `strahl bench`: the benchmarks a user runs, one submodule each.
//!
//! - [`speed`]: `strahl bench` itself, the performance figures of issue 2 (octree build,
//!   octree size, primary and shaded rays per second) on the generated large scene.
//! - [`scaling`]: `strahl bench scaling`, speedup over 1 to N workers, measured in-process and
//!   over TCP and extended by the discrete-event model; [`master_load`] measures the master's
//!   cost per result for it.
//! - [`accuracy`]: `strahl bench accuracy`, what each quality knob buys against a converged
//!   reference and what it costs in time; writes `docs/accuracy.md` and its plot.
//! - [`peers`]: `strahl bench peers`, Strahl against POV-Ray 3.7 on the SPD scenes (tracing
//!   time on one thread, the whole process on two, rays, image difference), side by side.
//! - `stats`: the median that every figure above is taken from; `machine`: the date and the CPU
//!   that reports name.
//!
//! Each benchmark takes a plain options struct ([`BenchOptions`],
//! [`ScalingOptions`](scaling::ScalingOptions), [`AccuracyOptions`](accuracy::AccuracyOptions),
//! [`PeersOptions`](peers::PeersOptions));
//! their clap types and the dispatch are the command line's (`cli::bench`).

pub mod accuracy;
mod machine;
pub mod master_load;
pub mod peers;
pub mod scaling;
pub mod speed;
mod stats;

pub use speed::{BenchOptions, BenchReport};
