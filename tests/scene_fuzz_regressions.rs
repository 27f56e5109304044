//! Inputs the fuzzer (`fuzz/`, target `load_glb`) once crashed the loader on. Each must now load
//! or fail with a one-line error naming the file: never panic.

#[test]
fn every_fuzz_regression_input_loads_or_errors_without_panicking() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz_regressions");
    let mut count = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "md") {
            continue;
        }
        let bytes = std::fs::read(&path).unwrap();
        if let Err(e) = ispm::scene::load::load_from_slice(&bytes, "regression.glb", None) {
            let msg = format!("{e:#}");
            assert!(
                msg.starts_with("regression.glb: ") && !msg.contains('\n'),
                "{msg}"
            );
        }
        count += 1;
    }
    assert!(count > 0, "no regression inputs in {}", dir.display());
}

/// xorshift64*: a fixed-seed generator, so a failure reproduces.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Mutates one bundled GLB: byte flips (biased towards the JSON chunk), digit edits,
/// truncation, or a splice of random bytes.
fn mutate(rng: &mut Rng, base: &[u8]) -> Vec<u8> {
    let mut v = base.to_vec();
    let json_end = 20 + u32::from_le_bytes([v[12], v[13], v[14], v[15]]) as usize;
    for _ in 0..1 + rng.below(4) {
        match rng.below(5) {
            0 => {
                let i = rng.below(v.len());
                v[i] ^= 1 << rng.below(8);
            }
            1 | 2 => {
                let i = 20 + rng.below(json_end.min(v.len()).saturating_sub(20));
                if i < v.len() {
                    v[i] = b"0123456789-.e,:[]{}\"9"[rng.below(21)];
                }
            }
            3 => {
                let keep = rng.below(v.len());
                v.truncate(keep.max(1));
            }
            _ => {
                let i = rng.below(v.len());
                let n = rng.below(16);
                for k in 0..n {
                    if i + k < v.len() {
                        v[i + k] = rng.next() as u8;
                    }
                }
            }
        }
    }
    v
}

fn mutation_run(iterations: usize, seed: u64) {
    let mut rng = Rng(seed);
    for it in 0..iterations {
        let name = ispm::scene::bundled::BUNDLED[it % 3];
        let base = ispm::scene::bundled::bundled(name).unwrap();
        let input = mutate(&mut rng, base);
        let result = std::panic::catch_unwind(|| {
            ispm::scene::load::load_from_slice(&input, "mutant.glb", None).map(|_| ())
        });
        if result.is_err() {
            let path = std::env::temp_dir().join(format!("ispm-mutant-{seed}-{it}.glb"));
            let _ = std::fs::write(&path, &input);
            panic!("iteration {it} panicked; input saved to {}", path.display());
        }
    }
}

#[test]
fn mutated_bundled_scenes_never_panic_the_loader() {
    mutation_run(300, 0x1595_2009);
}

/// The long form of the above (`cargo test --release --test scene_fuzz_regressions -- --ignored`);
/// `ISPM_MUTATIONS` sets the iteration count.
#[test]
#[ignore]
fn mutated_bundled_scenes_never_panic_the_loader_long() {
    let n = std::env::var("ISPM_MUTATIONS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(200_000);
    mutation_run(n, 0x159a_2009);
}
