-- accel_check.lua - what the check after every constrained solve costs
-- (constrained.c): the time of one solve with and without it (sleigh,
-- rolling disk, Hamel's particle, Andrews' squeezer), and of a whole
-- simulate run (t1 = 10, rk8pd; the squeezer's 0.03 s), whose right-hand
-- sides are those solves.  Prints a table.
package.path = "./?.lua;" .. package.path
local nz = rawget(_G, "nz") or require "nz"
local cs = require "tests.constraint_systems"
local mech = require("nz.core").mech
local constraints = require "nz.model.constraints"
local clock = os.clock
local N = tonumber(arg and arg[1]) or 5000

-- The least time of five runs of each of f(true) and f(false), taken in
-- turn (after a warm-up, with a full collection before each): the other
-- processes and the collector only ever add time.
local function best_of(f)
  local best = { [true] = math.huge, [false] = math.huge }
  f(true); f(false)
  for _ = 1, 5 do
    for _, check in ipairs{ true, false } do
      collectgarbage()
      local t0 = clock()
      f(check)
      best[check] = math.min(best[check], clock() - t0)
    end
  end
  return best
end

print("The check after every constrained solve: time with / without it")
print(("%-14s %10s %10s %6s  %10s %10s %6s"):format("system", "solve on", "off", "ratio", "simulate on", "off", "ratio"))
local ode_new = mech.ode_new
-- Andrews' squeezer (examples/squeezer.lua) from the Test Set's start.
cs.squeezer = function()
  local env = setmetatable({ nz = nz }, { __index = _G })
  local model = assert(loadfile("examples/squeezer.lua", "t", env))("module")
  return { sys = model.system, span = 0.03, draw = function() return 0, model.start.q, model.start.qd end }
end
for _, name in ipairs{ "sleigh", "rolling_disk", "hamel", "squeezer" } do
  local case = cs[name]()
  local sys = case.sys
  local t, q, qd = case.draw()
  local orders, linear = constraints.orders(sys)
  local solve = best_of(function(check)
    local opts = { check = check }
    for _ = 1, N do mech.accel_constrained(sys.engine, t, q, qd, orders, linear, opts) end
  end)
  local run = best_of(function(check)
    mech.ode_new = function(e, o) o.check = check; return ode_new(e, o) end
    sys:simulate{ t0 = t, q0 = q, qd0 = qd, t1 = t + (case.span or 10) }
    mech.ode_new = ode_new
  end)
  for _, check in ipairs{ true, false } do solve[check] = solve[check] / N end
  print(("%-14s %8.2fus %8.2fus %6.3f  %9.3fs %9.3fs %6.3f"):format(name, 1e6 * solve[true], 1e6 * solve[false],
    solve[true] / solve[false], run[true], run[false], run[true] / run[false]))
end
