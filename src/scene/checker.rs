//! Generated albedo textures (placeholder until implemented).
