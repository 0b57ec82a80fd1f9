-- loop_cost.lua - what the stepping loop itself costs per step: the same run
-- of a harmonic oscillator through the loop in Lua (lua/nz/motion/simulate.lua,
-- one return to Lua per step) and through the loop in C (src/ode/ode_run.c),
-- forced by the internal option _loop.  Both take the same steps (tests/
-- simulate_loop_spec.lua checks it to the bit), so the difference of the
-- times per step is what the Lua loop adds to every step.  The output grid
-- is coarse (dt = t1 / 10) so that the steps, not the output points, cost;
-- the last row records a point after every step (q'' solved there: one
-- more right-hand side, and the hand-over of the point to Lua).
-- Each figure: the least of 9 runs of the processor time (os.clock: other
-- processes on the machine count less than in wall time) / accepted steps.
local nz = rawget(_G, "nz") or require "nz"
local mech = require("nz.core").mech

local osc = nz.system{ name = "oscillator", coords = { "x" },
  T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
  V = function(t, q) return 0.5 * q[1] ^ 2 end }

-- Seconds per step through each loop (the least of 9 runs each, the two
-- loops alternating so that the load of the machine falls on both alike)
-- and the run's statistics.
local function per_step(opts)
  local best, stats = { lua = math.huge, c = math.huge }, nil
  for _ = 1, 9 do
    for _, loop in ipairs{ "lua", "c" } do
      local o = { q0 = { 1 }, qd0 = { 0 }, progress = false, _loop = loop }
      for k, v in pairs(opts) do o[k] = v end
      collectgarbage()
      local c0 = os.clock()
      local tr = osc:simulate(o)
      best[loop] = math.min(best[loop], (os.clock() - c0) / tr.stats.steps)
      assert(tr.stats.loop == loop, "the run did not take the loop asked for")
      stats = tr.stats
    end
  end
  return best.lua, best.c, stats
end

local cases = {
  { "rk8pd, rtol = atol = 1e-12", { method = "rk8pd", rtol = 1e-12, atol = 1e-12, t1 = 300, dt = 30 } },
  { "rk2, fixed step 0.01", { method = "rk2", step = 0.01, t1 = 20, dt = 2 } },
  { "rk2, step 0.01, output each", { method = "rk2", step = 0.01, t1 = 20, dt = 0.01 } },
}

print("The stepping loop's cost per step (harmonic oscillator from Lua; T and V evaluated in Lua)")
print(("%-28s %7s %7s %12s %12s %14s %7s %10s"):format("method", "steps", "rhs/st", "Lua loop", "C loop",
  "Lua loop adds", "ratio", "per rhs"))
for _, c in ipairs(cases) do
  local lua_t, c_t, st = per_step(c[2])
  print(("%-28s %7d %7.1f %9.2f us %9.2f us %11.2f us %6.3fx %7.2f us"):format(c[1], st.steps, st.nfev / st.steps,
    lua_t * 1e6, c_t * 1e6, (lua_t - c_t) * 1e6, lua_t / c_t, c_t / (st.nfev / st.steps) * 1e6))
end
print("(per rhs: the C loop's time per step / evaluations per step, nearly all of it the Lua evaluation of T and V;")
print(" in the last row the accelerations at each output point are not counted in rhs/st;")
print(" the Lua loop's own cost is the difference, which stays when the right-hand side moves to C)")
