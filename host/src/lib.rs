//! Strahl's host side: everything that needs an operating system.
//!
//! The crate is five groups of modules and a neutral base, each a folder (or a file) of its own:
//!
//! | group | modules | what |
//! |---|---|---|
//! | formats | [`formats`]: `lines config datafile nff obj mesh fart/ hosts load convert image`, and `error` | every file read or written, each format's reader beside its writer |
//! | scenes | [`generate`] | procedural scenes (the demo room, the large benchmark scene, test meshes) |
//! | cluster | [`cluster`] (master, scheduler, links, local and simulated workers), [`executor`] (which workers a render uses, and starting them) | rendering through workers |
//! | interface | [`cli`]: one module per subcommand (`render worker convert generate bench`), `progress`, `summary` | the `strahl` command line and what it prints |
//! | benchmarks | [`bench`](mod@bench), [`bench_scaling`], [`bench_accuracy`] | `strahl bench` and its studies |
//! | base | [`util`]: `sys` (host name, shared timeouts), `fs` (atomic writes), `units` | used by all, uses none |
//!
//! Dependencies point one way, from the interface down to the base:
//!
//! ```text
//! cli ──► bench ──► cluster ──► formats ──► util
//!  │        └─────► generate ──►──┘          ▲
//!  └──► (all of them) ───────────────────────┘
//! ```
//!
//! - `formats` uses only `util` (and `strahl_core`): no clap, no indicatif, nothing of the
//!   cluster, the benchmarks or the command line.
//! - `generate` uses `formats` (the data file and configuration file writers).
//! - `cluster` and `executor` use `formats` (the hosts file) and `util`; they take plain structs
//!   (`WorkerSources`, `MasterOptions`), never clap types.
//! - the benchmarks use `cluster`, `formats`, `generate` and `util`.
//! - `cli` uses everything; nothing uses `cli` except `main.rs`. All clap types live in `cli`,
//!   except the benchmarks' own (still in [`bench`](mod@bench) and [`bench_accuracy`], owned elsewhere, and
//!   reached only through [`cli::bench`]).
//!
//! Folders of one crate, not crates of their own: the groups share one version, one build and
//! one test run, and the direction above is kept not by the compiler but by a test,
//! `host/tests/layering.rs`, which fails when `util`, `formats`, `generate` or the cluster names
//! a group above it (or the cluster names clap). Making
//! `formats` a crate (`strahl-formats`, without clap, indicatif or image, for users who want only
//! the parsers) is the next step and a mechanical one, since it already uses nothing above it;
//! it was not done in this change for want of time, and `image` would first move out of it.
//! `executor` belongs to the cluster group but stays at the crate root while the cluster's
//! owner reworks it.

pub mod bench;
pub mod bench_accuracy;
pub mod bench_scaling;
pub mod cli;
pub mod cluster;
pub mod executor;
pub mod formats;
pub mod generate;
pub mod util;
