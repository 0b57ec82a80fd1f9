-- loop_cost.lua - what the stepping loop itself costs per step: the same run
-- of a harmonic oscillator through sys:simulate (the one stepping loop, in
-- C: src/ode/ode_run.c) and through a loop written here in Lua over the
-- same integrator (core.mech.ode_step, one call from Lua per step, the
-- output grid kept in Lua).  Both take the same steps (tests/
-- simulate_loop_spec.lua checks it to the bit against the same kind of
-- loop), so the difference of the times per step is what the loop costs
-- against the bare integrator stepped from Lua.  The output grid is coarse
-- (dt = t1 / 10) so that the steps, not the output points, cost; the last
-- row records a point after every step (q'' solved there: one more
-- right-hand side, and the hand-over of the point to Lua).
-- Each figure: the least of 9 runs of the processor time (os.clock: other
-- processes on the machine count less than in wall time) / accepted steps.
local nz = rawget(_G, "nz") or require "nz"
local mech = require("nz.core").mech

local osc = nz.system{ name = "oscillator", coords = { "x" },
  T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
  V = function(t, q) return 0.5 * q[1] ^ 2 end }

-- The loop in Lua: to each output time, adaptive or fixed steps landing on
-- it, q'' at each point (what sys:simulate keeps, in plain tables).
local function lua_loop(o)
  local engine = osc.engine
  local ode = mech.ode_new(engine, { method = o.method, rtol = o.rtol or 1e-10, atol = o.atol or 1e-12,
    h0 = math.min(o.dt, 1e-3), orders = {}, linear = {} })
  local t, h, y = 0, math.min(o.dt, 1e-3), { 1, 0 }
  local ts, ys = { 0 }, { { 1, 0, mech.ode_accel(ode, engine, 0, y)[1] } }
  local nout = math.ceil(o.t1 / o.dt - 1e-9)
  for i = 1, nout do
    local tout = i == nout and o.t1 or i * o.dt
    local nfixed = o.step and math.max(1, math.ceil((tout - t) / o.step - 1e-9))
    local hfixed = o.step and (tout - t) / nfixed
    while t < tout do
      if o.step then
        nfixed = nfixed - 1
        t, y = mech.ode_step_fixed(ode, engine, t, hfixed, y)
        if nfixed == 0 then t = tout end
      else
        t, h, y = mech.ode_step(ode, engine, t, tout, h, y)
      end
    end
    ts[#ts + 1], ys[#ys + 1] = t, { y[1], y[2], mech.ode_accel(ode, engine, t, y)[1] }
  end
  return mech.ode_stats(ode).steps
end

-- Seconds per step through each (the least of 9 runs each, the two
-- alternating so that the load of the machine falls on both alike) and the
-- run's statistics.
local function per_step(opts)
  local best, stats = { lua = math.huge, c = math.huge }, nil
  for _ = 1, 9 do
    collectgarbage()
    local c0 = os.clock()
    local steps = lua_loop(opts)
    best.lua = math.min(best.lua, (os.clock() - c0) / steps)
    local o = { q0 = { 1 }, qd0 = { 0 }, progress = false, dense = false }
    for k, v in pairs(opts) do o[k] = v end
    collectgarbage()
    c0 = os.clock()
    local tr = osc:simulate(o)
    best.c = math.min(best.c, (os.clock() - c0) / tr.stats.steps)
    assert(tr.stats.steps == steps, "the two loops took different steps")
    stats = tr.stats
  end
  return best.lua, best.c, stats
end

local cases = {
  { "rk8pd, rtol = atol = 1e-12", { method = "rk8pd", rtol = 1e-12, atol = 1e-12, t1 = 300, dt = 30 } },
  { "rk2, fixed step 0.01", { method = "rk2", step = 0.01, t1 = 20, dt = 2 } },
  { "rk2, step 0.01, output each", { method = "rk2", step = 0.01, t1 = 20, dt = 0.01 } },
}

print("The stepping loop's cost per step (harmonic oscillator; T and V recorded, evaluated in C)")
print(("%-28s %7s %7s %12s %12s %14s %7s %10s"):format("method", "steps", "rhs/st", "Lua loop", "simulate",
  "Lua loop adds", "ratio", "per rhs"))
for _, c in ipairs(cases) do
  local lua_t, c_t, st = per_step(c[2])
  print(("%-28s %7d %7.1f %9.2f us %9.2f us %11.2f us %6.3fx %7.2f us"):format(c[1], st.steps, st.nfev / st.steps,
    lua_t * 1e6, c_t * 1e6, (lua_t - c_t) * 1e6, lua_t / c_t, c_t / (st.nfev / st.steps) * 1e6))
end
print("(Lua loop: a loop written in Lua over the same integrator, one ode_step call per step; simulate: the loop")
print(" in C; per rhs: simulate's time per step / evaluations per step, nearly all of it the Lua evaluation of T and V)")
