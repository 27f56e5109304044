#!/usr/bin/env bash
# Builds everything tools/device/gpu-run.sh needs on a GPU machine that has no Rust toolchain,
# into .device/ (ignored by git; carry it with .gl): the test binaries and the test profile's
# `ispm` (stripped), the release `ispm`, the cached references, and the path the crate was built
# at. The Vulkan loader and the validation layer go into .gl/ as .debs (docs/performance.md
# "On a GPU").
set -euo pipefail
# BASELINE=path: another build's release `ispm`, for gpu-run.sh's `abrender`; resolved before
# the `cd` below, and copied aside before `cargo build` can replace it.
baseline=""
if [ -n "${BASELINE:-}" ]; then
  baseline=$(mktemp)
  trap 'rm -f "$baseline"' EXIT # a failed build leaves no copy behind (moved when it succeeds)
  cp "$(realpath "$BASELINE")" "$baseline"
fi
cd "$(dirname "$0")/../.."
grep -qx '/.gl/' .git/info/exclude 2>/dev/null || echo /.gl/ >>.git/info/exclude
grep -qx '/.device/' .git/info/exclude 2>/dev/null || echo /.device/ >>.git/info/exclude
if ! ls .gl/libvulkan1_*.deb .gl/vulkan-validationlayers_*.deb >/dev/null 2>&1; then
  mkdir -p .gl /tmp/amd64/partial
  o=(-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64)
  apt-get "${o[@]}" update >/dev/null
  (cd .gl && apt-get "${o[@]}" download libvulkan1 libegl1 libglvnd0 libopengl0 libgl1 libglx0 \
    libgles2 vulkan-validationlayers)
fi
cargo build --release
cargo test --no-run --message-format=json | python3 -c '
import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m.get("executable") and m["profile"]["test"]:
        print(m["executable"])
' >/tmp/ispm-test-bins.txt
rm -rf .device && mkdir -p .device/stage/bin .device/stage/tests .device/cache/ispm
while read -r exe; do
  name=$(basename "$exe")
  # The library's and the binary's unit tests are both `ispm-HASH`: keep the hash on those.
  case ${name%-*} in ispm) cp "$exe" ".device/stage/tests/$name" ;; *) cp "$exe" ".device/stage/tests/${name%-*}" ;; esac
done </tmp/ispm-test-bins.txt
# TESTS="a b …": carry only these test binaries, by the names they get under .device/tests (the
# integration tests' file names; the unit tests' `ispm-HASH`). The whole suite is ~45 MB packed;
# a call carries 64 MiB in all, references included.
if [ -n "${TESTS:-}" ]; then
  for t in .device/stage/tests/*; do
    case " $TESTS " in *" $(basename "$t") "*) ;; *) rm "$t" ;; esac
  done
fi
# SKIP_TESTS="a b …" (names, as TESTS): leave these out (e.g. the CPU-only ones, when the payload and the references
# must fit one call's carry).
for t in ${SKIP_TESTS:-}; do rm -f ".device/stage/tests/$t"; done
# BENCHES="a b …": the `cargo bench` targets to carry too (run by gpu-run.sh's `cargobench`).
mkdir -p .device/stage/benches
for bench in ${BENCHES:-}; do
  cargo bench --bench "$bench" --no-run --message-format=json | python3 -c '
import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m.get("executable") and m["target"]["kind"] == ["bench"]:
        print(m["executable"])
' | while read -r exe; do cp "$exe" ".device/stage/benches/$bench"; done
done
if [ -n "$baseline" ]; then mv "$baseline" .device/stage/bin/ispm-baseline && chmod +x .device/stage/bin/ispm-baseline; fi
cp target/debug/ispm .device/stage/bin/ispm-test
cp target/release/ispm .device/stage/bin/ispm-release
strip .device/stage/bin/* .device/stage/tests/*
if [ -n "$(ls .device/stage/benches)" ]; then strip .device/stage/benches/*; fi
cache=${XDG_CACHE_HOME:-$HOME/.cache}/ispm/references
if [ -d "$cache" ]; then cp -r "$cache" .device/cache/ispm/; fi
pwd >.device/built_at
tar -C .device/stage -cf - bin tests benches | xz -T0 -9 >.device/payload.tar.xz
rm -rf .device/stage
du -sh .device .gl
