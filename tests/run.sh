#!/bin/sh
# run.sh MODE - run the test suites and print one tally line at the end.
#   plain     the C tests and the busted specs with the normal build
#   sanitize  the same under AddressSanitizer + UndefinedBehaviorSanitizer:
#             the specs run inside build/asan/nzlua, which loads the
#             sanitized engine; LeakSanitizer checks a million-operation loop
#   all       both
# Every suite prints TAP ("ok N" / "not ok N") or GSL-style PASS/FAIL lines;
# this script counts them and exits 1 if any failed or a suite crashed.
mode=${1:-all}
cd "$(dirname "$0")/.." || exit 1
log=$(mktemp -d)
# Everything the tests write stays under $log: the machine code's cache
# (never the user's ~/.cache/nzlua) and GNU parallel's own files (never
# ~/.parallel).
export NZLUA_CACHE="$log/cache"
export PARALLEL_HOME="$log/parallel"
passed=0
failed=0
skipped=0
suites=0

# suite NAME COMMAND...: run, echo the output, count the results.
suite() {
  name=$1; shift
  suites=$((suites + 1))
  out="$log/$suites.out"
  echo "== $name"
  "$@" >"$out" 2>&1
  rc=$?
  cat "$out"
  # A skipped test ("ok N - # SKIP why": an optional tool is missing) is
  # counted apart, not as passed.
  p=$(grep -E '^(ok [0-9]|PASS:)' "$out" | grep -cv '^ok [0-9]* - # SKIP')
  s=$(grep -cE '^ok [0-9]+ - # SKIP' "$out")
  f=$(grep -cE '^(not ok [0-9]|FAIL:)' "$out")
  if [ "$rc" -ne 0 ] && [ "$f" -eq 0 ]; then
    echo "not ok - suite '$name' exited with status $rc without reporting a failed test"
    f=1
  fi
  passed=$((passed + p))
  failed=$((failed + f))
  skipped=$((skipped + s))
}

# One-shot scripts count as one test each.
script_test() {
  name=$1; shift
  if "$@"; then echo "ok 1 - $name"; else echo "not ok 1 - $name"; return 1; fi
}

# Every spec in tests/ (a new one cannot be left out).
specs=$(ls tests/*_spec.lua | sort | tr '\n' ' ')
BUSTED="/usr/bin/busted -o TAP --helper=tests/busted_setup.lua"

if [ "$mode" = plain ] || [ "$mode" = all ]; then
  suite "C core (series, jets)" build/test_series
  suite "C core (expression graphs)" build/test_graph
  suite "C core (graphs compiled to C)" build/test_native
  suite "C core (the integrator interface)" build/test_stepper
  suite "C core (contacts: the LCP, impacts, friction)" build/test_contact
  # NZ_GRAPH_CHECK=1: every system the specs make is checked, when it is
  # made, against the Lua evaluator (values, jets, state directions); the
  # compiled code of the plans goes to a fresh cache.
  suite "Lua specs (lua5.4 + build/nz.so)" env LUA_CPATH="build/?.so;;" NZLUA=build/nzlua \
    NZ_GRAPH_CHECK=1 lua5.4 $BUSTED $specs
  # The same comparisons with every plan on doubles compiled to machine code
  # at its first use (M and h, the constraint rows, q'' for a constant M),
  # and the series of Taylor's method too.
  suite "Graphs compiled to machine code (NZLUA_NATIVE=1)" env LUA_CPATH="build/?.so;;" NZLUA=build/nzlua \
    NZLUA_NATIVE=1 lua5.4 $BUSTED tests/graph_diff_spec.lua tests/record_spec.lua \
    tests/branch_spec.lua tests/fidelity_spec.lua tests/constraint_checks_spec.lua tests/taylor_spec.lua tests/simulate_taylor_spec.lua \
    tests/taylor_constrained_spec.lua
fi
if [ "$mode" = sanitize ] || [ "$mode" = all ]; then
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=0:halt_on_error=1
  export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
  suite "C core under ASan+UBSan" build/asan/test_series
  suite "Expression graphs under ASan+UBSan" build/asan/test_graph
  suite "Compiled graphs under ASan+UBSan" build/asan/test_native
  suite "The integrator interface under ASan+UBSan" build/asan/test_stepper
  suite "Contacts under ASan+UBSan" build/asan/test_contact
  # The long physics runs (#slow) are checked by the plain build; here the
  # point is memory safety and undefined behaviour on every code path.
  suite "Lua specs inside build/asan/nzlua" env NZLUA=build/asan/nzlua \
    build/asan/nzlua $BUSTED --exclude-tags=slow $specs
  suite "LeakSanitizer: a million jet operations" \
    script_test "memory loop under LeakSanitizer exits 0" build/asan/nzlua tests/data/memory_loop.lua
fi
rm -rf "$log"
echo
[ "$skipped" -gt 0 ] && echo "$skipped skipped (their reasons are on their '# SKIP' lines above)"
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
