-- contact_shared_spec.lua - dependent contacts (docs/theory.md §13): rows held
-- that depend on each other, where the motion is unique and the forces are
-- not, against closed forms under rk8pd and taylor.  The forces are the
-- documented choice (least norm among the admissible ones): by symmetry m g/2
-- at each corner of a block at rest and m g/4 at each leg of a table.  A
-- block resting on its two corners with friction at both (two equal slip
-- rows), pushed below mu m g (held; near the limit one corner at its cone),
-- above it (slides); a table on four legs (four rows on three coordinates) at
-- rest, dropped flat (it bounces flat, apex heights h e^(2k)) and tilted (it
-- lands on one leg, rotates about it and lands flat: the time by quadrature,
-- the angular velocity by energy); a box on four corners in 3-D with
-- isotropic cones, at rest, pushed, near the limit and sliding; a stack of two
-- blocks with friction at all four corners.
local h = require "tests.helpers"
local nz = h.nz

local g = 9.81
local METHODS = { "rk8pd", "taylor" }

local max_abs = h.max_abs
local events_of = h.contact_events
local function last(tr, name) local col = tr:column(name); return col[#col] end
local near = h.near

local quad = h.gauss_legendre

describe("a block on its two corners, friction at both", function()
  -- centre (x, y) at height b above the corners (+-a, 0), angle th; the
  -- push P at the centre: N_L + N_R = m g, a (N_R - N_L) = b P (moments)
  local m, a, b, mu, mus = 2.0, 0.5, 0.3, 0.4, 0.5
  local I = m * (4 * a * a + 4 * b * b) / 12
  local function block(P)
    local function corner(s) return function(t, q) return q[2] + s * a * nz.sin(q[3]) - b * nz.cos(q[3]) end end
    local function slip(s) return function(t, q, qd) return qd[1] + (-s * a * nz.sin(q[3]) + b * nz.cos(q[3])) * qd[3] end end
    return nz.system{ name = "block", coords = { "x", "y", "th" },
      T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2) + 0.5 * I * qd[3] ^ 2 end,
      V = function(t, q) return m * g * q[2] - P * q[1] end,
      constraints = { nz.unilateral(corner(-1), { name = "left", mu = mu, mu_s = mus, slip = slip(-1) }),
        nz.unilateral(corner(1), { name = "right", mu = mu, mu_s = mus, slip = slip(1) }) } }
  end
  for _, method in ipairs(METHODS) do
    it(("rests with m g/2 at each corner, and a push below mu_s m g is held (%s)"):format(method), function()
      for _, P in ipairs{ 0, 5, 9.3 } do
        local tr = block(P):simulate{ q0 = { 0, b, 0 }, t1 = 1, dt = 0.05, method = method }
        assert(tr.status == "done" and tr.contacts.final[1] == "stick" and tr.contacts.final[2] == "stick",
          ("P = %g: both corners stick (%s, %s)"):format(P, tr.contacts.final[1], tr.contacts.final[2]))
        local NL, NR = (m * g - b * P / a) / 2, (m * g + b * P / a) / 2
        near(last(tr, "N.left"), NL, 1e-12, ("P = %g: N.left = (m g - b P/a)/2"):format(P))
        near(last(tr, "N.right"), NR, 1e-12, ("P = %g: N.right = (m g + b P/a)/2"):format(P))
        local TL, TR = last(tr, "T.left"), last(tr, "T.right")
        near(TL + TR, -P, 1e-12, ("P = %g: the friction holds the push"):format(P))
        if P / 2 <= mus * NL then      -- the least norm: halves
          near(TL, -P / 2, 1e-12, ("P = %g: least norm, T.left = -P/2"):format(P))
        else                           -- the left corner at its cone, the right one the rest
          near(TL, -mus * NL, 1e-12, ("P = %g: the left corner at its cone, T = -mu_s N"):format(P))
        end
        assert(math.abs(TR) <= mus * NR * (1 + 1e-12), ("P = %g: the right corner within its cone"):format(P))
        assert(max_abs{ tr.q[#tr.q][1], tr.q[#tr.q][2] - b, tr.q[#tr.q][3] } <= 1e-12, ("P = %g: it does not move"):format(P))
      end
    end)

    it(("a push above mu_s m g slides it at x'' = (P - mu m g)/m (%s)"):format(method), function()
      local P = 12.0
      local tr = block(P):simulate{ q0 = { 0, b, 0 }, t1 = 1, dt = 0.05, method = method }
      assert(tr.contacts.final[1] == "slip+" and tr.contacts.final[2] == "slip+")
      local acc = (P - mu * m * g) / m
      for i, t in ipairs(tr.t) do near(tr.q[i][1], acc * t * t / 2, 1e-10, ("x(%g)"):format(t)) end
      -- sliding, the friction's moment about the centre joins the push's: a (N_R - N_L) = b mu m g
      near(last(tr, "N.right") - last(tr, "N.left"), b * mu * m * g / a, 1e-10, "N_R - N_L = b mu m g / a")
    end)
  end
end)

describe("a table on four legs", function()
  -- the top's centre (x, y), angle th; legs at x_i below it at depth d:
  -- gap_i = y + x_i sin th - d cos th (four rows on three coordinates)
  local m, I, d = 3.0, 0.8, 0.4
  local legs = { -0.6, -0.2, 0.2, 0.6 }
  local function table_sys(e)
    local cons = {}
    for i, xi in ipairs(legs) do
      cons[i] = nz.unilateral(function(t, q) return q[2] + xi * nz.sin(q[3]) - d * nz.cos(q[3]) end,
        { name = "leg" .. i, e = e })
    end
    return nz.system{ name = "table", coords = { "x", "y", "th" },
      T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2) + 0.5 * I * qd[3] ^ 2 end,
      V = function(t, q) return m * g * q[2] end, constraints = cons }
  end
  for _, method in ipairs(METHODS) do
    it(("at rest carries m g/4 on each leg (%s)"):format(method), function()
      local tr = table_sys(0.5):simulate{ q0 = { 0, d, 0 }, t1 = 2, dt = 0.1, method = method }
      for i = 1, 4 do near(last(tr, "N.leg" .. i), m * g / 4, 1e-12, "N.leg" .. i) end
      assert(max_abs{ tr.q[#tr.q][2] - d, tr.q[#tr.q][3], tr.qd[#tr.qd][2] } <= 1e-13, "at rest")
    end)

    it(("dropped flat it bounces flat: impacts at t1 (1 + 2e (1 - e^(k-1))/(1 - e)), apex heights H e^(2k) (%s)"):format(
      method), function()
      local H, e = 0.5, 0.5
      local tr = table_sys(e):simulate{ q0 = { 0, d + H, 0 }, t1 = 2, dt = 0.01, method = method }
      local t1, v1 = math.sqrt(2 * H / g), math.sqrt(2 * g * H)
      for k = 1, 10 do
        local tk = t1 * (1 + 2 * e * (1 - e ^ (k - 1)) / (1 - e))
        local hits = {}
        for _, ev in ipairs(events_of(tr, "impact")) do if math.abs(ev.t - tk) <= 1e-9 then hits[#hits + 1] = ev end end
        assert(#hits == 4, ("bounce %d at %.12g: an impulse at each leg (%d)"):format(k, tk, #hits))
        for _, ev in ipairs(hits) do
          near(ev.impulse, m * (1 + e) * e ^ (k - 1) * v1 / 4, 1e-9, ("bounce %d: %s's impulse m (1 + e) v / 4"):format(k, ev.name))
          near(ev.qd_after[2] ^ 2 / (2 * g), H * e ^ (2 * k), 1e-9 * H, ("bounce %d: apex H e^2k"):format(k))
          assert(math.abs(ev.qd_after[3]) <= 1e-12, "and flat")
        end
      end
      assert(math.abs(tr.q[#tr.q][3]) <= 1e-12 and tr.contacts.final[1] == "closed", "at rest flat in the end")
    end)

    it(("dropped tilted it lands on one leg, rotates about it and lands flat at the times the closed forms give (%s)"):format(
      method), function()
      local th0, y0 = 0.1, d + 0.5
      local tr = table_sys(0):simulate{ q0 = { 0, y0, th0 }, t1 = 1, dt = 0.01, method = method }
      local x1 = legs[1]
      -- the free fall until leg 1 touches: y = d cos th0 - x1 sin th0
      local yc = d * math.cos(th0) - x1 * math.sin(th0)
      local ta = math.sqrt(2 * (y0 - yc) / g)
      local first = events_of(tr, "impact")[1]
      assert(first.name == "leg1", "leg 1 lands first")
      near(first.t, ta, 1e-9, "its landing time")
      -- a plastic impact on one row J = (0, 1, x1 cos th0 + d sin th0): P = v / (1/m + J3^2/I)
      local v, J3 = g * ta, x1 * math.cos(th0) + d * math.sin(th0)
      local P = v / (1 / m + J3 ^ 2 / I)
      near(first.impulse, P, 1e-9 * P, "P = v / (J M^-1 J^T)")
      near(first.qd_after[3], J3 * P / I, 1e-9, "th' = J3 P / I")
      -- then about leg 1 (frictionless: x' stays 0): y = d cos th - x1 sin th, y' = f(th) th',
      -- (m f^2 + I) th'^2 / 2 + m g y = E
      local function f(th) return -d * math.sin(th) - x1 * math.cos(th) end
      local function yl(th) return d * math.cos(th) - x1 * math.sin(th) end
      local w0 = first.qd_after[3]
      local E = 0.5 * (m * f(th0) ^ 2 + I) * w0 ^ 2 + m * g * yl(th0)
      local function rate(th) return -math.sqrt(2 * (E - m * g * yl(th)) / (m * f(th) ^ 2 + I)) end
      local tland = ta + quad(function(th) return -1 / rate(th) end, 0, th0, 40)
      local flat = events_of(tr, "impact")
      local second = flat[2]
      assert(second and second.name ~= "leg1", "then the others land")
      near(second.t, tland, 1e-8, "flat at the quadrature's time")
      local Tland = 0.5 * (m * f(0) ^ 2 + I) * rate(0) ^ 2
      local lost = 0
      for _, ev in ipairs(flat) do if ev.t == second.t then lost = lost + (ev.energy_lost or 0) end end
      near(lost, Tland, 1e-8 * Tland, "the landing loses all the kinetic energy (e = 0)")
      for _, ev in ipairs(flat) do assert(ev.impulse >= 0, "every impulse pushes") end
      assert(max_abs{ tr.q[#tr.q][3], tr.qd[#tr.qd][2], tr.qd[#tr.qd][3], tr.qd[#tr.qd][1] } <= 1e-12, "at rest flat")
      for i = 1, 4 do near(last(tr, "N.leg" .. i), m * g / 4, 1e-10, "then m g/4 each") end
    end)
  end
end)

describe("a box on four corners in 3-D with isotropic cones", function()
  local m, mu, mus = 2.0, 0.4, 0.5
  local a, b, c = 0.5, 0.3, 0.2          -- corners at (+-a, +-b, -c) from the centre
  local I1, I2, I3 = m * (b * b + c * c) / 3, m * (a * a + c * c) / 3, m * (a * a + b * b) / 3
  -- q = x, y, z, roll, pitch, yaw: R = Rz(yaw) Ry(pitch) Rx(roll)
  local function R(q)
    local cf, sf, ct, st, cp, sp = nz.cos(q[4]), nz.sin(q[4]), nz.cos(q[5]), nz.sin(q[5]), nz.cos(q[6]), nz.sin(q[6])
    return { { cp * ct, cp * st * sf - sp * cf, cp * st * cf + sp * sf },
      { sp * ct, sp * st * sf + cp * cf, sp * st * cf - cp * sf }, { -st, ct * sf, ct * cf } }
  end
  local function omega(q, qd)   -- in the body's frame
    local sf, cf, st, ct = nz.sin(q[4]), nz.cos(q[4]), nz.sin(q[5]), nz.cos(q[5])
    return { qd[4] - qd[6] * st, qd[5] * cf + qd[6] * sf * ct, -qd[5] * sf + qd[6] * cf * ct }
  end
  local function corner_velocity(q, qd, r, i)
    local w, Rm = omega(q, qd), R(q)
    local wr = { w[2] * r[3] - w[3] * r[2], w[3] * r[1] - w[1] * r[3], w[1] * r[2] - w[2] * r[1] }
    return qd[i] + Rm[i][1] * wr[1] + Rm[i][2] * wr[2] + Rm[i][3] * wr[3]
  end
  local function box(P)
    local cons = {}
    for _, sx in ipairs{ -1, 1 } do
      for _, sy in ipairs{ -1, 1 } do
        local r = { sx * a, sy * b, -c }
        cons[#cons + 1] = nz.unilateral(function(t, q)
          local Rm = R(q)
          return q[3] + Rm[3][1] * r[1] + Rm[3][2] * r[2] + Rm[3][3] * r[3]
        end, { name = (sx < 0 and "back" or "front") .. (sy < 0 and "R" or "L"), mu = mu, mu_s = mus,
          slip = { function(t, q, qd) return corner_velocity(q, qd, r, 1) end,
            function(t, q, qd) return corner_velocity(q, qd, r, 2) end } })
      end
    end
    return nz.system{ name = "box", coords = { "x", "y", "z", "roll", "pitch", "yaw" },
      T = function(t, q, qd)
        local w = omega(q, qd)
        return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) + 0.5 * (I1 * w[1] ^ 2 + I2 * w[2] ^ 2 + I3 * w[3] ^ 2)
      end,
      V = function(t, q) return m * g * q[3] - P * q[1] end, constraints = cons }
  end
  local corners = { "backR", "backL", "frontR", "frontL" }
  for _, method in ipairs(METHODS) do
    it(("at rest m g/4 per corner; pushed along x, N = m g/4 -+ c P/(4a), T = -P/4 (%s)"):format(method), function()
      for _, P in ipairs{ 0, 3 } do
        local tr = box(P):simulate{ q0 = { 0, 0, c, 0, 0, 0 }, t1 = 1, dt = 0.05, method = method }
        for j, nm in ipairs(corners) do
          assert(tr.contacts.final[j] == "stick", nm .. " sticks")
          local back = nm:sub(1, 4) == "back"
          near(last(tr, "N." .. nm), m * g / 4 + (back and -1 or 1) * c * P / (4 * a), 1e-12, ("P = %g: N.%s"):format(P, nm))
          near(last(tr, "T1." .. nm), -P / 4, 1e-12, ("P = %g: T1.%s"):format(P, nm))
          near(last(tr, "T2." .. nm), 0, 1e-12, ("P = %g: T2.%s"):format(P, nm))
        end
        assert(max_abs(tr.qd[#tr.qd]) <= 1e-12, "it does not move")
      end
    end)

    it(("pushed near mu_s m g the back corners hold at their cones; beyond, it slides (%s)"):format(method), function()
      local P = 9.0                    -- P/4 > mu_s (m g/4 - c P/(4a)): least norm would leave the back cones
      local tr = box(P):simulate{ q0 = { 0, 0, c, 0, 0, 0 }, t1 = 1, dt = 0.05, method = method }
      local Nb, Nf = m * g / 4 - c * P / (4 * a), m * g / 4 + c * P / (4 * a)
      for _, nm in ipairs(corners) do
        local back = nm:sub(1, 4) == "back"
        near(last(tr, "N." .. nm), back and Nb or Nf, 1e-12, "N." .. nm)
        near(last(tr, "T1." .. nm), back and -mus * Nb or -(P / 2 - mus * Nb), 1e-12, "T1." .. nm)
      end
      assert(max_abs(tr.qd[#tr.qd]) <= 1e-12, "held")
      P = 10.5                         -- > mu_s m g: it slides, x'' = (P - mu m g)/m
      if method == "taylor" then
        -- an isotropic cone starting to slide from rest: |v_t|'s series is singular at zero
        local ok, err = pcall(box(P).simulate, box(P), { q0 = { 0, 0, c, 0, 0, 0 }, t1 = 0.5, method = method })
        assert(not ok and tostring(err):find("starts to slide from rest (its isotropic cone) at t = 0", 1, true)
          and tostring(err):find("method 'taylor' cannot start there", 1, true)
          and tostring(err):find("contact_shared_spec.lua:%d+:"), tostring(err))
        return
      end
      tr = box(P):simulate{ q0 = { 0, 0, c, 0, 0, 0 }, t1 = 0.5, dt = 0.05, method = method }
      local acc = (P - mu * m * g) / m
      for i, t in ipairs(tr.t) do
        near(tr.q[i][1], acc * t * t / 2, 1e-10, ("x(%g)"):format(t))
        assert(max_abs{ tr.q[i][2], tr.q[i][4], tr.q[i][5], tr.q[i][6] } <= 1e-12, "straight, without turning")
      end
      -- the friction mu m g at the floor tilts the load: N = m g/4 -+ c mu m g/(4a), friction mu N each
      for _, nm in ipairs(corners) do
        local Nj = m * g / 4 + (nm:sub(1, 4) == "back" and -1 or 1) * c * mu * m * g / (4 * a)
        near(last(tr, "N." .. nm), Nj, 1e-10, "sliding: N." .. nm)
        near(last(tr, "T1." .. nm), -mu * Nj, 1e-10, "sliding: T1." .. nm)
      end
    end)
  end
end)

describe("a stack of two blocks, friction at all four corners", function()
  local m1, m2, mu = 2.0, 1.0, 0.5
  local a1, b1, a2, b2 = 0.5, 0.2, 0.3, 0.15   -- half widths and heights
  local I1, I2 = m1 * (4 * a1 * a1 + 4 * b1 * b1) / 12, m2 * (4 * a2 * a2 + 4 * b2 * b2) / 12
  local function pt(q, i, u, v)     -- the point (u, v) of block i in the plane
    local x, y, th = q[3 * i - 2], q[3 * i - 1], q[3 * i]
    return x + u * nz.cos(th) - v * nz.sin(th), y + u * nz.sin(th) + v * nz.cos(th)
  end
  local function vel(q, qd, i, u, v)
    local th, w = q[3 * i], qd[3 * i]
    return qd[3 * i - 2] - w * (u * nz.sin(th) + v * nz.cos(th)), qd[3 * i - 1] + w * (u * nz.cos(th) - v * nz.sin(th))
  end
  local function stack(P)
    local cons = {}
    for _, s in ipairs{ -1, 1 } do    -- block 1 on the floor
      cons[#cons + 1] = nz.unilateral(function(t, q) local _, y = pt(q, 1, s * a1, -b1); return y end,
        { name = "floor" .. (s < 0 and "L" or "R"), mu = mu, slip = function(t, q, qd) return (vel(q, qd, 1, s * a1, -b1)) end })
    end
    for _, s in ipairs{ -1, 1 } do    -- block 2 on block 1's top, measured in block 1's frame
      cons[#cons + 1] = nz.unilateral(function(t, q)
        local x, y = pt(q, 2, s * a2, -b2)
        return -(x - q[1]) * nz.sin(q[3]) + (y - q[2]) * nz.cos(q[3]) - b1
      end, { name = "top" .. (s < 0 and "L" or "R"), mu = mu, slip = function(t, q, qd)
        local vx, vy = vel(q, qd, 2, s * a2, -b2)
        local x, y = pt(q, 2, s * a2, -b2)
        local ux, uy = vel(q, qd, 1, (x - q[1]) * nz.cos(q[3]) + (y - q[2]) * nz.sin(q[3]), b1)
        return (vx - ux) * nz.cos(q[3]) + (vy - uy) * nz.sin(q[3])
      end })
    end
    return nz.system{ name = "stack", coords = { "x1", "y1", "th1", "x2", "y2", "th2" },
      T = function(t, q, qd)
        return 0.5 * m1 * (qd[1] ^ 2 + qd[2] ^ 2) + 0.5 * I1 * qd[3] ^ 2 + 0.5 * m2 * (qd[4] ^ 2 + qd[5] ^ 2) + 0.5 * I2 * qd[6] ^ 2
      end,
      V = function(t, q) return m1 * g * q[2] + m2 * g * q[5] - P * q[4] end, constraints = cons }
  end
  for _, method in ipairs(METHODS) do
    it(("rests with (m1 + m2) g/2 under block 1 and m2 g/2 under block 2; the top one pushed, each pair shares (%s)"):format(
      method), function()
      for _, P in ipairs{ 0, 2 } do
        local tr = stack(P):simulate{ q0 = { 0, b1, 0, 0, 2 * b1 + b2, 0 }, t1 = 1, dt = 0.05, method = method }
        -- the top block: a2 (N_R - N_L) = b2 P; the whole stack: a1 (N_R - N_L) = (2 b1 + b2) P
        near(last(tr, "N.topL"), (m2 * g - b2 * P / a2) / 2, 1e-12, "N.topL")
        near(last(tr, "N.topR"), (m2 * g + b2 * P / a2) / 2, 1e-12, "N.topR")
        near(last(tr, "N.floorL"), ((m1 + m2) * g - (2 * b1 + b2) * P / a1) / 2, 1e-12, "N.floorL")
        near(last(tr, "N.floorR"), ((m1 + m2) * g + (2 * b1 + b2) * P / a1) / 2, 1e-12, "N.floorR")
        for _, nm in ipairs{ "topL", "topR", "floorL", "floorR" } do near(last(tr, "T." .. nm), -P / 2, 1e-12, "T." .. nm) end
        assert(max_abs(tr.qd[#tr.qd]) <= 1e-12, "at rest")
      end
    end)
  end
end)
