//! Strahl's host side: everything that needs an operating system.
//!
//! Modules (each helper adds its own `pub mod` line here):
