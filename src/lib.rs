//! `tmo`: tactile slip-detection experiments on the Tactile Model O hand.
//!
//! The binary (`main.rs`) is the CLI and glue; the work lives here and in `tmo-hal`.

pub mod import;
pub mod live;
pub mod online;
pub mod outcome;
pub mod output;
pub mod plots;
pub mod protocol;
pub mod quote;
pub mod replay;
pub mod report;
pub mod reproduce;
pub mod runner;
pub mod slip;
pub mod trace;
pub mod trial;

pub use tmo_hal as hal;
