//! The live view in a browser: the seed's wish to see the image while it is computed
//! (`pvm-raytracer-beleg.txt` 1.3.1) and to choose the tracer's features before it starts
//! (1.3.2).
//!
//! How the parts fit: the master's hooks feed a [`hub::Hub`] (each line's final pixels, the
//! workers' states, the end); the [`server`] serves the [`page`] and streams the hub's
//! [`events`] to every page that watches. `strahl render --view` only watches; `strahl view`
//! adds the form, whose buttons the server hands to [`control::Renders`], which runs the
//! same pipeline as `strahl render` on a thread of its own.
//!
//! - [`events`]: what a page is told (begin, line, progress, workers, status, settings).
//! - [`hub`]: the state a page draws from scratch, and the pages subscribed to its changes.
//! - [`server`]: HTTP (`tiny_http`): page, events, the finished image, the buttons.
//! - [`page`]: the HTML, CSS and JavaScript, built into the binary.
//! - [`control`]: renders started, stopped and resumed from the page.

pub mod control;
pub mod events;
pub mod hub;
pub mod page;
pub mod server;
