-- loop_events.lua - what events and projection cost in the stepping loop
-- (src/ode/ode_run.c):
--   1. a pendulum with a recorded event (th = 0 either way), rk4 at a fixed
--      step of 1e-3 over 10 s: 1e4 steps, an event every ~1 s;
--   2. the same event written with a Lua branch, so that it cannot be
--      recorded and the loop calls it in Lua after every step;
--   3. the same run without the event (what the event itself adds);
--   4. a pendulum in Cartesian coordinates with project = true, rk8pd at
--      rtol = 1e-6 and at the default 1e-10 over 200 s (the violation
--      watched after every step), and the same without projection.
-- Each figure: the least of 5 runs of the processor time (os.clock), and
-- the returns of the loop to Lua (events, projections, full output
-- buffers, pauses), counted by wrapping mech.ode_run.
-- Run: env LUA_CPATH="build/?.so;;" lua5.4 bench/loop_events.lua
local nz = rawget(_G, "nz") or require "nz"
local mech = require("nz.core").mech

local g = 9.81
local pendulum = nz.system{ name = "pendulum", coords = { "th" },
  T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
  V = function(t, q) return -g * nz.cos(q[1]) end }
local l, m = 1.3, 0.8
local cartesian = nz.system{ name = "cartesian pendulum", coords = { "x", "y" },
  T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2) end,
  V = function(t, q) return m * g * q[2] end,
  constraints = { function(t, q) return q[1] ^ 2 + q[2] ^ 2 - l * l end } }

local returns = 0
local ode_run = mech.ode_run
mech.ode_run = function(...) returns = returns + 1; return ode_run(...) end

local function measure(sys, opts)
  local best, info = math.huge, nil
  for _ = 1, 5 do
    local o = { progress = false }
    for k, v in pairs(opts) do o[k] = v end
    collectgarbage()
    returns = 0
    local c0 = os.clock()
    local tr = sys:simulate(o)
    best = math.min(best, os.clock() - c0)
    info = { steps = tr.stats.steps, events = #tr.events, projections = tr.projections, returns = returns }
  end
  return best, info
end

local th0 = 1.0
local cases = {
  { "pendulum, 1 recorded event, rk4 step 1e-3, 1e4 steps", pendulum,
    { q0 = { th0 }, t1 = 10, step = 1e-3, method = "rk4", events = { function(t, q) return q[1] end } } },
  { "the same event called in Lua (a Lua branch)", pendulum,
    { q0 = { th0 }, t1 = 10, step = 1e-3, method = "rk4",
      events = { function(t, q) if q[1] > 10 then return 1 end return q[1] end } } },
  { "the same without the event", pendulum, { q0 = { th0 }, t1 = 10, step = 1e-3, method = "rk4" } },
  { "Cartesian pendulum, project = true, rk8pd 1e-6, 200 s", cartesian,
    { q0 = { l * math.sin(1), -l * math.cos(1) }, qd0 = { 0, 0 }, t1 = 200, rtol = 1e-6, atol = 1e-8, project = true } },
  { "the same without projection", cartesian,
    { q0 = { l * math.sin(1), -l * math.cos(1) }, qd0 = { 0, 0 }, t1 = 200, rtol = 1e-6, atol = 1e-8 } },
  { "Cartesian pendulum, project = true, rk8pd 1e-10, 200 s", cartesian,
    { q0 = { l * math.sin(1), -l * math.cos(1) }, qd0 = { 0, 0 }, t1 = 200, project = true } },
  { "the same without projection", cartesian,
    { q0 = { l * math.sin(1), -l * math.cos(1) }, qd0 = { 0, 0 }, t1 = 200 } },
}
print(("%-52s %9s %7s %7s %6s %8s"):format("run", "time", "steps", "events", "proj", "returns"))
for _, c in ipairs(cases) do
  local best, info = measure(c[2], c[3])
  print(("%-52s %7.1fms %7d %7d %6s %8d"):format(c[1], 1e3 * best, info.steps, info.events,
    tostring(info.projections or "-"), info.returns))
end
