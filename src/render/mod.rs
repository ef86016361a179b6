//! Pipelines and what they share.
pub mod culling;
