//! One stable hash for everything that must hash the same across runs and
//! Rust releases: chart cache keys, the lights' change detection.

/// 64-bit FNV-1a: a stable hash (std's `DefaultHasher` may change between
/// Rust releases, which would silently invalidate every cache file).
#[derive(Clone, Copy, Debug)]
pub struct Fnv1a(u64);

impl Default for Fnv1a {
    fn default() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv1a {
    /// Hashes `bytes` into the state.
    pub fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    /// Hashes a u32, little-endian.
    pub fn write_u32(&mut self, x: u32) {
        self.write(&x.to_le_bytes());
    }

    /// Hashes a slice of plain values by their bytes, after its length (so
    /// that two arrays can't trade elements and hash the same).
    pub fn write_pod<T: bytemuck::Pod>(&mut self, values: &[T]) {
        self.write(&(values.len() as u64).to_le_bytes());
        self.write(bytemuck::cast_slice(values));
    }

    /// The hash of everything written so far.
    pub fn finish(&self) -> u64 {
        self.0
    }
}

/// Appends the FNV-1a checksum of `out` (the trailer of the cache files).
pub fn seal(out: &mut Vec<u8>) {
    let sum = fnv1a(out);
    out.extend_from_slice(&sum.to_le_bytes());
}

/// The bytes [`seal`] was given, if `bytes` ends in their checksum.
pub fn unseal(bytes: &[u8]) -> Result<&[u8], String> {
    let Some(split) = bytes.len().checked_sub(8) else { return Err("shorter than its checksum".into()) };
    let (body, tail) = bytes.split_at(split);
    if fnv1a(body).to_le_bytes() != tail {
        return Err("checksum mismatch (truncated or corrupt)".into());
    }
    Ok(body)
}

/// FNV-1a of a byte string.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h = Fnv1a::default();
    h.write(bytes);
    h.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a_matches_the_reference_values() {
        // Published FNV-1a 64 test vectors.
        let hash = fnv1a;
        assert_eq!(hash(b""), 0xcbf29ce484222325);
        assert_eq!(hash(b"a"), 0xaf63dc4c8601ec8c);
        assert_eq!(hash(b"foobar"), 0x85944171f73967e8);
    }
}
