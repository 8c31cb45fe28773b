//! The page the view serves: plain HTML, CSS and JavaScript built into the binary, so it works
//! with no network (no CDN, no web fonts). `page/view.js` draws the server-sent events of
//! [`super::events`] on a `<canvas>`, fills the worker table and, for `strahl view`, the form.

/// The page.
pub const HTML: &str = include_str!("page/index.html");

/// Its script.
pub const SCRIPT: &str = include_str!("page/view.js");

/// Its style sheet.
pub const STYLE: &str = include_str!("page/view.css");
