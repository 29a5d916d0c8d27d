//! Online slip detection: per-sensor classifications arriving asynchronously, combined by a
//! `NFr x NSen` strategy into the hand's reaction (SPEC.md, "Online strategy").

pub mod classify;
pub mod contact;
pub mod deadline;
pub mod strategy;
