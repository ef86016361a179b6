//! CPU light culling (placeholder until implemented).
