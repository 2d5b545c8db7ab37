#!/usr/bin/env bash
# Tussock's only entry point:  ./build.sh deps | build | test [--blender 3|4|5,...] | demo [--blender N]
#                              | bench [--blender N] [--record] [NAME...] | package | fuzz [SECONDS [NAME...]]
#                              | roots [4] [5] | shots [--blender N] | windows
#                              | soak [--blender N] [--minutes M] [--seed S] [--window] [--gdb]
#                              | leaks [--blender N] [--background] [CYCLES]
# Each step is idempotent and quiet when there is nothing to do.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
BUILD="$ROOT/build"
PY=/usr/bin/python3          # Blender on Debian uses the system Python 3.11
BLENDER="${BLENDER:-blender}"
export BLENDER

PACKAGES=(blender python3-numpy python3-dev cmake ninja-build pkg-config g++ clang
          libclang-rt-dev libopencv-dev libopenni2-dev libosd-dev valgrind debootstrap
          xvfb xauth libgl1-mesa-dri slurm-wlm munge flake8 clang-format)

# The Blenders the suite runs in: 3 is this machine's own (Debian 12's 3.4); 4 and 5 are
# Debian trixie's (4.3) and sid's (5.x), each in a Debian root made by debootstrap from
# Debian's own packages and kept outside the clone ($TSK_ROOTS) so later runs reuse it.
# The native library is built inside each root against that root's OpenCV, OpenNI2 and
# OpenSubdiv (their sonames differ between releases).
ROOTS="${TSK_ROOTS:-/var/cache/tussock/roots}"
# (libjemalloc2: the soak replays a memory failure of Blender 5's TBB allocator with it,
# which counts the bytes it has handed out; tools/soak.py)
ROOT_PACKAGES=(blender python3-numpy python3-dev cmake ninja-build pkg-config g++ clang
               libopencv-dev libopenni2-dev libosd-dev xvfb xauth libgl1-mesa-dri libjemalloc2)
suite_of() { # blender major -> Debian suite ("" for the machine's own)
  case "$1" in
    3) echo "" ;;
    4) echo trixie ;;
    5) echo sid ;;
    *) die "unknown Blender '$1': use 3 (this machine's 3.4), 4 (Debian trixie) or 5 (Debian sid)" ;;
  esac
}

say() { printf '%s\n' "$*" >&2; }
die() { say "build.sh: $*"; exit 1; }

# Runs a command quietly; prints its output only if it fails.
quiet() {
  local log
  log="$(mktemp)"
  if ! "$@" >"$log" 2>&1; then
    cat "$log" >&2
    rm -f "$log"
    return 1
  fi
  rm -f "$log"
}

cmd_deps() {
  local missing=()
  for p in "${PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  say "build.sh deps: installing Debian packages: ${missing[*]}"
  local sudo=()
  if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null || die "need root or sudo to install: ${missing[*]}"
    sudo=(sudo)
  fi
  quiet "${sudo[@]}" apt-get update -qq || die "apt-get update failed"
  DEBIAN_FRONTEND=noninteractive quiet "${sudo[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" \
    || die "apt-get install failed for: ${missing[*]}"
}

configure() { # dir, extra cmake args...
  local dir="$1"; shift
  if [ ! -f "$dir/build.ninja" ]; then
    quiet cmake -S "$ROOT/native" -B "$dir" -G Ninja "$@" || die "cmake configure failed ($dir)"
  fi
}

cmd_build() {
  configure "$BUILD/release" -DCMAKE_BUILD_TYPE=Release
  quiet cmake --build "$BUILD/release" || die "native build failed"
  # the extension and the recording reader it starts (src/capture/oni_reader_protocol.h)
  local f
  for f in _tussock.abi3.so tussock_oni_reader; do
    cmp -s "$BUILD/release/$f" "$ROOT/addon/$f" \
      || install_binary "$BUILD/release/$f" "$ROOT/addon/$f"
  done
}

# Copies a built binary over the one a running Blender may have mapped: into a new file, then
# renamed over it, so that the running process keeps the old file's pages (cp would rewrite
# them in place, and Blender would die of SIGBUS).
install_binary() { # from, to
  cp "$1" "$2.new.$$" && mv -f "$2.new.$$" "$2"
}

build_asan() {
  configure "$BUILD/asan" -DCMAKE_BUILD_TYPE=Debug -DTSK_SANITIZE=ON \
    -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++
  quiet cmake --build "$BUILD/asan" || die "sanitizer build failed"
}

# The library and its tests with TSK_NO_SIMD (native/src/core/simd.h): only the portable
# kernels and branches, which other targets run and an x86-64 build otherwise never compiles.
build_nosimd() {
  configure "$BUILD/nosimd" -DCMAKE_BUILD_TYPE=Release -DTSK_NO_SIMD=ON -DTSK_PYTHON=OFF
  quiet cmake --build "$BUILD/nosimd" || die "no-SIMD build failed"
}

# libFuzzer targets (native/fuzz/fuzz_*.c) in their own build dir: ASan + UBSan + coverage.
build_fuzz() {
  configure "$BUILD/fuzz" -DCMAKE_BUILD_TYPE=Debug -DTSK_FUZZ=ON \
    -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
    -DCMAKE_C_FLAGS_DEBUG="-g -O1" -DCMAKE_CXX_FLAGS_DEBUG="-g -O1"
  quiet cmake --build "$BUILD/fuzz" --target fuzzers || die "fuzz build failed"
}

# Runs each fuzzer (all, or those named) for `seconds`, one at a time at the lowest priority,
# on a working copy of its seed corpus; prints executions per target and adds to
# PASSED/FAILED (a run that finds nothing passes). Crashes land in build/fuzz/artifacts/.
# An input counts as a hang after 300 s (TSK_FUZZ_TIMEOUT): the library lets one call work
# about a minute in a Release build (e.g. the refine rod model, TSK_BEND_MAX_WORK), and the
# sanitizers make it several times slower; several fuzzers sharing the cores, slower still.
run_fuzzers() { # seconds [name...]
  local secs="$1" f name log rc execs t0 t1 want runs=()
  shift
  # TSK_FUZZ_RUNS=N also stops each target after N executions (the reliability bar is
  # 10 million executions or one hour, whichever comes first).
  case "${TSK_FUZZ_TIMEOUT:-300}" in ''|*[!0-9]*) die "TSK_FUZZ_TIMEOUT must be a whole number" ;; esac
  if [ -n "${TSK_FUZZ_RUNS:-}" ]; then
    case "$TSK_FUZZ_RUNS" in *[!0-9]*) die "TSK_FUZZ_RUNS must be a whole number" ;; esac
    runs=(-runs="$TSK_FUZZ_RUNS")
  fi
  mkdir -p "$BUILD/fuzz/artifacts" "$BUILD/fuzz/logs"
  for f in "$BUILD/fuzz"/fuzz_*; do
    [ -x "$f" ] || continue
    name="${f##*/fuzz_}"
    if [ $# -gt 0 ]; then
      want=0
      for n in "$@"; do [ "$n" = "$name" ] && want=1; done
      [ "$want" -eq 1 ] || continue
    fi
    mkdir -p "$BUILD/fuzz/corpus/$name"
    log="$BUILD/fuzz/logs/$name.log"
    t0=$(date +%s)
    rc=0
    ASAN_OPTIONS="detect_leaks=1:halt_on_error=1" UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1" \
      LSAN_OPTIONS="suppressions=$ROOT/native/fuzz/lsan.supp:print_suppressions=0" \
      nice -n 19 "$f" -max_total_time="$secs" "${runs[@]}" -timeout="${TSK_FUZZ_TIMEOUT:-300}" -rss_limit_mb=2048 \
      -print_final_stats=1 -artifact_prefix="$BUILD/fuzz/artifacts/$name-" \
      "$BUILD/fuzz/corpus/$name" "$ROOT/native/fuzz/corpus/$name" >"$log" 2>&1 || rc=$?
    t1=$(date +%s)
    execs="$(grep -E '^stat::number_of_executed_units' "$log" | awk '{print $2}' | tail -n 1 || true)"
    if [ "$rc" -eq 0 ]; then
      printf '%-8s %-28s 1 passed, 0 failed  (%s executions in %s s)\n' fuzz "fuzz_$name" \
        "${execs:-?}" "$((t1 - t0))"
      PASSED=$((PASSED + 1))
    else
      grep -E 'ERROR|SUMMARY|Test unit written|==[0-9]+==' "$log" | head -n 20 >&2 || true
      printf '%-8s %-28s 0 passed, 1 failed  (log: %s)\n' fuzz "fuzz_$name" "$log"
      FAILED=$((FAILED + 1))
    fi
  done
}

cmd_fuzz() {
  local secs="${1:-60}"
  [ $# -gt 0 ] && shift
  case "$secs" in ''|*[!0-9]*) die "fuzz: seconds must be a whole number, got '$secs'" ;; esac
  build_fuzz
  run_fuzzers "$secs" "$@"
  echo "$PASSED passed, $FAILED failed"
  [ "$FAILED" -eq 0 ]
}

# Runs every test_* program of a build dir; adds to PASSED/FAILED.
PASSED=0
FAILED=0
run_native_tests() { # dir, label [, command that runs each test: e.g. in_root SUITE]
  local dir="$1" label="$2" t out line p f
  shift 2
  for t in "$dir"/test_*; do
    [ -x "$t" ] || continue
    if out="$(cd "$dir" && "$@" "$t" 2>&1)"; then :; else
      printf '%s\n' "$out"
    fi
    line="$(printf '%s\n' "$out" | grep -E '^[0-9]+ passed, [0-9]+ failed' | tail -n 1 || true)"
    if [ -z "$line" ]; then
      printf '%s\n' "$out"
      p=0; f=1
    else
      p="${line%% passed*}"; f="${line#*passed, }"; f="${f%% failed*}"
      if [ "$f" -eq 0 ] && ! printf '%s\n' "$out" | grep -q "^$line\$"; then f=1; fi
    fi
    printf '%-8s %-28s %s passed, %s failed\n' "$label" "$(basename "$t")" "$p" "$f"
    PASSED=$((PASSED + p)); FAILED=$((FAILED + f))
  done
}

# The plain-Python tests under the machine's python3 with numpy, no Blender: tests/test_*.py
# (the parts of the add-on and the tools that need no Blender; they find the built module in
# addon/) and the binding's checks native/tests/py_*.py (handles, def tables, the checked-in
# stub; run beside the release build's module). Same output and tally as the C tests.
run_python_tests() {
  local t out dir
  for t in "$ROOT"/tests/test_*.py "$ROOT"/native/tests/py_*.py; do
    [ -f "$t" ] || continue
    case "$t" in "$ROOT"/native/*) dir="$BUILD/release" ;; *) dir="$ROOT" ;; esac
    out="$(cd "$dir" && PYTHONPATH="$BUILD/release" timeout 600 "$PY" "$t" 2>&1)" || true
    tally python "$(basename "$t")" "$out"
  done
}

# Adds a Python test program's "N passed, N failed" to PASSED/FAILED, with one line for it
# (its whole output too when it failed or printed no tally).
tally() { # label, name, output
  local line p f
  line="$(printf '%s\n' "$3" | grep -E '^[0-9]+ passed, [0-9]+ failed$' | tail -n 1 || true)"
  if [ -z "$line" ]; then printf '%s\n' "$3"; p=0; f=1; else
    p="${line%% passed*}"; f="${line#*passed, }"; f="${f%% failed*}"
    [ "$f" -eq 0 ] || printf '%s\n' "$3"
  fi
  printf '%-8s %-28s %s passed, %s failed\n' "$1" "$2" "$p" "$f"
  PASSED=$((PASSED + p)); FAILED=$((FAILED + f))
}

# The binding's checks (native/tests/py_*.py) on the portable module, with Debian 12's Python
# 3.11 and with the artists' roots' (trixie 3.13, sid 3.14). Debian 11's 3.9 is older than
# the stable ABI the module is built for (3.11), so the bullseye run has the native suites.
run_portable_binding_checks() { # artist suite...
  local t who out
  for who in host "$@"; do
    for t in "$ROOT"/native/tests/py_*.py; do
      if [ "$who" = host ]; then
        out="$(cd "$PORTABLE/addon" && PYTHONPATH="$PORTABLE/addon" timeout 600 "$PY" "$t" 2>&1)" \
          || true
      else
        out="$(cd "$PORTABLE/addon" && in_root "artist-$who" env PYTHONPATH="$PORTABLE/addon" \
          timeout 600 python3 "$t" 2>&1)" || true
      fi
      tally "py-$who" "portable $(basename "$t")" "$out"
    done
  done
}

# The style checks, one result each: flake8 over the Python (.flake8) and clang-format over
# the C and C++ of native/ (.clang-format); a file either would change is a failure.
run_lint() {
  local out files
  if out="$(cd "$ROOT" && flake8 addon tools tests blender_tests native/tests 2>&1)"; then
    PASSED=$((PASSED + 1)); printf "%-8s %-28s passed\n" lint flake8
  else
    printf '%s\n' "$out"; FAILED=$((FAILED + 1)); printf "%-8s %-28s FAILED\n" lint flake8
  fi
  mapfile -t files < <(cd "$ROOT" && git ls-files 'native/*.c' 'native/*.h' 'native/*.cpp')
  if out="$(cd "$ROOT" && clang-format --dry-run --Werror "${files[@]}" 2>&1)"; then
    PASSED=$((PASSED + 1)); printf "%-8s %-28s passed\n" lint clang-format
  else
    printf '%s\n' "${out:0:6000}"
    FAILED=$((FAILED + 1)); printf "%-8s %-28s FAILED (clang-format -i FILE)\n" lint clang-format
  fi
}

# valgrind memcheck over the release test programs: no invalid access, no use of
# uninitialised values, no definite/indirect leak (third-party ones suppressed in
# native/tests/valgrind.supp). Long numeric tests are skipped (TSK_TEST_SKIP): valgrind runs
# them 20-50x slower, and their memory behaviour is the same as that of the short ones.
VALGRIND_SKIP="test_fluid_open_boundary,test_no_blowup_over_10000_steps,test_same_bytes_with_1_and_2_threads,test_float_functions_are_glibc,test_double_functions_are_within,test_fmaf_exact_is_glibc"
VALGRIND_SKIP+=",test_continuum_pulse_travels,test_tree_random_parameters_never_crash"
VALGRIND_SKIP+=",test_refine_heap_matches_naive_bitwise,test_refine_simulated_blade_end_to_end"
run_valgrind_tests() { # dir
  local dir="$1" t name out line p f rc tmp running q pids=() order=()
  tmp="$(mktemp -d)"
  # Two programs at a time (valgrind runs a program's threads one at a time, so each takes a
  # core), the longest first so that it does not start last: test_sim takes 5-9 minutes.
  for t in "$dir"/test_sim "$dir"/test_*; do
    [ -x "$t" ] || continue
    case " ${order[*]-} " in *" $t "*) continue ;; esac
    order+=("$t")
  done
  for t in ${order[@]+"${order[@]}"}; do
    while :; do
      running=0
      for q in ${pids[@]+"${pids[@]}"}; do
        if kill -0 "$q" 2>/dev/null; then running=$((running + 1)); fi
      done
      [ "$running" -lt "${TSK_VALGRIND_JOBS:-2}" ] && break
      sleep 1
    done
    name="$(basename "$t")"
    (
      rc=0
      cd "$dir" && TSK_TEST_SKIP="$VALGRIND_SKIP" OMP_WAIT_POLICY=PASSIVE \
        timeout "${TSK_VALGRIND_TIMEOUT:-1200}" valgrind --tool=memcheck --leak-check=full \
        --errors-for-leak-kinds=definite,indirect --error-exitcode=99 --num-callers=30 \
        --suppressions="$ROOT/native/tests/valgrind.supp" "$t" >"$tmp/$name.out" 2>&1 || rc=$?
      echo "$rc" >"$tmp/$name.rc"
    ) &
    pids+=("$!")
  done
  for q in ${pids[@]+"${pids[@]}"}; do wait "$q" || true; done
  for t in ${order[@]+"${order[@]}"}; do
    name="$(basename "$t")"
    out="$(cat "$tmp/$name.out" 2>/dev/null || true)"
    rc="$(cat "$tmp/$name.rc" 2>/dev/null || echo 1)"
    line="$(printf '%s\n' "$out" | grep -E '^[0-9]+ passed, [0-9]+ failed' | tail -n 1 || true)"
    if [ -z "$line" ]; then p=0; f=1; else
      p="${line%% passed*}"; f="${line#*passed, }"; f="${f%% failed*}"
    fi
    if [ "$rc" -ne 0 ]; then
      printf '%s\n' "$out" | grep -E '==[0-9]+== (Invalid|Conditional|Use of|.*definitely lost|.*indirectly lost|ERROR SUMMARY)|FAIL|TIMEOUT' | head -n 20 >&2 || true
      [ "$rc" -eq 124 ] && say "valgrind: $name timed out"
      [ "$f" -eq 0 ] && f=1
    fi
    printf '%-8s %-28s %s passed, %s failed\n' valgrind "$name" "$p" "$f"
    PASSED=$((PASSED + p)); FAILED=$((FAILED + f))
  done
  rm -rf "$tmp"
}

# The Blender suite (blender_tests/run.py) in Blender `major`; adds to PASSED/FAILED.
run_blender_suite() { # major
  local out line p f
  if out="$(with_blender "$1" "$ROOT/blender_tests/run.py" 2>&1)"; then :; fi
  printf '%s\n' "$out" | grep -v -E '^[0-9]+ passed, [0-9]+ failed$' || true
  line="$(printf '%s\n' "$out" | grep -E '^[0-9]+ passed, [0-9]+ failed$' | tail -n 1 || true)"
  if [ -z "$line" ]; then p=0; f=1; else
    p="${line%% passed*}"; f="${line#*passed, }"; f="${f%% failed*}"
  fi
  printf '%-8s %-28s %s passed, %s failed\n' "blender$1" "blender_tests" "$p" "$f"
  PASSED=$((PASSED + p)); FAILED=$((FAILED + f))
}

# Parses "--blender 3,4,5" (or --blender=...) into MAJORS; the rest stays in ARGS.
MAJORS=()
ARGS=()
parse_blenders() { # default list, args...
  local list="$1" m
  shift
  BLENDER_CHOSEN=0
  ARGS=()
  while [ $# -gt 0 ]; do
    case "$1" in
      --blender) [ $# -ge 2 ] || die "--blender needs 3, 4 or 5 (or a list: 3,5)"
                 list="$2"; BLENDER_CHOSEN=1; shift 2 ;;
      --blender=*) list="${1#*=}"; BLENDER_CHOSEN=1; shift ;;
      *) ARGS+=("$1"); shift ;;
    esac
  done
  IFS=, read -r -a MAJORS <<<"$list"
  for m in "${MAJORS[@]}"; do suite_of "$m" >/dev/null; done
}

# ./build.sh test: the native suites (release, ASan+UBSan, no-SIMD, valgrind, a short fuzz) and
# the Blender suite in Blenders 3.4, 4.3 and 5.x. With --blender N[,N...] only the Blender suite
# in those Blenders (quick work on one version).
cmd_test() {
  local t0 t1 m prep_log="" prep_pid=""
  t0=$(date +%s)
  parse_blenders 3,4,5 "$@"
  [ ${#ARGS[@]} -eq 0 ] || die "test: unknown argument '${ARGS[0]}'"
  cmd_deps
  # The roots download and build beside the native suites, and so does the portable build
  # (in its Debian 11 root) with the artists' roots it is tried in; they are waited for below.
  prep_log="$(mktemp)"
  (
    [ "$BLENDER_CHOSEN" = 0 ] && portable_build
    for m in "${MAJORS[@]}"; do
      root_build "$m"
      [ "$BLENDER_CHOSEN" = 1 ] || [ -z "$(suite_of "$m")" ] || artist_root "$(suite_of "$m")"
    done
  ) >"$prep_log" 2>&1 &
  prep_pid=$!
  cmd_build
  TSK_PORTABLE=0 cmd_package >/dev/null
  run_lint
  run_python_tests
  if [ "$BLENDER_CHOSEN" = 0 ]; then
    build_asan
    export ASAN_OPTIONS="detect_leaks=1:halt_on_error=1"
    export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
    run_native_tests "$BUILD/release" native
    run_native_tests "$BUILD/asan" asan+ubsan
    unset ASAN_OPTIONS UBSAN_OPTIONS
    build_nosimd
    run_native_tests "$BUILD/nosimd" nosimd
    # valgrind memcheck (TSK_VALGRIND=0 skips)
    if [ "${TSK_VALGRIND:-1}" != 0 ]; then
      run_valgrind_tests "$BUILD/release"
    fi
    # every fuzzer briefly (TSK_CI_FUZZ_SECONDS each, default 15; 0 skips)
    if [ "${TSK_CI_FUZZ_SECONDS:-15}" -gt 0 ]; then
      build_fuzz
      run_fuzzers "${TSK_CI_FUZZ_SECONDS:-15}"
    fi
    # the native suites on Windows: mingw-w64 cross-build, run under wine (TSK_WINDOWS=0 skips).
    # With the Windows libraries where they were built before: building them here (26 minutes
    # on 2 cores, beside the portable build's 25) put a fresh machine's run past CI's 90
    # minutes; TSK_WINDOWS_DEPS_BUILD=1 builds them.
    export TSK_WINDOWS_DEPS_BUILD="${TSK_WINDOWS_DEPS_BUILD:-0}"
    [ "${TSK_WINDOWS:-1}" = 0 ] || run_windows_tests
  fi
  if ! wait "$prep_pid"; then
    cat "$prep_log" >&2
    die "could not make the portable build or the Debian roots of Blenders ${MAJORS[*]}"
  fi
  rm -f "$prep_log"
  if [ "$BLENDER_CHOSEN" = 0 ]; then
    # the portable build: its native suites on Debian 11 (glibc 2.31), and the floor
    quiet in_root "$PORTABLE_SUITE" cmake --build "$PORTABLE/release" \
      || die "portable build of the native tests failed"
    run_native_tests "$PORTABLE/release" bullseye in_root "$PORTABLE_SUITE"
    run_floor_checks
    [ "${TSK_WINDOWS:-1}" = 0 ] || windows_zip tally
  fi
  for m in "${MAJORS[@]}"; do run_blender_suite "$m"; done
  # the short random soak, a new seed each run (TSK_SOAK_MINUTES per Blender; 0 skips)
  [ "${TSK_SOAK_MINUTES:-3}" = 0 ] || run_soak_checks "${MAJORS[@]}"
  if [ "$BLENDER_CHOSEN" = 0 ]; then
    local suites=()
    for m in "${MAJORS[@]}"; do [ -z "$(suite_of "$m")" ] || suites+=("$(suite_of "$m")"); done
    [ ${#suites[@]} -eq 0 ] || run_artist_checks "${suites[@]}"
    run_portable_binding_checks ${suites[@]+"${suites[@]}"}
  fi
  t1=$(date +%s)
  say "test time: $((t1 - t0)) s"
  echo "$PASSED passed, $FAILED failed"
  [ "$FAILED" -eq 0 ]
}

# ./build.sh demo [--blender N]: the demo's three clips and frames into out/, rendered by this
# machine's Blender 3.4 or by Blender N from its Debian root.
cmd_demo() {
  parse_blenders 3 "$@"
  [ ${#ARGS[@]} -eq 0 ] && [ ${#MAJORS[@]} -eq 1 ] || die "demo: takes one --blender N"
  cmd_deps
  cmd_build
  root_build "${MAJORS[0]}"
  mkdir -p "$ROOT/out"
  with_blender "${MAJORS[0]}" "$ROOT/tools/demo_run.py" -- "$ROOT/out"
}

# ./build.sh bench [--blender N[,N]] [--record] [NAME...]: the native benchmarks and the Blender ones in
# this machine's Blender; with --blender, only the Blender ones, in each Blender named.
cmd_bench() {
  local a out record=0 names=()
  parse_blenders 3 "$@"
  for a in ${ARGS[@]+"${ARGS[@]}"}; do
    if [ "$a" = --record ]; then record=1; else names+=("$a"); fi
  done
  if [ "$record" = 1 ]; then
    # every line also into this host's record (docs/perf/), then the table remade from it
    out="$(mktemp)"
    read -r TSK_BENCH_LOAD _ </proc/loadavg  # before the run, which loads the machine itself
    export TSK_BENCH_LOAD
    cmd_bench_run ${names[@]+"${names[@]}"} | tee "$out"
    "$PY" "$ROOT/tools/perf_table.py" record <"$out"
    rm -f "$out"
    "$PY" "$ROOT/tools/perf_table.py" write
    return
  fi
  cmd_bench_run ${names[@]+"${names[@]}"}
}

cmd_bench_run() {
  local m b s
  cmd_build
  # as inside Blender (addon/native.py): OpenMP waiters sleep instead of spinning
  export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-PASSIVE}"
  if [ "$BLENDER_CHOSEN" = 0 ]; then
    for b in "$BUILD/release"/bench_*; do
      [ -x "$b" ] || continue
      "$b" "$@"
    done
  fi
  # benchmarks that need Blender itself; each line's params name the Blender
  for m in "${MAJORS[@]}"; do
    root_build "$m"
    for s in "$ROOT"/tools/bench_*.py; do
      [ -f "$s" ] || continue
      case "${s##*/}" in bench_common.py) continue ;; esac
      with_blender "$m" "$ROOT/tools/blender_run.py" "$s" -- "$@" | grep '^{' || true
    done
  done
}

# ---- Debian roots for the newer Blenders ----------------------------------------------------

# The mirror this machine's apt takes Debian from, so the roots come from the same place;
# empty lets debootstrap use its own default.
host_mirror() {
  local f
  for f in /etc/apt/sources.list.d/*.sources /etc/apt/sources.list; do
    [ -f "$f" ] || continue
    sed -n -E 's#^(URIs:[[:space:]]*|deb[[:space:]]+(\[[^]]*\][[:space:]]+)?)([a-z]+://[^[:space:]]+/debian)/?([[:space:]].*)?$#\3#p' "$f"
  done | head -n 1
}

# Runs a command as root inside the Debian root of `suite`, in a mount namespace of its own:
# /proc, /sys, /dev, a tmpfs on /dev/shm and this checkout (at the same path) are mounted
# there and vanish with the command, so nothing is left mounted whatever happens. The
# command sees a clean environment plus the TSK_*, CI and OMP_* variables, and starts in the
# current folder when that is inside the checkout.
in_root() { # suite, command...
  local dir="$ROOTS/$1" kv pass=() cwd=/
  shift
  case "$PWD/" in "$ROOT"/*) cwd="$PWD" ;; esac
  while IFS= read -r kv; do pass+=("$kv"); done < <(env | grep -E '^(TSK_[A-Z0-9_]*|CI|OMP_[A-Z_]*)=' || true)
  unshare --mount --propagation private -- /bin/sh -euc '
    d="$1"; src="$2"; shift 2
    mount --bind "$d" "$d"  # the root a mount point, so that commands inside can unshare too
    mount -t proc proc "$d/proc"
    mount --rbind /sys "$d/sys"
    mount --rbind /dev "$d/dev"
    mount -t tmpfs -o mode=1777 tmpfs "$d/dev/shm"
    mkdir -p "$d$src"
    mount --bind "$src" "$d$src"
    exec chroot "$d" "$@"' in_root "$dir" "$ROOT" \
    env -i -C "$cwd" PATH=/usr/local/bin:/usr/bin:/bin:/usr/sbin:/sbin HOME=/root LANG=C.UTF-8 \
    TERM=dumb DEBIAN_FRONTEND=noninteractive "${pass[@]}" "$@"
}

# A minimal Debian `suite` in `dir` (debootstrap, once), its apt set up for this machine.
debootstrap_root() { # suite, dir, what it is for the messages
  local suite="$1" dir="$2" mirror
  mirror="$(host_mirror)"
  mkdir -p "$(dirname "$dir")"
  if [ ! -x "$dir/usr/bin/apt-get" ]; then
    say "build.sh: making $3 in $dir (debootstrap)"
    rm -rf "$dir.tmp"
    quiet debootstrap --variant=minbase "$suite" "$dir.tmp" ${mirror:+"$mirror"} \
      || die "debootstrap $suite failed"
    rm -rf "$dir"
    mv "$dir.tmp" "$dir"
  fi
  # sid's Release file can be past its Valid-Until date between two archive updates
  printf 'Acquire::Check-Valid-Until "false";\n' >"$dir/etc/apt/apt.conf.d/99tussock"
  if [ -f /etc/resolv.conf ]; then cp -L /etc/resolv.conf "$dir/etc/resolv.conf"; fi
}

# Makes (or brings up to date) the Debian root of `suite` with ROOT_PACKAGES installed (for
# the portable build's root, PORTABLE_PACKAGES). A root whose stamp lists the same packages
# is reused as it is.
root_ensure() { # suite
  local suite="$1" dir="$ROOTS/$1" want mirror pkgs=("${ROOT_PACKAGES[@]}")
  [ "$suite" = "$PORTABLE_SUITE" ] && pkgs=("${PORTABLE_PACKAGES[@]}")
  want="${pkgs[*]}"
  if [ -f "$dir/.tussock-packages" ] && [ "$(cat "$dir/.tussock-packages")" = "$want" ]; then
    return 0
  fi
  mirror="$(host_mirror)"
  debootstrap_root "$suite" "$dir" "the Debian $suite root"
  if [ "$suite" = "$PORTABLE_SUITE" ]; then
    # the sources of the libraries it builds: Debian 12's versions (native/portable/
    # build_deps.sh says why), and sid's for a file this mirror lacks in bookworm's revision
    printf 'deb-src %s bookworm main\ndeb-src %s sid main\n' "${mirror:-http://deb.debian.org/debian}" \
      "${mirror:-http://deb.debian.org/debian}" >"$dir/etc/apt/sources.list.d/tussock-src.list"
  fi
  say "build.sh: installing into the $suite root: $want"
  quiet in_root "$suite" apt-get update -qq || die "apt-get update in the $suite root failed"
  quiet in_root "$suite" apt-get install -y -qq --no-install-recommends "${pkgs[@]}" \
    || die "apt-get install in the $suite root failed"
  printf '%s\n' "$want" >"$dir/.tussock-packages"
}

# An add-on folder for a build: links to addon/'s sources, with that build's own binaries.
addon_for() { # build dir, add-on dir
  local from="$1" to="$2" e name
  mkdir -p "$to"
  for e in "$to"/*; do  # sources removed from addon/ since the last run
    if [ -L "$e" ] && [ ! -e "$e" ]; then rm -f "$e"; fi
  done
  for e in "$ROOT"/addon/*; do
    name="${e##*/}"
    case "$name" in _tussock*.so|tussock_oni_reader|__pycache__) continue ;; esac
    [ -L "$to/$name" ] || ln -sfn "$e" "$to/$name"
  done
  for name in _tussock.abi3.so tussock_oni_reader; do
    cmp -s "$from/$name" "$to/$name" || install_binary "$from/$name" "$to/$name"
  done
}

# The root of Blender `major` made and its add-on built: $BUILD/root-SUITE/{release,addon,dist}
root_build() { # major
  local suite b
  suite="$(suite_of "$1")"
  [ -n "$suite" ] || return 0
  b="$BUILD/root-$suite"
  root_ensure "$suite"
  if [ ! -f "$b/release/build.ninja" ]; then
    quiet in_root "$suite" cmake -S "$ROOT/native" -B "$b/release" -G Ninja \
      -DCMAKE_BUILD_TYPE=Release || die "cmake configure failed in the $suite root"
  fi
  quiet in_root "$suite" cmake --build "$b/release" --target _tussock tussock_oni_reader \
    || die "native build failed in the $suite root"
  addon_for "$b/release" "$b/addon"
  quiet in_root "$suite" python3 "$ROOT/tools/package.py" "$ROOT" "$b/dist" "$b/addon" \
    || die "packaging failed in the $suite root"
}

# ---- the portable Linux extension (docs/platforms.md) ---------------------------------------
# Built in a Debian 11 root (glibc 2.31; glibc_floor.h pins the few newer symbols to 2.28),
# against libraries that native/portable/build_deps.sh builds there from Debian's source
# packages, once: they are kept in the root (/opt/tussock-deps), stamped with the hash of the
# files that make them.
PORTABLE_SUITE=bullseye
PORTABLE_PACKAGES=(cmake ninja-build pkg-config g++ clang make patch xz-utils bzip2 dpkg-dev
                   nasm ca-certificates binutils python3)
PORTABLE="$BUILD/portable"

portable_deps() {
  local dir="$ROOTS/$PORTABLE_SUITE" want log
  root_ensure "$PORTABLE_SUITE"
  want="$(cat "$ROOT/native/portable/build_deps.sh" "$ROOT/native/portable/glibc_floor.h" \
    | sha256sum | cut -c1-16)"
  if [ "$(cat "$dir/opt/tussock-deps/.stamp" 2>/dev/null)" != "$want" ]; then
    mkdir -p "$PORTABLE"
    log="$PORTABLE/deps.log"
    say "build.sh: building OpenCV, OpenSubdiv, OpenNI2 and their codecs from Debian's sources" \
      "in the $PORTABLE_SUITE root, once (about 25 minutes on 2 cores; log: $log)"
    rm -rf "$dir/opt/tussock-deps" "$dir/opt/tussock-deps.work"
    if ! in_root "$PORTABLE_SUITE" bash "$ROOT/native/portable/build_deps.sh" /opt/tussock-src \
        /opt/tussock-deps >"$log" 2>&1; then
      tail -n 40 "$log" >&2
      die "building the portable build's libraries failed (log: $log)"
    fi
    rm -rf "$dir/opt/tussock-deps.work"
    printf '%s\n' "$want" >"$dir/opt/tussock-deps/.stamp"
  fi
  # The module is built against CPython 3.11's headers (limited API, abi3 >= 3.11, the
  # Python of Blender 4.2 and later); Debian 11 has 3.9, so the host's (Debian 12) go in.
  if ! cmp -s /usr/include/python3.11/Python.h "$dir/opt/python3.11/include/python3.11/Python.h"; then
    mkdir -p "$dir/opt/python3.11/include/x86_64-linux-gnu"
    cp -a /usr/include/python3.11 "$dir/opt/python3.11/include/"
    cp -a /usr/include/x86_64-linux-gnu/python3.11 "$dir/opt/python3.11/include/x86_64-linux-gnu/"
  fi
}

# The portable build: $BUILD/portable/{release,addon,dist}; the zip
# dist/tussock-VERSION-linux_x64.zip, checked by tools/binary_floor.py.
portable_build() {
  local b="$PORTABLE/release" a="$PORTABLE/addon" deps f
  portable_deps
  deps="$ROOTS/$PORTABLE_SUITE/opt/tussock-deps"
  if [ ! -f "$b/build.ninja" ]; then
    quiet in_root "$PORTABLE_SUITE" cmake -S "$ROOT/native" -B "$b" -G Ninja \
      -DCMAKE_BUILD_TYPE=Release -DTSK_PORTABLE_DEPS=/opt/tussock-deps \
      "-DTSK_PYTHON_INCLUDE=/opt/python3.11/include/python3.11;/opt/python3.11/include" \
      || die "cmake configure failed in the $PORTABLE_SUITE root"
  fi
  quiet in_root "$PORTABLE_SUITE" cmake --build "$b" --target _tussock tussock_oni_reader \
    || die "portable build failed"
  addon_for "$b" "$a"
  # OpenNI2 and its drivers in lib/ (found through the binaries' RPATH $ORIGIN/lib; OpenNI2
  # loads its drivers from OpenNI2/Drivers beside itself)
  mkdir -p "$a/lib/OpenNI2/Drivers"
  cp "$deps/openni2/libOpenNI2.so.0" "$a/lib/"
  rm -f "$a"/lib/OpenNI2/Drivers/*
  cp "$deps"/openni2/OpenNI2/Drivers/lib*.so.0 "$a/lib/OpenNI2/Drivers/"
  # no symbols an artist's Blender needs: a smaller zip
  for f in "$a/_tussock.abi3.so" "$a/tussock_oni_reader" "$a/lib/libOpenNI2.so.0" \
      "$a"/lib/OpenNI2/Drivers/*.so.0; do
    in_root "$PORTABLE_SUITE" strip --strip-unneeded "$f"
  done
  mkdir -p "$ROOT/dist"
  "$PY" "$ROOT/tools/package.py" "$ROOT" "$ROOT/dist" "$a" --platform linux_x64 >/dev/null \
    || die "packaging the linux_x64 zip failed"
  "$PY" "$ROOT/tools/binary_floor.py" "$(portable_zip)" >"$PORTABLE/floor.txt" 2>&1 || {
    cat "$PORTABLE/floor.txt" >&2
    die "the linux_x64 zip needs more than the base system or newer symbols than the floor"
  }
}

# ---- artists' machines: roots with Blender and numpy alone ---------------------------------
# What an artist has: Debian's blender (with its own dependencies) and numpy, nothing of
# ours, no OpenCV, OpenNI2 or OpenSubdiv development packages, no compiler. Made once per
# suite in $ROOTS/artist-SUITE, from the packages the suite's test root already downloaded.
ARTIST_PACKAGES=(blender python3-numpy)
artist_root() { # suite
  local suite="$1" dir="$ROOTS/artist-$1" want="${ARTIST_PACKAGES[*]}"
  [ -f "$dir/.tussock-packages" ] && [ "$(cat "$dir/.tussock-packages")" = "$want" ] && return 0
  root_ensure "$suite"  # its apt cache holds blender's packages
  debootstrap_root "$suite" "$dir" "an artist's $suite root (Blender and numpy only)"
  find "$ROOTS/$suite/var/cache/apt/archives" -maxdepth 1 -name '*.deb' \
    -exec cp -n {} "$dir/var/cache/apt/archives/" \; 2>/dev/null || true
  quiet in_root "artist-$suite" apt-get update -qq || die "apt-get update in artist-$suite failed"
  quiet in_root "artist-$suite" apt-get install -y -qq --no-install-recommends "${ARTIST_PACKAGES[@]}" \
    || die "apt-get install in artist-$suite failed"
  in_root "artist-$suite" apt-get clean
  printf '%s\n' "$want" >"$dir/.tussock-packages"
}

# The portable zip on an artist's machine: in artist-SUITE, installed with
# `blender --command extension install-file`, enabled in a new Blender, and the artist's
# path (tools/artist_check.py: capture from files and a recording, refine, meadow with a
# collider, tree, picture, bake, one rendered frame) run there; then the same script with
# the suite's apt build (its test root); the hashes of both must be equal. Adds to
# PASSED/FAILED, one result per suite.
run_artist_checks() { # suite...
  local suite w zip oni rc
  zip="$(portable_zip)"
  w="$BUILD/artist"
  rm -rf "$w"
  mkdir -p "$w"
  oni="$w/blades.oni"
  "$BUILD/release/png_to_oni" "$oni" "$ROOT/samples/blades/depth_####.png" >/dev/null \
    || die "could not make the test recording"
  for suite in "$@"; do
    artist_root "$suite"
    rc=0
    # (the farm on an artist's machine, in sid: native/portable/artist_run.sh)
    in_root "artist-$suite" env HOME="$w/$suite-home" TSK_ARTIST_ZIP="$zip" \
      TSK_ARTIST_FARM="$([ "$suite" = sid ] && echo 1 || echo 0)" \
      bash "$ROOT/native/portable/artist_run.sh" "$ROOT" "$w/$suite-portable" "$oni" \
      >"$w/$suite-portable.log" 2>&1 || rc=$?
    if [ "$rc" -eq 0 ]; then
      in_root "$suite" env TSK_ADDON="$BUILD/root-$suite/addon" python3 \
        "$ROOT/tools/blender_run.py" "$ROOT/tools/artist_check.py" -- "$w/$suite-apt/out.json" \
        "$w/$suite-apt/work" "$ROOT/samples" "$oni" >"$w/$suite-apt.log" 2>&1 || rc=$?
    fi
    # trixie's and sid's OpenCV (4.10) is not the zip's (Debian 12's 4.6): the picture's
    # inpainted background is compared within a bound (tools/artist_compare.py)
    if [ "$rc" -eq 0 ] && "$PY" "$ROOT/tools/artist_compare.py" --opencv-differs \
        "$w/$suite-portable/out.json" "$w/$suite-apt/out.json" >"$w/$suite-compare.txt" 2>&1; then
      printf '%-8s %-28s 1 passed, 0 failed\n' artist "linux_x64 zip in $suite"
      PASSED=$((PASSED + 1))
    else
      cat "$w/$suite-compare.txt" 2>/dev/null >&2 || true
      tail -n 30 "$w/$suite-portable.log" "$w/$suite-apt.log" 2>/dev/null >&2 || true
      printf '%-8s %-28s 0 passed, 1 failed (logs: %s)\n' artist "linux_x64 zip in $suite" "$w"
      FAILED=$((FAILED + 1))
    fi
  done
}

# tools/binary_floor.py on what ships: the linux_x64 zip passes; the add-on built in the sid
# root (glibc 2.4x, Debian's shared OpenCV) must fail it, or the check proves nothing.
run_floor_checks() {
  local out
  if out="$("$PY" "$ROOT/tools/binary_floor.py" "$(portable_zip)" 2>&1)"; then
    printf '%-8s %-28s 1 passed, 0 failed\n' floor "linux_x64 zip"; PASSED=$((PASSED + 1))
  else
    printf '%s\n' "$out"
    printf '%-8s %-28s 0 passed, 1 failed\n' floor "linux_x64 zip"; FAILED=$((FAILED + 1))
  fi
  if [ -f "$BUILD/root-sid/addon/_tussock.abi3.so" ]; then
    out="$("$PY" "$ROOT/tools/binary_floor.py" "$BUILD/root-sid/addon" 2>&1)" && out=""
    if printf '%s\n' "$out" | grep -q 'above the floor GLIBC_2.28' \
        && printf '%s\n' "$out" | grep -q 'needs libopencv_core'; then
      printf '%-8s %-28s 1 passed, 0 failed\n' floor "sid build is refused"; PASSED=$((PASSED + 1))
    else
      printf '%s\n' "$out"
      printf '%-8s %-28s 0 passed, 1 failed\n' floor "sid build is refused"; FAILED=$((FAILED + 1))
    fi
  fi
}

portable_zip() {
  local v
  v="$(sed -n -E 's/^version *= *"([0-9.]+)".*/\1/p' "$ROOT/manifest.toml")"
  printf '%s\n' "$ROOT/dist/tussock-$v-linux_x64.zip"
}

# Runs a Python script of the checkout with Blender `major`: this machine's own, or the one
# in its Debian root with the add-on built there (TSK_ADDON, TSK_DIST tell tools/blender_env.py
# and the tests where that build is).
with_blender() { # major, python script, args...
  local suite
  suite="$(suite_of "$1")"
  shift
  if [ -z "$suite" ]; then
    "$PY" "$@"
  else
    in_root "$suite" env TSK_ADDON="$BUILD/root-$suite/addon" TSK_DIST="$BUILD/root-$suite/dist" \
      python3 "$@"
  fi
}

# ./build.sh package: the Debian zips (legacy, extension) of this machine's build and, unless
# TSK_PORTABLE=0, the self-contained linux_x64 extension of the portable build.
cmd_package() {
  cmd_build
  "$PY" "$ROOT/tools/package.py" "$ROOT" "$ROOT/dist"
  if [ "${TSK_PORTABLE:-1}" != 0 ]; then
    portable_build
    portable_zip
    windows_zip
  fi
}

# Screenshots of every Tussock panel, for the docs (docs/images/ui/ui_<state>.png): the
# real-window panel test, run in the Blender named (default 5, what most artists run), keeps
# the sidebar of each state it draws.
cmd_shots() {
  parse_blenders 5 "$@"
  [ ${#ARGS[@]} -eq 0 ] && [ ${#MAJORS[@]} -eq 1 ] || die "shots: takes one --blender N"
  cmd_deps
  cmd_build
  root_build "${MAJORS[0]}"
  TSK_UI_SHOTS="$ROOT/docs/images/ui" with_blender "${MAJORS[0]}" \
    "$ROOT/blender_tests/run.py" test_window_panels
}

# ./build.sh soak [--blender N[,N]] [--minutes M] [--seed S] [--window] [--gdb] [--asan] [...]:
# the soak tester (tools/soak.py, issue 42) in each Blender named (default this machine's
# 3.4); other arguments go to tools/soak.py as they are (--steps, --debug-memory, --only, ...).
# --asan (this machine's Blender 3.4 only): the add-on's library built with AddressSanitizer
# and UndefinedBehaviorSanitizer, and clang's ASan runtime preloaded into Blender.
cmd_soak() {
  local m rc=0 a asan=0 args=()
  parse_blenders 3 "$@"
  for a in ${ARGS[@]+"${ARGS[@]}"}; do
    if [ "$a" = --asan ]; then asan=1; else args+=("$a"); fi
  done
  cmd_deps
  cmd_build
  if [ "$asan" = 1 ]; then
    [ "${MAJORS[*]}" = 3 ] || die "soak --asan: only with this machine's Blender 3.4 (--blender 3)"
    configure "$BUILD/asan-module" -DCMAKE_BUILD_TYPE=Debug -DTSK_SANITIZE=ON \
      -DTSK_SANITIZE_MODULE=ON -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++
    quiet cmake --build "$BUILD/asan-module" --target _tussock tussock_oni_reader \
      || die "sanitizer build of the extension failed"
    rm -rf "$BUILD/asan-addon"
    cp -a "$ROOT/addon" "$BUILD/asan-addon"
    cp "$BUILD/asan-module/_tussock.abi3.so" "$BUILD/asan-module/tussock_oni_reader" \
      "$BUILD/asan-addon/"
    # Blender's own code is not built for ASan: allocations it makes and frees with other
    # calls, and what it leaves at exit, are Blender's (the leak check is --debug-memory's)
    TSK_ADDON="$BUILD/asan-addon" \
      TSK_SOAK_PRELOAD="$(clang -print-file-name=libclang_rt.asan-x86_64.so)" \
      TSK_SOAK_ASAN_OPTIONS="detect_leaks=0:alloc_dealloc_mismatch=0:halt_on_error=1:abort_on_error=1" \
      TSK_SOAK_UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1" \
      "$PY" "$ROOT/tools/soak.py" ${args[@]+"${args[@]}"} || rc=1
    return "$rc"
  fi
  for m in "${MAJORS[@]}"; do
    root_build "$m"
    say "build.sh soak: Blender $m"
    with_blender "$m" "$ROOT/tools/soak.py" ${args[@]+"${args[@]}"} || rc=1
  done
  return "$rc"
}

# ./build.sh leaks [--blender N[,N]] [--background] [CYCLES]: resident memory over CYCLES
# (default 1000) add/delete cycles of a meadow and of a tree (tools/leak_cycles.py, issue 42)
# in each Blender named (default 3,4,5), in a real window on Xvfb as an artist works (each
# cycle in a timer call, Blender's event loop between them) or with --background in background
# Blender; fails when memory after the last cycle is more than 5 % above that after cycle 100,
# or Tussock's native bytes or data-blocks differ. Then the control: as many plain objects as
# a meadow makes, without Tussock (what Blender itself keeps; never fails).
cmd_leaks() {
  local m kind a rc=0 mode=(--window) rest=()
  parse_blenders 3,4,5 "$@"
  for a in ${ARGS[@]+"${ARGS[@]}"}; do
    if [ "$a" = --background ]; then mode=(); else rest+=("$a"); fi
  done
  cmd_deps
  cmd_build
  for m in "${MAJORS[@]}"; do
    root_build "$m"
    for kind in meadow tree objects; do
      say "build.sh leaks: Blender $m, $kind, ${mode[*]:-background}"
      with_blender "$m" "$ROOT/tools/blender_run.py" ${mode[@]+"${mode[@]}"} \
        "$ROOT/tools/leak_cycles.py" -- "$kind" ${rest[@]+"${rest[@]}"} \
        | grep -E '^(cycle|LEAK|CONTROL)' || rc=1
    done
  done
  return "$rc"
}

# The short soak of the test run: TSK_SOAK_MINUTES (default 3) in background Blender `major`,
# with a seed from the clock (printed, so that a red run can be replayed with --seed); one
# result for the run, added to PASSED/FAILED. The Blenders soak side by side: a soak lasts
# its minutes however loaded the cores are (it takes fewer steps), so one after another
# spent 3 minutes of the run per Blender for nothing else. Side by side they measure a scene
# in a fresh Blender from 4,000 MB rather than 6,000, so that three soaks and their fresh
# Blenders stay inside a 24 GiB machine.
run_soak_checks() { # major...
  local m out seed line f i rc
  local -a seeds=() outs=() pids=()
  for m in "$@"; do
    # the failures it found that only a replay of their steps shows (a crash inside Blender)
    for f in "$ROOT"/tests/soak_replays/*.json; do
      [ -e "$f" ] || continue
      if out="$(with_blender "$m" "$ROOT/tools/soak.py" --replay "$f" 2>&1)"; then
        printf '%-8s %-28s 1 passed, 0 failed\n' "blender$m" "replay $(basename "$f" .json | cut -c1-21)"
        PASSED=$((PASSED + 1))
      else
        printf '%s\n' "$out" | tail -n 40
        printf '%-8s %-28s 0 passed, 1 failed\n' "blender$m" "replay $(basename "$f" .json | cut -c1-21)"
        FAILED=$((FAILED + 1))
      fi
    done
  done
  seed="$(($(date +%s) % 1000000))"
  i=0
  for m in "$@"; do
    seeds[i]=$((seed + i))
    say "soak in Blender $m: seed ${seeds[i]} (./build.sh soak --blender $m --seed ${seeds[i]} replays it)"
    outs[i]="$(mktemp)"
    with_blender "$m" "$ROOT/tools/soak.py" --minutes "${TSK_SOAK_MINUTES:-3}" \
      --seed "${seeds[i]}" --max-failures 1 --shrink-minutes 5 --max-rss-mb 4000 >"${outs[i]}" 2>&1 &
    pids[i]=$!
    i=$((i + 1))
  done
  i=0
  for m in "$@"; do
    rc=0
    wait "${pids[i]}" || rc=$?
    if [ "$rc" = 0 ]; then
      line="$(grep -E '^soak: [0-9]+ steps in' "${outs[i]}" | tail -n 1 || true)"
      printf '%-8s %-28s 1 passed, 0 failed  (%s)\n' "blender$m" soak "${line#soak: }"
      PASSED=$((PASSED + 1))
    else
      tail -n 80 "${outs[i]}"
      printf '%-8s %-28s 0 passed, 1 failed  (seed %s)\n' "blender$m" soak "${seeds[i]}"
      FAILED=$((FAILED + 1))
    fi
    rm -f "${outs[i]}"
    i=$((i + 1))
  done
}

windows_packages() {
  local missing=() p
  for p in mingw-w64 wine wine64; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if [ ${#missing[@]} -gt 0 ]; then
    quiet apt-get update -qq || die "apt-get update failed"
    DEBIAN_FRONTEND=noninteractive quiet apt-get install -y -qq --no-install-recommends \
      "${missing[@]}" || die "apt-get install failed for: ${missing[*]}"
  fi
}

# The Windows build's third-party libraries: OpenSubdiv and OpenCV with its codecs, cross-built
# by native/portable/build_deps_windows.sh from the portable build's Debian source packages
# into $WINDOWS_DEPS/prefix (kept between runs, emptied when a script that makes them
# changes). A run resumes after the last library that was finished; one that fails leaves the
# Windows build to use those that were (its log says why). Then OpenNI2 (windows_openni2).
# Sets WINDOWS_WITH: the CMake options of the Windows builds (windows_tests.sh,
# windows_module.sh).
WINDOWS_DEPS="${TSK_WINDOWS_DEPS:-/var/cache/tussock/windows-deps}"
windows_deps() {
  local prefix="$WINDOWS_DEPS/prefix" src="$ROOTS/$PORTABLE_SUITE/opt/tussock-src" want p
  want="$(cat "$ROOT/native/portable/build_deps.sh" "$ROOT/native/portable/build_deps_windows.sh" \
    "$ROOT/native/cmake/mingw-w64-x86_64.cmake" | sha256sum | cut -c1-16)"
  if [ "$(cat "$WINDOWS_DEPS/.stamp" 2>/dev/null)" != "$want" ]; then
    rm -rf "$WINDOWS_DEPS"
    mkdir -p "$WINDOWS_DEPS"
    printf '%s\n' "$want" >"$WINDOWS_DEPS/.stamp"
  fi
  if [ ! -f "$prefix/.built-opencv" ] && [ "${TSK_WINDOWS_DEPS_BUILD:-1}" = 0 ]; then
    say "build.sh: the Windows build's OpenCV and OpenSubdiv are not built on this machine:" \
      "it goes without them (./build.sh windows or package builds them, about 20 minutes once)"
  elif [ ! -f "$prefix/.built-opencv" ]; then
    if ! ls "$src"/opencv_*.orig.tar.* >/dev/null 2>&1; then # (build_deps.sh fetches them)
      root_ensure "$PORTABLE_SUITE"
      mkdir -p "$src"
      for p in zlib libpng1.6 libjpeg-turbo imath openexr opencv opensubdiv; do
        in_root "$PORTABLE_SUITE" bash -c "cd /opt/tussock-src && apt-get source -qq \
          --download-only $p/bookworm >/dev/null 2>&1" || true
      done
    fi
    say "build.sh: cross-building OpenSubdiv and OpenCV for Windows from Debian's sources, once" \
      "(about 20 minutes on 2 cores; log: $WINDOWS_DEPS/deps.log)"
    flock "$WINDOWS_DEPS/.lock" bash "$ROOT/native/portable/build_deps_windows.sh" "$src" \
      "$prefix" >"$WINDOWS_DEPS/deps.log" 2>&1 \
      || say "build.sh: the Windows libraries did not all build (log: $WINDOWS_DEPS/deps.log)"
    [ ! -f "$prefix/.built-opencv" ] || rm -rf "$prefix.work" # (the sources and objects)
  fi
  windows_openni2 "$src"
  WINDOWS_WITH=("-DTSK_PORTABLE_DEPS=$prefix")
  if [ -f "$WINDOWS_DEPS/openni2/.built-openni2" ]; then
    WINDOWS_WITH+=(-DTSK_WITH_OPENNI2=ON "-DTSK_OPENNI2_WINDOWS=$WINDOWS_DEPS/openni2")
  else
    WINDOWS_WITH+=(-DTSK_WITH_OPENNI2=OFF)
  fi
  for p in opensubdiv opencv; do
    if [ -f "$prefix/.built-$p" ]; then
      WINDOWS_WITH+=("-DTSK_WITH_${p^^}=ON")
    else
      WINDOWS_WITH+=("-DTSK_WITH_${p^^}=OFF")
    fi
  done
}

# OpenNI2 for the Windows build (native/portable/build_openni2_windows.sh: OpenNI2.dll and its
# drivers, from the same Debian source package as the portable build's) in a prefix of its own,
# $WINDOWS_DEPS/openni2, with a stamp of its own: changing how it is built rebuilds it alone
# (a few minutes), not OpenCV. A build that fails leaves the Windows build without OpenNI2.
windows_openni2() { # source folder
  local src="$1" oni="$WINDOWS_DEPS/openni2" want
  want="$(cat "$ROOT/native/portable/build_deps.sh" \
    "$ROOT/native/portable/build_openni2_windows.sh" "$ROOT"/native/portable/openni2_windows/* \
    "$ROOT/native/cmake/mingw-w64-x86_64.cmake" | sha256sum | cut -c1-16)"
  if [ "$(cat "$oni/.stamp" 2>/dev/null)" != "$want" ]; then
    rm -rf "$oni" "$oni.work"
    mkdir -p "$oni"
    printf '%s\n' "$want" >"$oni/.stamp"
  fi
  [ ! -f "$oni/.built-openni2" ] || return 0
  if [ "${TSK_WINDOWS_DEPS_BUILD:-1}" = 0 ]; then
    say "build.sh: the Windows build's OpenNI2 is not built on this machine: it goes without" \
      "(./build.sh windows or package builds it, about 6 minutes once)"
    return 0
  fi
  if ! ls "$src"/openni2_*.orig.tar.* >/dev/null 2>&1; then # (build_deps.sh fetches it)
    root_ensure "$PORTABLE_SUITE"
    mkdir -p "$src"
    in_root "$PORTABLE_SUITE" bash -c "cd /opt/tussock-src && apt-get source -qq \
      --download-only openni2/bookworm >/dev/null 2>&1" || true
  fi
  say "build.sh: cross-building OpenNI2 for Windows from Debian's sources, once" \
    "(about 6 minutes on 2 cores; log: $WINDOWS_DEPS/openni2.log)"
  flock "$WINDOWS_DEPS/.lock" bash "$ROOT/native/portable/build_openni2_windows.sh" "$src" \
    "$oni" >"$WINDOWS_DEPS/openni2.log" 2>&1 \
    || say "build.sh: OpenNI2 for Windows did not build (log: $WINDOWS_DEPS/openni2.log)"
  [ ! -f "$oni/.built-openni2" ] || rm -rf "$oni.work" # (the sources and objects)
}

# ./build.sh windows: the C core and its native tests cross-built for Windows x64 with
# Debian's mingw-w64 (with OpenCV, OpenSubdiv and OpenNI2: windows_deps) and run under wine
# (native/portable/windows_tests.sh; docs/platforms.md says what passes); ./build.sh test runs
# them too, and makes and checks the windows_x64 zip (windows_zip).
cmd_windows() {
  windows_packages
  bash "$ROOT/native/portable/windows_tests.sh" "$BUILD/windows"
}

# The native suites cross-built for Windows and run under wine (cmd_windows), in ./build.sh
# test: their per-test lines, and their tally added to PASSED/FAILED.
run_windows_tests() {
  local out line p f
  windows_packages
  out="$(bash "$ROOT/native/portable/windows_tests.sh" "$BUILD/windows" 2>&1)" || true
  printf '%s\n' "$out" | grep -v -E '^[0-9]+ passed, [0-9]+ failed$' || true
  line="$(printf '%s\n' "$out" | grep -E '^[0-9]+ passed, [0-9]+ failed$' | tail -n 1 || true)"
  if [ -z "$line" ]; then p=0; f=1; else
    p="${line%% passed*}"; f="${line#*passed, }"; f="${f%% failed*}"
  fi
  PASSED=$((PASSED + p)); FAILED=$((FAILED + f))
}

# The windows_x64 zip (native/portable/windows_module.sh: _tussock.pyd against python3.dll, its
# import table checked, loaded under wine); CPython's Windows headers from Debian's python3.11
# source package, fetched in the portable build's root, whose apt lists bookworm's sources.
# Prints the script's check lines; with `tally` set, adds them to PASSED/FAILED.
windows_zip() { # [tally]
  local src="$ROOTS/$PORTABLE_SUITE/opt/tussock-src/python" tarball out line p f
  windows_packages
  root_ensure "$PORTABLE_SUITE"
  tarball="$(ls "$src"/python3.11_*.orig.tar.* 2>/dev/null | head -n 1 || true)"
  if [ -z "$tarball" ]; then
    mkdir -p "$src"
    quiet in_root "$PORTABLE_SUITE" bash -c \
      'cd /opt/tussock-src/python && apt-get source -qq --download-only python3.11/bookworm' \
      || die "could not fetch python3.11's source package"
    tarball="$(ls "$src"/python3.11_*.orig.tar.* | head -n 1)"
  fi
  out="$(bash "$ROOT/native/portable/windows_module.sh" "$BUILD/windows-module" "$tarball" \
    "$ROOT/dist" 2>&1)" || true
  printf '%s\n' "$out" | grep -v -E '^[0-9]+ passed, [0-9]+ failed$' || true
  [ "${1:-}" = tally ] || return 0
  line="$(printf '%s\n' "$out" | grep -E '^[0-9]+ passed, [0-9]+ failed$' | tail -n 1 || true)"
  if [ -z "$line" ]; then p=0; f=1; else
    p="${line%% passed*}"; f="${line#*passed, }"; f="${f%% failed*}"
  fi
  PASSED=$((PASSED + p)); FAILED=$((FAILED + f))
}

# Makes the Debian roots of the Blenders named (default: all but this machine's own) and
# builds the add-on in each.
cmd_roots() {
  local m
  [ $# -gt 0 ] || set -- 4 5
  for m in "$@"; do root_build "$m"; done
}

main() {
  local cmd="${1:-}"
  [ $# -gt 0 ] && shift
  case "$cmd" in
    deps) cmd_deps ;;
    build) cmd_deps; cmd_build ;;
    test) cmd_test "$@" ;;
    demo) cmd_demo "$@" ;;
    bench) cmd_deps; cmd_bench "$@" ;;
    package) cmd_deps; cmd_package ;;
    fuzz) cmd_deps; cmd_fuzz "$@" ;;
    roots) cmd_deps; cmd_roots "$@" ;;
    shots) cmd_shots "$@" ;;
    soak) cmd_soak "$@" ;;
    leaks) cmd_leaks "$@" ;;
    windows) cmd_windows ;;
    *) say "usage: ./build.sh deps | build | test [--blender 3|4|5[,...]] | demo [--blender N]"
       say "                  | bench [--blender N] [--record] [NAME...] | package | fuzz [SECONDS [NAME...]]"
       say "                  | roots [4] [5] | shots [--blender N] | windows"
       say "                  | soak [--blender N] [--minutes M] [--seed S] | leaks [--blender N] [--background] [CYCLES]"
       exit 2 ;;
  esac
}

if [ "${BASH_SOURCE[0]}" = "$0" ]; then main "$@"; fi  # sourcing only defines the steps
