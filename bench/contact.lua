-- contact.lua - what contacts cost (issues 26, 35): a ball bouncing to rest,
-- a block on a belt through 100 stick-slip cycles, a table on four legs
-- dropped flat to rest (dependent contacts: four rows on three coordinates,
-- their forces shared by least norm) and a puck sliding along (1, 1) to a
-- stop (an isotropic cone), each run with rk8pd and with taylor to its
-- closed form's events, against the time the closed form
-- itself takes to give them (evaluated in Lua, as nzlua's own Lua loop
-- would: the floor of what any code pays to write the answers down), and
-- against the same motion without its contacts (the run's cost without the
-- events).  Per event: the run's time over its events.  Each time is the
-- least of 7 runs (processor time, os.clock): the machine's noise only adds.
local nz = rawget(_G, "nz") or require "nz"
local g = 9.81

local function best(f, reps)
  local t = math.huge
  local out
  for _ = 1, reps or 7 do
    local c0 = os.clock()
    out = table.pack(f())
    t = math.min(t, os.clock() - c0)
  end
  return t, table.unpack(out, 1, out.n)
end

-- The ball: dropped from h with restitution e; bounces at t1 (1 + 2e (1 -
-- e^(k-1))/(1 - e)) until Zeno makes the last one plastic.
local h, e = 1.0, 0.8
local ball = nz.system{ name = "ball", coords = { "y" },
  T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end, V = function(t, q) return g * q[1] end,
  constraints = { nz.unilateral(function(t, q) return q[1] end, { e = e, name = "floor" }) } }
local free_ball = nz.system{ name = "free ball", coords = { "y" },
  T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end, V = function(t, q) return g * q[1] end }
local function ball_closed(n)
  local t1, times, heights = math.sqrt(2 * h / g), {}, {}
  for k = 1, n do
    times[k] = t1 * (1 + 2 * e * (1 - e ^ (k - 1)) / (1 - e))
    heights[k] = h * e ^ (2 * k)
  end
  return times, heights
end

-- The belt: a block (mass m, spring k to a wall) on a belt at speed V, mu_s
-- > mu: sticks until k x = mu_s m g, slips for (2 pi - 2 delta)/w, sticks
-- again for 2 A / V (A = (mu_s - mu) m g / k, tan delta = w A / V).
local m, kk, V, mu, mus = 1.2, 30.0, 0.4, 0.25, 0.45
local belt = nz.system{ name = "belt", coords = { "x", "y" },
  T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2) end,
  V = function(t, q) return 0.5 * kk * q[1] ^ 2 + m * g * q[2] end,
  constraints = { nz.unilateral(function(t, q) return q[2] end,
    { name = "belt", mu = mu, mu_s = mus, slip = function(t, q, qd) return qd[1] - V end }) } }
local free_belt = nz.system{ name = "free belt", coords = { "x", "y" },
  T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2) end, V = function(t, q) return 0.5 * kk * q[1] ^ 2 end }
local w = math.sqrt(kk / m)
local xb, A = mus * m * g / kk, (mus - mu) * m * g / kk
local slip, stick = (2 * math.pi - 2 * math.atan(w * A, V)) / w, 2 * A / V
local cycles = 100
local function belt_closed(n)
  local slips, sticks = {}, {}
  for c = 1, n do
    slips[c] = xb / V + (c - 1) * (slip + stick)
    sticks[c] = slips[c] + slip
  end
  return slips, sticks
end

print("Contacts: runs to the closed form's events (issues 26, 35); each time the least of 7 runs")
print(("%-50s %-7s %7s %11s %10s %12s %11s %11s"):format("problem", "method", "events", "nzlua", "per event",
  "no contacts", "closed form", "max |dt|"))
for _, method in ipairs{ "rk8pd", "taylor" } do
  local t_run, tr = best(function() return ball:simulate{ q0 = { h }, t1 = 5, dt = 0.01, method = method, progress = false } end)
  local t_free = best(function() return free_ball:simulate{ q0 = { h }, t1 = 5, dt = 0.01, method = method, progress = false } end)
  local n = #tr.events
  local t_closed, times = best(function() return ball_closed(n) end, 101)
  local worst = 0
  for k = 1, n - 1 do worst = math.max(worst, math.abs(tr.events[k].t - times[k])) end
  print(("%-50s %-7s %7d %8.3f ms %7.1f us %9.3f ms %8.1f us %11.2g"):format(
    ("ball e = %g from %g m to rest (Zeno at %.4f s)"):format(e, h, tr.contacts.zeno[1].t), method, n, 1e3 * t_run,
    1e6 * t_run / n, 1e3 * t_free, 1e6 * t_closed, worst))
end
for _, method in ipairs{ "rk8pd", "taylor" } do
  local t1 = xb / V + cycles * (slip + stick)
  local t_run, tr = best(function() return belt:simulate{ q0 = { 0, 0 }, qd0 = { V, 0 }, t1 = t1, dt = 0.05,
    method = method, progress = false } end)
  local t_free = best(function() return free_belt:simulate{ q0 = { 0, 0 }, qd0 = { V, 0 }, t1 = t1, dt = 0.05,
    method = method, progress = false } end)
  local t_closed, slips, sticks = best(function() return belt_closed(cycles) end, 101)
  local s, k, worst = 0, 0, 0
  for _, ev in ipairs(tr.events) do
    if ev.kind == "slips" then s = s + 1; worst = math.max(worst, math.abs(ev.t - slips[s])) end
    if ev.kind == "sticks" and ev.t > 0 then k = k + 1; worst = math.max(worst, math.abs(ev.t - sticks[k])) end
  end
  assert(s == cycles and k == cycles, ("%d slips and %d sticks"):format(s, k))
  print(("%-50s %-7s %7d %8.3f ms %7.1f us %9.3f ms %8.1f us %11.2g"):format(
    ("block on a belt, %d stick-slip cycles"):format(cycles), method, #tr.events, 1e3 * t_run,
    1e6 * t_run / #tr.events, 1e3 * t_free, 1e6 * t_closed, worst))
end

-- The table: dropped flat from H with restitution e, it bounces flat at the
-- ball's times (each bounce four impulses) until Zeno; legs at x_i below the
-- top at depth d.
local mt, It, d, H, et = 3.0, 0.8, 0.4, 0.5, 0.5
local legs = {}
for i, xi in ipairs{ -0.6, -0.2, 0.2, 0.6 } do
  legs[i] = nz.unilateral(function(t, q) return q[2] + xi * nz.sin(q[3]) - d * nz.cos(q[3]) end, { name = "leg" .. i, e = et })
end
local tbl = nz.system{ name = "table", coords = { "x", "y", "th" },
  T = function(t, q, qd) return 0.5 * mt * (qd[1] ^ 2 + qd[2] ^ 2) + 0.5 * It * qd[3] ^ 2 end,
  V = function(t, q) return mt * g * q[2] end, constraints = legs }
local free_tbl = nz.system{ name = "free table", coords = { "x", "y", "th" },
  T = function(t, q, qd) return 0.5 * mt * (qd[1] ^ 2 + qd[2] ^ 2) + 0.5 * It * qd[3] ^ 2 end,
  V = function(t, q) return mt * g * q[2] end }
local function table_closed(n)
  local t1, times = math.sqrt(2 * H / g), {}
  for k = 1, n do times[k] = t1 * (1 + 2 * et * (1 - et ^ (k - 1)) / (1 - et)) end
  return times
end
for _, method in ipairs{ "rk8pd", "taylor" } do
  local t_run, tr = best(function() return tbl:simulate{ q0 = { 0, d + H, 0 }, t1 = 2, dt = 0.01, method = method,
    progress = false } end)
  local t_free = best(function() return free_tbl:simulate{ q0 = { 0, d + H, 0 }, t1 = 2, dt = 0.01, method = method,
    progress = false } end)
  local n = tr.contacts.impacts
  local t_closed, times = best(function() return table_closed(n) end, 101)
  local worst, k, last = 0, 0, nil
  for _, ev in ipairs(tr.events) do
    if ev.kind == "impact" and ev.t ~= last then
      k, last = k + 1, ev.t
      -- (the first 10: later the bounces rise less than 1e-8 m, and a rounding of the gap, 1e-15 m, over
      -- their speed is already 1e-10 s)
      if k <= 10 then worst = math.max(worst, math.abs(ev.t - times[k])) end
    end
  end
  print(("%-50s %-7s %7d %8.3f ms %7.1f us %9.3f ms %8.1f us %11.2g"):format(
    ("table on four legs, e = %g, to rest (%d impacts)"):format(et, n), method, #tr.events, 1e3 * t_run,
    1e6 * t_run / #tr.events, 1e3 * t_free, 1e6 * t_closed, worst))
end

-- The puck: sent along (1, 1) at v0, it stops at v0/(mu g) after v0^2/(2 mu g).
local mp, mup, v0 = 0.17, 0.3, 2.0
local puck = nz.system{ name = "puck", coords = { "x", "y", "z" },
  T = function(t, q, qd) return 0.5 * mp * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end,
  V = function(t, q) return mp * g * q[3] end,
  constraints = { nz.unilateral(function(t, q) return q[3] end, { name = "ice", mu = mup,
    slip = { function(t, q, qd) return qd[1] end, function(t, q, qd) return qd[2] end } }) } }
local free_puck = nz.system{ name = "free puck", coords = { "x", "y", "z" },
  T = function(t, q, qd) return 0.5 * mp * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end }
for _, method in ipairs{ "rk8pd", "taylor" } do
  local c = v0 / math.sqrt(2)
  local t_run, tr = best(function() return puck:simulate{ q0 = { 0, 0, 0 }, qd0 = { c, c, 0 }, t1 = 1.2, dt = 0.01,
    method = method, progress = false } end)
  local t_free = best(function() return free_puck:simulate{ q0 = { 0, 0, 0 }, qd0 = { c, c, 0 }, t1 = 1.2, dt = 0.01,
    method = method, progress = false } end)
  local t_closed, ts = best(function() return v0 / (mup * g) end, 101)
  local stop = tr.events[#tr.events]
  print(("%-50s %-7s %7d %8.3f ms %7.1f us %9.3f ms %8.1f us %11.2g"):format(
    "puck along (1, 1) on ice to a stop (isotropic cone)", method, #tr.events, 1e3 * t_run, 1e6 * t_run / #tr.events,
    1e3 * t_free, 1e6 * t_closed, math.abs(stop.t - ts)))
end
print("per event: the run's time over its events (impulses, sticks, slips); no contacts: the same system and")
print("span without its contacts (a free fall; a block on its spring alone; the table falling; the puck gliding);")
print("closed form: its event times in Lua")

-- What the isotropic cone costs at a transition: one impact of a point on a
-- plane (e = 0.6, mu = 0.2), its LCP with 4 unknowns for a planar contact
-- and 10 for an isotropic one (an 8-generator pyramid), Newton's method on
-- the slip's angle where it slides through off a generator.  Each the least
-- of 5 means over 2000 transitions (core.mech.contacts_transition).
local mech = require("nz.core").mech
local function transition_cost(iso, mu, qd)
  local slip = iso and { function(t, q, v) return v[1] end, function(t, q, v) return v[2] end }
    or function(t, q, v) return v[1] end
  local s = nz.system{ name = "point", coords = { "x", "y", "z" },
    T = function(t, q, v) return 0.15 * (v[1] ^ 2 + v[2] ^ 2 + v[3] ^ 2) end, V = function(t, q) return 0.3 * g * q[3] end,
    constraints = { nz.unilateral(function(t, q) return q[3] end, { name = "p", e = 0.6, mu = mu, slip = mu > 0 and slip or nil }) } }
  local c, csys = s.contact, s.contact.system
  local orders = require("nz.model.constraints").orders(csys, { t = 0, q = { 0, 0, 0 }, qd = { 1, 1, 1 } })
  csys.engine.orders = orders
  local sp = c.contacts[1]
  local cs = mech.contacts_new(csys.engine, { nb = 0, orders = orders, names = c.names, contacts = { { gap = sp.gap,
    slip = sp.slip, slip2 = sp.slip2, speed = sp.speed, e = sp.e, mu = sp.mu, mu_s = sp.mu_s } } })
  local n = 2000
  return best(function()
    for _ = 1, n do
      mech.contacts_set_mode(cs, { "open" })
      mech.contacts_transition(cs, csys.engine, 0.1, { 0, 0, 0 }, qd, 1)
    end
  end, 5) / n
end
print()
print("One impact's transition (the LCP, and Newton for the isotropic cone off a generator)")
for _, row in ipairs{ { "frictionless", false, 0, { 1, 0, -3.13 } }, { "planar friction, sliding through", false, 0.2, { 1, 0, -3.13 } },
  { "isotropic cone, sliding through along x (a generator)", true, 0.2, { 1, 0, -3.13 } },
  { "isotropic cone, sliding through along (1, 2) (Newton)", true, 0.2, { 1, 2, -3.13 } },
  { "isotropic cone, sticking", true, 0.2, { 0.3, 0.4, -3.13 } } } do
  print(("  %-56s %6.1f us"):format(row[1], 1e6 * transition_cost(row[2], row[3], row[4])))
end
