#!/bin/bash
# cc_cpu.sh - the C compiler nzlua runs, timed (bench/scale.lua sets
# CC=bench/cc_cpu.sh): runs ${NZ_BENCH_CC:-cc} with nzlua's arguments and
# appends one line per compile to $NZ_BENCH_CC_LOG: its processor seconds
# (user, system: bash's time, which counts the compiler's own children)
# and the first line of the source, which names the generator and the
# emitter ("nzlua-native ... compact code").  `--version` (nzlua asks it
# once, for the compiler's identity) is passed through unlogged.
src=
for a in "$@"; do
  case $a in *.c) src=$a ;; esac
done
exec 3>&1 4>&2
TIMEFORMAT='%3U %3S'
t=$( { time ${NZ_BENCH_CC:-cc} "$@" 1>&3 2>&4; } 2>&1 )
rc=$?
if [ -n "$NZ_BENCH_CC_LOG" ] && [ -n "$src" ]; then
  printf '%s %s\n' "$t" "$(head -n 1 "$src")" >> "$NZ_BENCH_CC_LOG"
fi
exit $rc
