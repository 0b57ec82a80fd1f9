#!/bin/sh
# run.sh - every benchmark, each printing its table (make bench).
cd "$(dirname "$0")/.." || exit 1
build/bench_jet
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
build/nzlua bench/loop_cost.lua
