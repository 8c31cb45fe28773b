//! Strahl's host side: everything that needs an operating system.
//!
//! The host is six groups of modules and a neutral base. The file formats are a crate of their
//! own, `strahl-formats` (folder `host/formats`), re-exported here as [`formats`]; the other
//! groups are folders (or files) of this crate:
//!
//! | group | where | what |
//! |---|---|---|
//! | formats | [`formats`] (`host/formats`): `lines config datafile nff obj mesh fart/ hosts load convert fs error` | every file read or written in Strahl's scene formats, each reader beside its writer; atomic file writes |
//! | scenes | [`generate`] | procedural scenes (the demo room, the large benchmark scene), built with core's `scene::mesh` |
//! | cluster | [`cluster`]: master, scheduler, links, local and simulated workers, and `executor` (which workers a render uses, and starting them) | rendering through workers |
//! | interface | [`cli`]: one module per subcommand (`render worker convert generate bench`), `progress`, `summary`; [`output`] (BMP and PNG images) | the `strahl` command line, what it prints and the images it writes |
//! | benchmarks | [`bench`](mod@bench): `speed`, `scaling`, `accuracy/`, `peers/`, `stats` | `strahl bench` and its studies |
//! | view | [`view`]: `hub`, `events`, `server`, `page`, `control` | the live view in a browser (`render --view`, `strahl view`) |
//! | base | [`util`]: `cpu` (whether this processor runs the tracer as built), `sys` (host name, shared timeouts), `units` (rays per second as text) | used by the groups above, uses none |
//!
//! Dependencies point one way, from the interface down:
//!
//! ```text
//! cli ──► bench ──► cluster ──► formats
//!  │        │          └──► util
//!  │        └──► generate ──► formats
//!  ├──► view ──► cluster, output, formats, util
//!  └──► output, and every group below
//! ```
//!
//! - `formats` is a separate crate and uses nothing of this one: the compiler keeps it below
//!   everything, and its dependencies hold no clap, indicatif or image.
//! - `util` uses no group; `generate` uses only `formats` (the data file and configuration file
//!   writers).
//! - `cluster` uses `formats` (the hosts file) and `util`; it takes plain structs
//!   (`WorkerSources`, `MasterOptions`), never clap types.
//! - the benchmarks use `cluster`, `formats`, `generate` and `util`; `output` uses `formats::fs`.
//! - `view` uses `cluster` (the master's hooks, the workers' states), `output`, `formats` and
//!   `util`; it sits beside `bench`, and neither uses the other.
//! - `cli` uses everything; nothing uses `cli` except `main.rs`. All clap types live in `cli`
//!   (`cli::bench` holds the benchmarks'); each subcommand turns its arguments into the plain
//!   options struct of the group it calls ([`formats::load::Overrides`],
//!   [`cluster::job::MasterOptions`], `bench::scaling::ScalingOptions`, ...).
//!
//! Why the formats are a crate and the rest are folders: the parsers are the part with users of
//! their own (a tool that reads `.fart` or `raytracer.cfg` files), who should not pull in a
//! command line, a progress bar or image codecs; a crate boundary makes that, and the direction
//! of dependencies, a compiler error rather than a convention. The other groups share the
//! binary's dependencies anyway, so separate crates would buy them only build boundaries; inside
//! this crate, `tests/tests/layers.rs` fails when a group imports from one above it or two
//! modules import each other round a loop, and when a module outside `cli` names clap. The
//! cluster could become a crate too; today only the binary and the benchmarks use it, so the
//! boundary would buy nothing the layer check does not.

pub mod bench;
pub mod cli;
pub mod cluster;
pub use strahl_formats as formats;
pub mod generate;
pub mod output;
pub mod util;
pub mod view;
