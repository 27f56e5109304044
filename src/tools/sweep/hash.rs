//! A stable 64-bit content hash (FNV-1a) for the sweep's cache and resume keys: unlike
//! `std`'s `DefaultHasher` it is the same on every build and release.

const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

fn fnv1a_continue(mut h: u64, bytes: &[u8]) -> u64 {
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// FNV-1a, 64 bits.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    fnv1a_continue(FNV_OFFSET, bytes)
}

/// FNV-1a of `value`'s `Debug` text, streamed (a scene's textures are never copied into one
/// string).
pub fn fnv1a_debug(value: &impl std::fmt::Debug) -> u64 {
    struct Hasher(u64);
    impl std::fmt::Write for Hasher {
        fn write_str(&mut self, s: &str) -> std::fmt::Result {
            self.0 = fnv1a_continue(self.0, s.as_bytes());
            Ok(())
        }
    }
    let mut h = Hasher(FNV_OFFSET);
    // Writing into the hasher cannot fail; a Debug impl that fails leaves a partial hash.
    let _ = std::fmt::write(&mut h, format_args!("{value:?}"));
    h.0
}

/// Sixteen lowercase hex digits.
pub fn hex(h: u64) -> String {
    format!("{h:016x}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a_matches_the_published_test_vectors() {
        assert_eq!(fnv1a(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a(b"foobar"), 0x8594_4171_f739_67e8);
        assert_eq!(hex(0xab), "00000000000000ab");
        assert_eq!(fnv1a_debug(&"foobar"), fnv1a(b"\"foobar\""));
    }
}
