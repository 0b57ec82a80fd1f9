-- contact_cone_spec.lua - the isotropic Coulomb cone, nz.unilateral(gap, {mu
-- =, slip = {f1, f2}}) (docs/theory.md §13), against closed forms under rk8pd
-- and taylor: a puck sent along (1, 1) slows on a straight line, both
-- components together, and stops at v0/(mu g) after v0^2/(2 mu g); a block
-- sent across a slope bends downhill and stops where the quadrature of its
-- sliding law puts it, on the path a fine fixed-step reference integrates (a
-- second path sharing no code); an oblique impact slides through along the
-- incoming slip, v_t+ = v_t (1 - mu (1 + e) v_n/|v_t|), or sticks; two
-- contacts on one gap are noticed; the option's errors.
local h = require "tests.helpers"
local nz = h.nz

local g = 9.81
local METHODS = { "rk8pd", "taylor" }

local max_abs = h.max_abs
local near = h.near
-- (here, not in tests/helpers.lua: an error names the first frame outside
-- the library, which must be this file's)
local function errmsg(f, ...)
  local ok, err = pcall(f, ...)
  assert(not ok, "an error was expected")
  return tostring(err)
end

local quad = h.gauss_legendre

-- A point mass (x, y, z) on the plane z = 0 with an isotropic cone.
local function slider(name, m, mu, mus, e, V)
  return nz.system{ name = name, coords = { "x", "y", "z" },
    T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end, V = V,
    constraints = { nz.unilateral(function(t, q) return q[3] end, { name = "plane", mu = mu, mu_s = mus, e = e,
      slip = { function(t, q, qd) return qd[1] end, function(t, q, qd) return qd[2] end } }) } }
end

describe("the isotropic cone", function()
  for _, method in ipairs(METHODS) do
    it(("a puck sent along (1, 1) stops at v0/(mu g) after v0^2/(2 mu g), both components slowing together (%s)"):format(
      method), function()
      local m, mu, v0 = 0.17, 0.3, 2.0
      local puck = slider("puck", m, mu, mu, 0, function(t, q) return m * g * q[3] end)
      local c = v0 / math.sqrt(2)
      local tr = puck:simulate{ q0 = { 0, 0, 0 }, qd0 = { c, c, 0 }, t1 = 1.2, dt = 0.01, method = method }
      local ts, d = v0 / (mu * g), v0 ^ 2 / (2 * mu * g)
      assert(#tr.events == 2 and tr.events[1].kind == "slips" and tr.events[1].to == "slip", "it slides from the start")
      local stop = tr.events[2]
      assert(stop.kind == "sticks", "then it sticks")
      near(stop.t, ts, 1e-12, "it stops at v0/(mu g)")
      near(stop.q[1], d / math.sqrt(2), 1e-12, "x at the stop")
      near(stop.q[2], d / math.sqrt(2), 1e-12, "y at the stop")
      for i, t in ipairs(tr.t) do
        local s = t < ts and (v0 * t - mu * g * t * t / 2) or d
        local v = t < ts and (v0 - mu * g * t) or 0
        near(tr.q[i][1], s / math.sqrt(2), 1e-11, ("x(%g)"):format(t))
        near(tr.q[i][2] - tr.q[i][1], 0, 1e-14, ("y = x at %g: a straight line"):format(t))
        near(tr.qd[i][1], v / math.sqrt(2), 1e-11, ("x'(%g)"):format(t))
        near(tr.qd[i][2], tr.qd[i][1], 1e-14, ("y' = x' at %g"):format(t))
        if t < ts - 1e-9 then
          -- the friction opposes the slip: (T1, T2) = -mu N (1, 1)/sqrt(2)
          near(tr:column("T1.plane")[i], -mu * m * g / math.sqrt(2), 1e-12, "T1")
          near(tr:column("T2.plane")[i], -mu * m * g / math.sqrt(2), 1e-12, "T2")
        end
      end
    end)

    it(("a block sent across a slope bends downhill and stops where the quadrature puts it (%s)"):format(method), function()
      -- on a slope of angle alpha (s up it, x across), the slip speed v at angle phi from downhill:
      -- dv/dt = a_g cos phi - a_f, v dphi/dt = -a_g sin phi (a_g = g sin alpha, a_f = mu g cos alpha), so
      -- v = v0 tan(phi/2)^k / sin phi (k = a_f/a_g > 1: it stops, phi -> 0), dt = -v dphi/(a_g sin phi),
      -- dx = v sin phi dt, ds = -v cos phi dt
      local m, mu, alpha, v0 = 0.4, 0.5, 0.3, 1.5
      local block = slider("block", m, mu, 0.6, 0, function(t, q) return m * g * (q[2] * math.sin(alpha) + q[3] * math.cos(alpha)) end)
      local tr = block:simulate{ q0 = { 0, 0, 0 }, qd0 = { v0, 0, 0 }, t1 = 0.8, dt = 0.01, method = method }
      local ag, af = g * math.sin(alpha), mu * g * math.cos(alpha)
      local k = af / ag
      local function v(phi) return v0 * math.tan(phi / 2) ^ k / math.sin(phi) end
      local p = 1 / (k - 1)   -- phi = u^p makes the integrands smooth at the stop (phi -> 0)
      local function I(f) return quad(function(u) local phi = u ^ p; return f(phi) * p * u ^ (p - 1) end, 0, (math.pi / 2) ^ (1 / p), 200) end
      local ts = I(function(phi) return v(phi) / (ag * math.sin(phi)) end)
      local xs = I(function(phi) return v(phi) ^ 2 / ag end)
      local ss = -I(function(phi) return v(phi) ^ 2 / ag * math.cos(phi) / math.sin(phi) end)
      local stop = tr.events[#tr.events]
      assert(stop.kind == "sticks" and tr.contacts.final[1] == "stick", "it stops and sticks (tan alpha < mu_s)")
      near(stop.t, ts, 1e-11, "the stop's time")
      near(stop.q[1], xs, 1e-11, "across the slope")
      near(stop.q[2], ss, 1e-11, "down the slope")
      -- the path against RK4 on the sliding law with 20,000 steps up to each point (halving its step
      -- changes it by less than 5e-15); the bound 1e-11: rk8pd at its default rtol 1e-10 is within 1e-12
      local function rk4(T, n)
        local y, dt = { 0, 0, v0, 0 }, T / n
        local function f(s)
          local sp = math.sqrt(s[3] ^ 2 + s[4] ^ 2)
          return { s[3], s[4], -af * s[3] / sp, -ag - af * s[4] / sp }
        end
        for _ = 1, n do
          local k1 = f(y)
          local y2 = {}; for i = 1, 4 do y2[i] = y[i] + dt / 2 * k1[i] end
          local k2 = f(y2)
          local y3 = {}; for i = 1, 4 do y3[i] = y[i] + dt / 2 * k2[i] end
          local k3 = f(y3)
          local y4 = {}; for i = 1, 4 do y4[i] = y[i] + dt * k3[i] end
          local k4 = f(y4)
          for i = 1, 4 do y[i] = y[i] + dt / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]) end
        end
        return y
      end
      for _, i in ipairs{ 11, 21, 31, 41 } do
        local ref = rk4(tr.t[i], 20000)
        near(tr.q[i][1], ref[1], 1e-11, ("x(%g) against RK4"):format(tr.t[i]))
        near(tr.q[i][2], ref[2], 1e-11, ("s(%g) against RK4"):format(tr.t[i]))
      end
      assert(max_abs{ tr.qd[#tr.qd][1], tr.qd[#tr.qd][2] } <= 1e-12, "at rest after the stop")
    end)

    it(("an oblique impact slides through along the slip, v_t+ = v_t (1 - mu (1 + e) v_n/|v_t|), or sticks (%s)"):format(
      method), function()
      local m, mu, e, H = 0.3, 0.2, 0.6, 0.5
      local ball = slider("ball", m, mu, mu, e, function(t, q) return m * g * q[3] end)
      local vn = math.sqrt(2 * g * H)
      for _, v in ipairs{ { 1.0, 2.0 }, { 0.3, 0.4 } } do
        local tr = ball:simulate{ q0 = { 0, 0, H }, qd0 = { v[1], v[2], 0 }, t1 = 0.4, dt = 0.01, method = method }
        local ev = tr.events[1]
        assert(ev.kind == "impact", "it lands")
        local vt = math.sqrt(v[1] ^ 2 + v[2] ^ 2)
        local f = math.max(0, 1 - mu * (1 + e) * vn / vt)
        near(ev.impulse, m * (1 + e) * vn, 1e-9, "P_n = m (1 + e) v_n")
        near(ev.qd_after[1], v[1] * f, 1e-9, "x'+")
        near(ev.qd_after[2], v[2] * f, 1e-9, "y'+")
        near(ev.qd_after[3], e * vn, 1e-9, "z'+ = e v_n")
        local Pt = ev.tangential_impulse
        assert(type(Pt) == "table" and #Pt == 2, "the tangential impulse is a vector")
        near(math.sqrt(Pt[1] ^ 2 + Pt[2] ^ 2), f > 0 and mu * ev.impulse or m * vt, 1e-9,
          f > 0 and "sliding through: |P_t| = mu P_n" or "sticking: |P_t| = m |v_t| < mu P_n")
        near(Pt[1] * v[2] - Pt[2] * v[1], 0, 1e-12, "P_t along the slip")
        assert(Pt[1] * v[1] + Pt[2] * v[2] < 0, "against it")
      end
    end)
  end

  it("a cone that starts sliding from rest follows the force's direction (rk8pd); taylor says it cannot start there", function()
    -- pulled by F = (3, 4) beyond mu_s m g: it slides along (3, 4)/5 at (|F| - mu m g)/m
    local m, mu = 0.5, 0.3
    local F = { 3.0, 4.0 }
    local sys = slider("pulled", m, mu, 0.4, 0, function(t, q) return m * g * q[3] - F[1] * q[1] - F[2] * q[2] end)
    local tr = sys:simulate{ q0 = { 0, 0, 0 }, t1 = 0.5, dt = 0.05 }
    local acc = (5 - mu * m * g) / m
    for i, t in ipairs(tr.t) do
      near(tr.q[i][1], 0.6 * acc * t * t / 2, 1e-10, ("x(%g)"):format(t))
      near(tr.q[i][2], 0.8 * acc * t * t / 2, 1e-10, ("y(%g)"):format(t))
    end
    local msg = errmsg(sys.simulate, sys, { q0 = { 0, 0, 0 }, t1 = 0.5, method = "taylor" })
    assert(msg:find("contact 'plane' starts to slide from rest (its isotropic cone) at t = 0", 1, true)
      and msg:find("take a GSL stepper for this run (method = 'rk8pd')", 1, true) and msg:find("contact_cone_spec.lua:%d+:"), msg)
  end)
end)

describe("what the cone option takes", function()
  local gap = function(t, q) return q[3] end
  it("slip = {f1, f2} or a function; else said", function()
    for _, bad in ipairs{ { function() return 0 end }, { 1, 2 }, "x" } do
      local msg = errmsg(function() local u = nz.unilateral(gap, { mu = 0.3, slip = bad }); return u end)
      assert(msg:find("'slip' must be a function(t, q, qd, params) giving the slip velocity, or {f1, f2}: the two slip "
        .. "velocities along orthonormal tangent directions (an isotropic cone)", 1, true) and msg:find("contact_cone_spec.lua:%d+:"), msg)
    end
  end)

  it("two contacts with the same gap are noticed at nz.system, in one line naming them", function()
    local said = {}
    local warn = require("nz.system").warn
    require("nz.system").warn = function(msg) said[#said + 1] = msg end
    local sys = nz.system{ name = "twice", coords = { "x", "y", "z" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end,
      constraints = { nz.unilateral(gap, { name = "a", mu = 0.3, slip = function(t, q, qd) return qd[1] end }),
        nz.unilateral(function(t, q) return q[3] end, { name = "b", mu = 0.3, slip = function(t, q, qd) return qd[2] end }),
        nz.unilateral(function(t, q) return q[3] - q[1] end, { name = "c" }) } }
    require("nz.system").warn = warn
    assert(sys.contact.n == 3 and #said == 1, ("one line (%d)"):format(#said))
    assert(said[1]:find("nz.system 'twice': contacts 'a' and 'b' have the same gap: one contact twice, held together and "
      .. "sharing its force; for friction in two directions give one contact slip = {f1, f2}", 1, true)
      and said[1]:find("contact_cone_spec.lua:%d+:") and not said[1]:find("'c'"), said[1])
  end)
end)
