//! Protocol runners: one state machine per protocol kind over the HAL traits, generic over
//! backends (issue 4; in progress: hand release only, no batch layer yet).

pub mod batch;
pub mod hand_release;
