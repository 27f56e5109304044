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
