//! The neutral base every group may use and that uses no group: the machine's name and the
//! shared waits ([`sys`]), whole-or-nothing file writes ([`fs`]), quantities as text ([`units`]).

pub mod fs;
pub mod sys;
pub mod units;
