//! Subcommands: argument types and the glue from them to the library.

pub mod hardware;
pub mod import;
pub mod live;
pub mod output;
pub mod replay;
pub mod report;
pub mod reproduce;
pub mod run;
pub mod serve;
pub mod sim;
pub mod slip;
pub mod sweep;

#[cfg(test)]
mod documented_commands;
