#!/usr/bin/env bash
# Runs ispm's benchmarks, an accuracy-vs-time sweep and the test suite on a lent GPU machine, in
# one call of the `device` tool, with the results under $OUT (docs/performance.md "On a GPU").
#
# The device machine has no Rust toolchain and a time budget of minutes, so everything is built
# here first by tools/device/pack.sh (stripped test binaries, the release `ispm`, the cached
# references, the Vulkan loader and the Khronos validation layer as .debs) and carried:
#
#   bash tools/device/pack.sh
#   run(command="bash tools/device/gpu-run.sh tests bench sweep", carry=[".gl", ".device"],
#       timeout_s=590)
#
# Stages (arguments, run in the order given): `render` (the README's render with stats and a
# trace), `shadows` (direct light alone at several shadow-map sizes), `bench` (`ispm bench` on
# every bundled scene), `subsample` (`--compare-subsample 4` on every bundled scene),
# `abrender` (the renders of `render` with a baseline binary and this one, alternately),
# `cargobench` (the `cargo bench` targets pack.sh was given), `tests` (the test suite,
# validation on), `crashes` (the binaries that crashed, again and again, with and without
# validation), `sweep`
# (the 160x120 accuracy-vs-time sweep of docs/tools/headline.py), `sweep640` (the same at
# 640x480, against references made here beforehand). BUDGET seconds in all; each
# stage stops at it, and everything lands in one $OUT/results.tgz (the tool returns few files),
# also when the run is cut short.
set -uo pipefail
DEST=${OUT:-/tmp/ispm-gpu-dest}
OUT=/tmp/ispm-gpu-out
BUDGET=${BUDGET:-570}
rm -rf "$OUT" && mkdir -p "$OUT" "$DEST"
trap 'tar -C "$OUT" -czf "$DEST/results.tgz" .' EXIT
root=$PWD
t0=$(date +%s)
log() { echo "[$(($(date +%s) - t0)) s] $*" | tee -a "$OUT/progress.log"; }
left() { echo $((BUDGET - ($(date +%s) - t0))); }

# The Vulkan loader into /, the validation layer beside it (unpacking more into / can break it).
for f in .gl/*.deb; do
  case $f in
  *validationlayers*) dpkg -x "$f" /opt/vvl ;;
  *) dpkg -x "$f" / ;;
  esac
done
ldconfig
for icd in /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json /usr/share/vulkan/icd.d/nvidia_icd.json \
  /etc/vulkan/icd.d/nvidia_icd.json; do
  if [ -f "$icd" ]; then export VK_DRIVER_FILES=$icd; break; fi
done
export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
export VK_ADD_LAYER_PATH=/opt/vvl/usr/share/vulkan/explicit_layer.d
export LD_LIBRARY_PATH=/opt/vvl/usr/lib/x86_64-linux-gnu${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
export XDG_CACHE_HOME=$root/.device/cache
# Test binaries name files by the path the crate was built at (CARGO_MANIFEST_DIR).
built_at=$(cat .device/built_at)
if [ "$root" != "$built_at" ] && [ ! -e "$built_at" ]; then
  mkdir -p "$(dirname "$built_at")"
  ln -sfn "$root" "$built_at"
fi

log "unpacking"
if command -v xz >/dev/null; then
  tar -xJf .device/payload.tar.xz -C .device
else
  python3 -c 'import sys, tarfile; tarfile.open(sys.argv[1]).extractall(sys.argv[2])' \
    .device/payload.tar.xz .device
fi
mkdir -p target/debug target/tmp # CARGO_TARGET_TMPDIR of the tests
cp .device/bin/ispm-test target/debug/ispm # the binary the tests spawn (CARGO_BIN_EXE_ispm)
R=.device/bin/ispm-release
# Every bundled scene (ispm::scene::bundled::BUNDLED), the stages' default; SCENES="a b" picks.
BUNDLED="cornell-box caustic-ring glass-sphere diffuse-box thin-walls facing-mirrors glass-cube"

{
  nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.mem,temperature.gpu,utilization.gpu \
    --format=csv
  nproc
  uptime
  echo "VK_DRIVER_FILES=${VK_DRIVER_FILES:-unset}"
} >"$OUT/machine.txt" 2>&1
log "info"
if ! ISPM_VALIDATION=1 timeout 60 $R info >"$OUT/info.txt" 2>&1 ||
  ! grep -qi "${ISPM_GPU_VENDOR:-nvidia}" "$OUT/info.txt"; then
  log "no NVIDIA Vulkan device: see info.txt"
  cat "$OUT/info.txt"
  ls -la /usr/local/nvidia/share/vulkan/icd.d /usr/share/vulkan/icd.d 2>&1 | tee -a "$OUT/info.txt"
  exit 1
fi
cat "$OUT/info.txt"


# The README's default render, with its stats and a Perfetto trace of every queue and thread;
# then the 640x480 bench's default (100k photons) as a render, for its trace.
stage_render() {
  log "render"
  timeout 90 $R render cornell-box -o "$OUT/cornell-box.png" --stats "$OUT/render-stats.json" \
    --trace "$OUT/render-trace.json" >"$OUT/render.txt" 2>&1 || log "render: rc $?"
  timeout 90 $R render cornell-box --quality none --size 640x480 --frames 12 \
    -o "$OUT/cornell-box-100k.png" --stats "$OUT/render-100k-stats.json" \
    --trace "$OUT/render-100k-trace.json" >"$OUT/render-100k.txt" 2>&1 || log "render 100k: rc $?"
}

# Before and after, side by side: the README's render and the 100k-photon one with the
# baseline binary pack.sh was given (`BASELINE=path/to/ispm`, carried as bin/ispm-baseline) and
# this one, alternately (ABBA: the order flips each round), ROUNDS times (default 3); their stats
# and the 100k renders' traces under $OUT/abrender.
stage_abrender() {
  mkdir -p "$OUT/abrender"
  local b=.device/bin/ispm-baseline
  if [ ! -x "$b" ]; then
    log "abrender: no baseline binary"
    return
  fi
  # At most 60 s a render, never past BUDGET.
  limit() {
    local t=$(($(left) - 5))
    [ "$t" -gt 60 ] && t=60
    echo "$t"
  }
  local order=(baseline current)
  for i in $(seq 1 "${ROUNDS:-3}"); do
    for which in "${order[@]}"; do
      local bin=$R
      [ "$which" = baseline ] && bin=$b
      [ "$(limit)" -lt 10 ] && return
      log "abrender $i $which"
      timeout "$(limit)" "$bin" render cornell-box -o "$OUT/abrender/default-$which-$i.png" \
        --stats "$OUT/abrender/default-$which-$i.json" >"$OUT/abrender/default-$which-$i.txt" \
        2>&1 || log "abrender default $which $i: rc $?"
      [ "$(limit)" -lt 10 ] && return
      timeout "$(limit)" "$bin" render cornell-box --quality none --size 640x480 --frames 12 \
        -o "$OUT/abrender/100k-$which-$i.png" --stats "$OUT/abrender/100k-$which-$i.json" \
        --trace "$OUT/abrender/100k-$which-$i-trace.json" >"$OUT/abrender/100k-$which-$i.txt" \
        2>&1 || log "abrender 100k $which $i: rc $?"
    done
    order=("${order[1]}" "${order[0]}")
  done
}

# The dotted arcs on the floor of the default render on an H100 (not on lavapipe): direct light
# alone, and the shadow maps at other resolutions.
stage_shadows() {
  mkdir -p "$OUT/shadows"
  local args=(cornell-box --size 640x480 --frames 8)
  log "shadows"
  timeout 60 $R render "${args[@]}" -o "$OUT/shadows/default.png" >/dev/null 2>&1
  timeout 60 $R render "${args[@]}" --method direct -o "$OUT/shadows/direct.png" >/dev/null 2>&1
  for n in 512 4096; do
    timeout 60 $R render "${args[@]}" --method direct --shadow-resolution $n \
      -o "$OUT/shadows/direct-$n.png" >/dev/null 2>&1
  done
  # The sun's two views (one fitted to what the eye sees, one over the whole scene) and their
  # lookup offsets: caustic-ring, the bundled scene with a directional light.
  args=(caustic-ring --size 640x480 --frames 8)
  timeout 60 $R render "${args[@]}" -o "$OUT/shadows/sun-default.png" >/dev/null 2>&1
  for n in 512 1024 4096; do
    timeout 60 $R render "${args[@]}" --method direct --shadow-resolution $n \
      -o "$OUT/shadows/sun-direct-$n.png" >/dev/null 2>&1
  done
}

# Benchmarks: every bundled scene at two sizes, both estimators, overlapped against serial.
bench() {
  local name=$1
  shift
  local t=$(($(left) - 5))
  if [ "$t" -lt 10 ]; then
    log "skip bench $name (time)"
    return
  fi
  log "bench $name"
  timeout "$t" $R bench "$@" --json "$OUT/bench/$name.json" >"$OUT/bench/$name.txt" 2>&1 ||
    log "bench $name: rc $?"
}
stage_bench() {
  mkdir -p "$OUT/bench"
  for scene in ${SCENES:-$BUNDLED}; do
    bench "$scene-640x480" "$scene" --size 640x480 --frames 20 --chunks 5 --compare-density
  done
  for n in 1 4; do
    bench "cornell-box-1920x1080-s$n" cornell-box --size 1920x1080 --frames 12 --chunks 3 \
      --subsample $n --compare-density
  done
  bench diffuse-box-1920x1080 diffuse-box --size 1920x1080 --frames 12 --chunks 3 --compare-density
}

# Item 3 of #20: the whole radiance estimate at 1/4 against 1/1 (`--compare-subsample 4`) on
# every bundled scene, at the default preset's photons (`--quality high --subsample 1`) and at
# 100k photons.
stage_subsample() {
  mkdir -p "$OUT/bench"
  for scene in ${SCENES:-$BUNDLED}; do
    bench "$scene-sub4-high" "$scene" --size 640x480 --frames 20 --warmup 2 --chunks 5 \
      --quality high --subsample 1 --compare-subsample 4
    bench "$scene-sub4-100k" "$scene" --size 640x480 --frames 20 --warmup 2 --chunks 5 \
      --photons 100000 --compare-subsample 4
  done
}

# The test suite, four binaries at a time, validation on. `viewer` needs xvfb-run and `layouts`
# spirv-val, neither on the device machine (both run in CI).
stage_tests() {
  mkdir -p "$OUT/tests"
  local deadline=$(($(date +%s) + $(left) - 5))
  log "tests (until $((deadline - t0)) s)"
  # Longest first (by size, a fair proxy), so the slow ones do not start last.
  ls -S .device/tests | grep -vx 'viewer\|layouts' | ISPM_VALIDATION=1 xargs -P 4 -I{} bash -c '
    cd "$0"; t=$(($1 - $(date +%s)))
    if [ "$t" -lt 5 ]; then echo "{} rc=skipped" >>"$2/tests/summary.txt"; exit 0; fi
    timeout "$t" ".device/tests/{}" >"$2/tests/{}.log" 2>&1
    echo "{} rc=$?" >>"$2/tests/summary.txt"' "$root" "$deadline" "$OUT"
  touch "$OUT/tests/summary.txt"
  log "tests: $(grep -c 'rc=0$' "$OUT/tests/summary.txt") passed, $(grep -vc 'rc=0$' "$OUT/tests/summary.txt") not"
  grep -v 'rc=0$' "$OUT/tests/summary.txt"
}

# The `cargo bench` targets pack.sh carried (BENCHES), one after the other, each alone on the
# machine.
stage_cargobench() {
  mkdir -p "$OUT/cargobench"
  for b in .device/benches/*; do
    [ -x "$b" ] || continue
    local t=$(($(left) - 5))
    if [ "$t" -lt 10 ]; then break; fi
    log "cargo bench $(basename "$b")"
    timeout "$t" "$b" --bench >"$OUT/cargobench/$(basename "$b").txt" 2>&1 || log "$(basename "$b"): rc $?"
    cat "$OUT/cargobench/$(basename "$b").txt"
  done
}

# Binaries that crashed (SIGSEGV) once under the parallel suite: each of CRASHERS, REPEAT times,
# four at a time, alternately with and without the validation layer.
stage_crashes() {
  mkdir -p "$OUT/crashes"
  local deadline=$(($(date +%s) + $(left) - 5))
  log "crashes (until $((deadline - t0)) s)"
  for i in $(seq 1 "${REPEAT:-4}"); do
    for b in ${CRASHERS:-translucent render_direct}; do echo "$b $i 1"; echo "$b $i 0"; done
  done | xargs -P 4 -L1 bash -c '
    cd "$0"; t=$(($1 - $(date +%s)))
    if [ "$t" -lt 5 ]; then exit 0; fi
    ISPM_VALIDATION=$5 timeout "$t" ".device/tests/$3" >"$2/crashes/$3-$4-v$5.log" 2>&1
    echo "$3 run $4 validation $5 rc=$?" >>"$2/crashes/summary.txt"' "$root" "$deadline" "$OUT"
  touch "$OUT/crashes/summary.txt"
  sort "$OUT/crashes/summary.txt"
}

# `sweeps NAME SIZE ISPM_GRID BASELINE_GRID SECONDS`: the headline's accuracy-vs-time sweep of
# every bundled scene at SIZE against the cached references, ISPM's grid then the CPU
# photon-gather baseline's on this machine's cores, into $OUT/NAME; each scene (SCENES, default
# every bundled one) given an equal share of SECONDS (never past BUDGET).
sweeps() {
  local name=$1 size=$2 ispm=$3 baseline=$4 seconds=$5
  mkdir -p "$OUT/$name"
  [ "$seconds" -gt "$(left)" ] && seconds=$(left)
  local scenes=(${SCENES:-$BUNDLED})
  local share=$((seconds / ${#scenes[@]}))
  for scene in "${scenes[@]}"; do
    local end=$(($(date +%s) + share)) grid t
    for grid in "$ispm" "$baseline"; do
      t=$((end - $(date +%s)))
      [ "$t" -gt $(($(left) - 5)) ] && t=$(($(left) - 5))
      if [ "$t" -lt 10 ]; then break; fi
      log "$name $scene: $grid"
      timeout "$t" $R sweep "$scene" --out "$OUT/$name/$scene" --size "$size" --frames 3 \
        --grid "$grid" >>"$OUT/$name/$scene.log" 2>&1
    done
  done
}

# 160x120, both estimators (docs/tools/headline.py).
stage_sweep() {
  sweeps sweep 160x120 'photons=10k,40k,160k;radius=1,2;subsample=1,2,4;density=volumes,tiled' \
    'method=photon-gather;photons=10k,40k,160k;radius=1;subsample=1' "$(left)"
}

# 640x480 (references made beforehand by `ispm sweep --size 640x480` and carried in the
# cache), SWEEP_BUDGET seconds (default: what is left): the baseline's gather grows with the
# pixels, ISPM's GPU estimate hardly.
stage_sweep640() {
  sweeps sweep640 640x480 'photons=10k,40k,160k;radius=1,2;subsample=1,4' \
    'method=photon-gather;photons=10k,40k,160k,640k;radius=1;subsample=1' \
    "${SWEEP_BUDGET:-$(left)}"
}

for stage in "$@"; do
  "stage_$stage"
done
log "done"
for f in "$OUT"/bench/*.txt; do
  [ -f "$f" ] || continue
  echo "== $f"
  tail -n 4 "$f"
done
