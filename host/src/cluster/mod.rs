//! Distributed rendering: the master, its scheduler, the links to workers, and the in-process
//! workers and simulated cluster that use the same protocol.
//!
//! How the parts fit, from the wire inwards: a [`link`] is two byte streams to one worker (TCP,
//! a serial port or an in-process [`pipe`]). The `link_threads` read and write each link on
//! their own threads and turn frames into events. The `session` is the master's state
//! machine with no I/O: per-worker state, which tasks are in flight, re-issue of lost ones,
//! dropping of duplicates; it asks the [`schedule`] which line goes next (the one window
//! policy). The `assembly` puts the first result of each task into the image, with the core's
//! adaptive bookkeeping for the second pass. The [`master`] runs the loop that ties them
//! together and says what a render's options, job, image and errors are.
//!
//! Executors: [`local`] worker threads (the default of `strahl render`), TCP and serial workers
//! (started by [`executor`]), each behind a [`link`]; [`prepared`] holds a scene built
//! and encoded once for all of them. For testing and planning: [`sim`] runs many in-process
//! workers with link models and seeded faults against the real master, and [`model`] is a
//! discrete-event model in virtual time that calls the same scheduler and window policy.
//! [`report`] says what each worker did.
//!
//! - [`schedule`]: which line goes to which worker (no I/O, no clock).
//! - `session`: each worker's session and the tasks in flight (no I/O).
//! - `assembly`: the image from the results.
//! - [`job`]: what a render asks of the master and gets back (options, job, image, errors).
//! - [`master`]: the master loop over any set of [`link::Link`]s.
//! - `link_threads`: the reader and writer thread of each link.
//! - [`link`]: a connection to one worker over TCP, a serial port or an in-process [`pipe`].
//! - [`pipe`]: in-process byte pipes, with a link model (latency, bandwidth, bit flips).
//! - [`prepared`]: a scene built once and encoded once, for the master and in-process workers.
//! - [`local`]: worker threads in this process, the default executor of `strahl render`.
//! - [`held`]: their outbox, which writes the answers to one request together.
//! - [`executor`]: which workers a render uses (local threads, TCP, serial, dialling in,
//!   launched on a hosts file's machines) and starting them.
//! - [`slurm`]: `--slurm`: the allocation and the `srun` step that starts a worker per node.
//! - [`sim`]: the simulated cluster: many in-process workers with speeds and seeded faults.
//! - [`model`]: a discrete-event model of the master and workers in virtual time, for
//!   clusters larger than this machine.
//! - [`report`]: what each worker did.
//! - [`faults`]: seeded faults (drop, duplicate, corrupt, split, delay, disconnect) over any
//!   link, for tests.
//! - [`checkpoint`]: the results used so far, in a file beside the output, for `--resume`.
//! - [`region`]: `--region`: the lines outside taken as done, the columns outside masked.
//! - `verify`: `--verify`'s bookkeeping: sampled tasks, held results, who delivered what.

pub(crate) mod assembly;
pub mod checkpoint;
pub mod executor;
pub mod faults;
pub mod held;
pub mod job;
pub mod link;
pub(crate) mod link_threads;
pub mod local;
pub mod master;
pub mod model;
pub mod pipe;
pub mod prepared;
pub mod region;
pub mod report;
pub mod schedule;
pub(crate) mod session;
pub mod sim;
pub mod slurm;
pub(crate) mod verify;
