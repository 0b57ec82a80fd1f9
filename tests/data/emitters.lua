-- emitters.lua - real systems whose numbers tests/emitters_spec.lua compares
-- across the evaluators: run by nzlua under NZLUA_NATIVE=0 (the interpreter),
-- and under NZLUA_NATIVE=1 with NZLUA_COMPACT=0 (straight-line machine code)
-- or 1 (compact machine code).  Prints one line per figure, every number
-- with %a (all its bits), then a line per system with the machine code it
-- ran (plans and series), so that the spec knows machine code was used.
local nz = rawget(_G, "nz") or require "nz"
local fmt = function(v) local s = {} for i, x in ipairs(v) do s[i] = ("%a"):format(x) end return table.concat(s, " ") end

-- A chain of point masses from bodies (bench/chain.lua: masses 1 + 0.1 i,
-- links 0.5): M and h not constant.
local chain = require "bench.chain"

-- Henon-Heiles: a constant M (q'' as one plan, the fused series loop).
local henon = nz.system{ name = "Henon-Heiles", coords = { "x", "y" },
  T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end,
  V = function(t, q) return 0.5 * (q[1] ^ 2 + q[2] ^ 2) + q[1] ^ 2 * q[2] - q[2] ^ 3 / 3 end }

-- The Chaplygin sleigh: a nonholonomic constraint (its rows as plans).
local sleigh = require("tests.constraint_systems").sleigh().sys

local function run(sys, q0, qd0, t1, methods)
  for _, method in ipairs(methods) do
    local tr = sys:simulate{ q0 = q0, qd0 = qd0, t1 = t1, dt = t1, method = method, rtol = 1e-11, atol = 1e-11 }
    local n = #tr.t
    print(sys.name, method, fmt{ tr.t[n] }, fmt(tr.q[n]), fmt(tr.qd[n]), tr.stats.steps)
  end
end

local systems = {}
local c6 = chain(6)
local q, qd = {}, {}
for i = 1, 6 do q[i], qd[i] = 0.7 * math.sin(1.3 * i + 0.5), 0.9 * math.cos(0.7 * i + 0.2) end
print(c6.name, "accel", fmt(c6:accel(0, q, qd)))
run(c6, q, qd, 0.5, { "rk8pd", "taylor" })
systems[#systems + 1] = c6

print(henon.name, "accel", fmt(henon:accel(0, { 0.1, -0.2 }, { 0.3, 0.25 })))
run(henon, { 0.1, -0.2 }, { 0.3, 0.25 }, 20, { "rk8pd", "taylor" })
systems[#systems + 1] = henon

local th, u, w = 0.7, 1.3, -0.8
local sq, sqd = { 0.2, -0.1, th }, { u * math.cos(th), u * math.sin(th), w }
print(sleigh.name, "accel", fmt(sleigh:accel(0, sq, sqd)))
run(sleigh, sq, sqd, 2, { "rk8pd", "taylor" })
systems[#systems + 1] = sleigh

local env = setmetatable({ nz = nz }, { __index = _G })
local bike = assert(loadfile("examples/bicycle.lua", "t", env))("module")
local bq, bqd = bike.state(0.05, -0.02, 0.1, 0.05, -5 / bike.params.rR)
print(bike.system.name, "accel", fmt(bike.system:accel(0, bq, bqd)))
systems[#systems + 1] = bike.system

for _, sys in ipairs(systems) do
  local g = sys:graph_info()
  print(sys.name, "machine code", g.native_plans, g.native_series, tostring(g.native_why))
end
