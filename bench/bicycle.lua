-- bicycle.lua - the Whipple bicycle (examples/bicycle.lua, Meijaard et al.
-- 2007): what recording, differentiation and a constrained acceleration
-- cost, against the targets of issue 10 (recording and differentiation
-- under 0.2 s, constrained accel under 50 us).  Prints a table (make bench).
local root = (arg and arg[0] or ""):match("^(.-)bench/[^/]*$") or ""
package.path = root .. "?.lua;" .. package.path
local nz = rawget(_G, "nz") or require "nz"
local timing = require "bench.timing"

local clock = os.clock
local t0 = clock()
local model = loadfile(root .. "examples/bicycle.lua")("module")
local made = clock() - t0
local bicycle, state, p = model.system, model.state, model.params
local q, qd = state(0.05, 0.02, 0.1, -0.1, -5 / p.rR)

t0 = clock()
bicycle:accel(0, q, qd)                 -- the first one differentiates (M, h, the rows)
local first = clock() - t0
local gi = bicycle:graph_info()

local interp = timing.per_call(function() bicycle:accel(0, q, qd) end, { budget = 1.0 })
bicycle.engine.recording:set_native(true)
t0 = clock()
bicycle:accel(0, q, qd)                 -- compiles the plans (or loads them from the cache)
local compile = clock() - t0
local native = timing.per_call(function() bicycle:accel(0, q, qd) end, { budget = 1.0 })
local gn = bicycle:graph_info()
local nocheck = timing.per_call(function() bicycle:accel(0, q, qd, { check = false }) end, { budget = 0.5 })

print("Whipple bicycle (8 coordinates, 1 holonomic + 4 rolling constraints): what it costs")
print("target (issue 10): recording and differentiation under 0.2 s, constrained accel under 50 us")
print(("%-58s %12s"):format("making the system (the example's definitions + recording)", timing.fmt(made, 12)))
print(("%-58s %12s"):format("  of which recording the functions", timing.fmt(gi.record_seconds, 12)))
print(("%-58s %12s"):format("first constrained accel (differentiates M, h and the rows)", timing.fmt(first, 12)))
print(("%-58s %12s"):format("constrained accel, graphs interpreted", timing.fmt(interp, 12)))
print(("%-58s %12s"):format(("compiling %d plans to machine code (0 s when cached)"):format(gn.native_plans), timing.fmt(compile, 12)))
print(("%-58s %12s"):format("constrained accel, native", timing.fmt(native, 12)))
print(("%-58s %12s"):format("constrained accel, native, without the check", timing.fmt(nocheck, 12)))
print(("graph: %d nodes recorded, %d in the mass-bias plan; %.2f ns/node per accel (interpreted, over the graph)")
  :format(gi.nodes, gn.mass_bias_nodes, 1e9 * interp / math.max(gn.nodes, 1)))
print("notes: CPU time (os.clock); accel is sys:accel from Lua, its argument checks included; the check")
print("  after the solve is on by default (NZ_ACCEL_CHECK_TOL)")
