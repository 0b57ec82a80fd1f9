#!/bin/sh
# run.sh - every benchmark, each printing its table (make bench).
cd "$(dirname "$0")/.." || exit 1
build/bench_jet
echo
build/bench_motion
echo
build/nzlua bench/jet_lua.lua
echo
build/nzlua bench/mech.lua
echo
build/nzlua bench/workprecision.lua
echo
build/nzlua bench/scene_cost.lua
echo
build/nzlua bench/accel_check.lua
echo
# nzlua against hand-written C, measured in the same run.
build/nzlua bench/henon.lua
echo
# Taylor's method against the same C program.
build/nzlua bench/taylor.lua
echo
build/nzlua bench/taylor_problems.lua
echo
# Long runs at machine precision (Brouwer's law), variational integrators.
build/nzlua bench/longrun.lua
echo
build/nzlua bench/accel_scaling.lua
echo
build/nzlua bench/bicycle.lua
echo
start=$(date +%s.%N)
build/nzlua bench/pendulum18.lua
end=$(date +%s.%N)
awk -v a="$start" -v b="$end" 'BEGIN { printf "wall time of the whole script from the shell (interpreter start, probe and C baseline included): %.3f s\n", b - a }'
echo
build/nzlua bench/loop_cost.lua
echo
build/nzlua bench/loop_events.lua
echo
# The exported C against hand-written C and nzlua.
build/nzlua bench/export.lua
echo
# nz.sweep on 1, 2 and every core, and its overhead per point.
build/nzlua bench/sweep.lua
echo
# Contacts, impacts and friction against their closed forms.
build/nzlua bench/contact.lua
echo
# Issue 34: research-size systems, n = 4..64 (BENCH_SCALE_MAX=128 adds the
# largest: minutes more), compile and speed of both emitters of machine code.
build/nzlua bench/scale.lua
