-- sweep_pendulum.lua - a sweep's file for tests/sweep_spec.lua: the simple
-- pendulum and its period (between two upward zero crossings) as the run;
-- amp = pi fails on purpose (no crossing: the pendulum stays up).
local nz = rawget(_G, "nz") or require "nz"     -- nzlua's global, or nz.so from lua5.4
local sys = nz.system{
  name = "pendulum", coords = { "th" }, params = { l = 1.0, g = 9.81 },
  T = function(t, q, qd, p) return 0.5 * p.l^2 * qd[1]^2 end,
  V = function(t, q, p) return -p.g * p.l * nz.cos(q[1]) end,
}

local function run(s, point)
  local tr = s:simulate{ q0 = { point.amp }, qd0 = { 0 }, t1 = 9, dt = 1, rtol = 1e-12, atol = 1e-14,
    events = { { name = "up", f = function(t, q) return q[1] end, direction = 1 } } }
  local ev = tr.events
  if #ev < 2 then error(("no period: %d upward crossings"):format(#ev)) end
  return { period = ev[2].t - ev[1].t, crossings = #ev }
end

return { system = sys, run = run }
