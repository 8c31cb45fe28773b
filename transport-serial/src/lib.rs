//! Serial-link transport for Strahl frames (filled in by the distribution issue).
#![forbid(unsafe_code)]
