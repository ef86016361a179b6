//! GPU context.
