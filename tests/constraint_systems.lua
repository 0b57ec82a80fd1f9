-- constraint_systems.lua - systems with constraints and their motion derived
-- by hand (written here, independently of the engine), shared by the specs.
-- Each entry: sys, n (Dolapchiev's order expected), accel(t, q, qd) -> qdd
-- (hand), draw() -> t, q, qd on the constraints.
local nz = require("tests.helpers").nz
local sin, cos, sqrt = math.sin, math.cos, math.sqrt

local M = {}
local function uniform(a, b) return a + (b - a) * math.random() end

-- Chaplygin sleigh: contact point (x, y), heading th, centre of mass at a
-- distance a along the blade; no lateral velocity at the contact point.
-- With u the forward speed and w = th': u' = a w^2, w' = -m a u w / (I + m a^2).
function M.sleigh()
  local m, I, a = 2.0, 0.3, 0.4
  return {
    name = "Chaplygin sleigh", n = 1, homogeneous = true,
    sys = nz.system{ name = "sleigh", coords = { "x", "y", "th" },
      T = function(t, q, qd)
        local vx, vy = qd[1] - a * nz.sin(q[3]) * qd[3], qd[2] + a * nz.cos(q[3]) * qd[3]
        return 0.5 * m * (vx * vx + vy * vy) + 0.5 * I * qd[3] ^ 2
      end,
      constraints = { function(t, q, qd) return -qd[1] * nz.sin(q[3]) + qd[2] * nz.cos(q[3]) end } },
    accel = function(t, q, qd)
      local th, w = q[3], qd[3]
      local u = qd[1] * cos(th) + qd[2] * sin(th)
      local ud, wd = a * w * w, -m * a * u * w / (I + m * a * a)
      return { ud * cos(th) - u * sin(th) * w, ud * sin(th) + u * cos(th) * w, wd }
    end,
    draw = function()
      local th, u, w = uniform(-3, 3), uniform(-2, 2), uniform(-2, 2)
      return 0, { uniform(-1, 1), uniform(-1, 1), th }, { u * cos(th), u * sin(th), w }
    end,
  }
end

-- Vertical rolling disk: contact (x, y), heading th, rolling angle ph;
-- x' = R ph' cos th, y' = R ph' sin th.  By hand: th'' = 0, ph'' = 0,
-- x'' = -R ph' th' sin th, y'' = R ph' th' cos th.
function M.rolling_disk()
  local m, R, Id, Ia = 1.2, 0.3, 0.05, 0.08
  return {
    name = "vertical rolling disk", n = 1, homogeneous = true,
    sys = nz.system{ name = "rolling disk", coords = { "x", "y", "th", "ph" },
      T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2) + 0.5 * Id * qd[3] ^ 2 + 0.5 * Ia * qd[4] ^ 2 end,
      constraints = {
        function(t, q, qd) return qd[1] - R * qd[4] * nz.cos(q[3]) end,
        function(t, q, qd) return qd[2] - R * qd[4] * nz.sin(q[3]) end,
      } },
    accel = function(t, q, qd)
      local th, thd, phd = q[3], qd[3], qd[4]
      return { -R * phd * thd * sin(th), R * phd * thd * cos(th), 0, 0 }
    end,
    draw = function()
      local th, thd, phd = uniform(-3, 3), uniform(-2, 2), uniform(-5, 5)
      return 0, { uniform(-1, 1), uniform(-1, 1), th, uniform(-3, 3) }, { R * phd * cos(th), R * phd * sin(th), thd, phd }
    end,
  }
end

-- A particle held at constant speed v0 in the field of a spring:
-- m a = F + 2 lambda v with a . v = 0, so lambda = -F.v / (2 |v|^2).
function M.constant_speed()
  local m, k, v0 = 0.7, 3.0, 1.5
  return {
    name = "particle at constant speed", n = 2, homogeneous = false,
    sys = nz.system{ name = "constant speed", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2) end,
      V = function(t, q) return 0.5 * k * (q[1] ^ 2 + q[2] ^ 2) end,
      constraints = { function(t, q, qd) return qd[1] ^ 2 + qd[2] ^ 2 - v0 * v0 end } },
    accel = function(t, q, qd)
      local F = { -k * q[1], -k * q[2] }
      local lam = -(F[1] * qd[1] + F[2] * qd[2]) / (2 * (qd[1] ^ 2 + qd[2] ^ 2))
      return { (F[1] + 2 * lam * qd[1]) / m, (F[2] + 2 * lam * qd[2]) / m }
    end,
    draw = function()
      local a = uniform(-3, 3)
      return 0, { uniform(-1, 1), uniform(-1, 1) }, { v0 * cos(a), v0 * sin(a) }
    end,
  }
end

-- Appell's constraint z'^2 = c^2 (x'^2 + y'^2) on a heavy particle:
-- m a = F + A^T lambda, A = (-2c^2 x', -2c^2 y', 2 z'), A . a = 0,
-- so lambda = -A.F / |A|^2.
function M.appell()
  local m, g, c = 1.3, 9.81, 0.6
  return {
    name = "Appell's nonlinear constraint", n = 2, homogeneous = true,
    sys = nz.system{ name = "appell", coords = { "x", "y", "z" },
      T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end,
      V = function(t, q) return m * g * q[3] end,
      constraints = { function(t, q, qd) return qd[3] ^ 2 - c * c * (qd[1] ^ 2 + qd[2] ^ 2) end } },
    accel = function(t, q, qd)
      local F = { 0, 0, -m * g }
      local A = { -2 * c * c * qd[1], -2 * c * c * qd[2], 2 * qd[3] }
      local lam = -(A[1] * F[1] + A[2] * F[2] + A[3] * F[3]) / (A[1] ^ 2 + A[2] ^ 2 + A[3] ^ 2)
      return { (F[1] + A[1] * lam) / m, (F[2] + A[2] * lam) / m, (F[3] + A[3] * lam) / m }
    end,
    draw = function()
      local vx, vy = uniform(-2, 2), uniform(-2, 2)
      return 0, { uniform(-1, 1), uniform(-1, 1), uniform(-1, 1) }, { vx, vy, c * sqrt(vx * vx + vy * vy) }
    end,
  }
end

-- A program constraint of second order, linear in the accelerations:
-- x'' + 2 y'' = sin t under constant forces.  m x'' = Fx + lambda,
-- m y'' = Fy + 2 lambda  =>  lambda = (m sin t - Fx - 2 Fy) / 5.
function M.program()
  local m, Fx, Fy = 0.9, 0.4, -1.1
  return {
    name = "second-order constraint linear in the accelerations", n = 2,
    sys = nz.system{ name = "program", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2) end,
      Q = function() return { Fx, Fy } end,
      constraints = { function(t, q, qd, qdd) return qdd[1] + 2 * qdd[2] - nz.sin(t) end } },
    accel = function(t, q, qd)
      local lam = (m * sin(t) - Fx - 2 * Fy) / 5
      return { (Fx + lam) / m, (Fy + 2 * lam) / m }
    end,
    draw = function() return uniform(0, 6), { uniform(-1, 1), uniform(-1, 1) }, { uniform(-1, 1), uniform(-1, 1) } end,
  }
end

-- A pendulum in Cartesian coordinates, x^2 + y^2 = l^2; by the angle th
-- (th'' = -(g/l) sin th): x'' = l (th'' cos th - th'^2 sin th),
-- y'' = l (th'' sin th + th'^2 cos th).
function M.cartesian_pendulum()
  local l, g, m = 1.3, 9.81, 0.8
  return {
    name = "pendulum in Cartesian coordinates", n = 1, homogeneous = true,
    sys = nz.system{ name = "cartesian pendulum", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2) end,
      V = function(t, q) return m * g * q[2] end,
      constraints = { function(t, q) return q[1] ^ 2 + q[2] ^ 2 - l * l end } },
    accel = function(t, q, qd)
      local th = math.atan(q[1], -q[2])
      local thd = (qd[1] * cos(th) + qd[2] * sin(th)) / l
      local thdd = -g / l * sin(th)
      return { l * (thdd * cos(th) - thd ^ 2 * sin(th)), l * (thdd * sin(th) + thd ^ 2 * cos(th)) }
    end,
    draw = function()
      local th, thd = uniform(-3, 3), uniform(-2, 2)
      return 0, { l * sin(th), -l * cos(th) }, { l * cos(th) * thd, l * sin(th) * thd }
    end,
  }
end

-- Hamel's particle (docs/theory.md §10): q3'' = q1'' q2'' under constant forces.
function M.hamel()
  local m, Q = 1.5, { 0.7, -0.4, 2.0 }
  return {
    name = "Hamel's second-order constraint", n = 3,
    m = m, Q = Q,
    sys = nz.system{ name = "hamel", coords = { "q1", "q2", "q3" },
      T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end,
      Q = function() return { Q[1], Q[2], Q[3] } end,
      constraints = { function(t, q, qd, qdd) return qdd[3] - qdd[1] * qdd[2] end } },
    draw = function()
      return uniform(0, 5), { uniform(-1, 1), uniform(-1, 1), uniform(-1, 1) }, { uniform(-1, 1), uniform(-1, 1), uniform(-1, 1) }
    end,
  }
end

-- Hamel's constraint one order up, nonlinear in q''' (q3''' = q1''' q2'''),
-- beside the unit circle in (q1, q2): a constraint of order 3 at the top
-- level and a holonomic one below it.  q0, qd0 lie on the circle.
function M.hamel3_on_circle()
  local m, Q = 1.3, { 0.7, -0.4, 2.0 }
  return {
    name = "Hamel's third-order constraint on a circle", m = m, Q = Q,
    q0 = { 0.6, 0.8, 0.3 }, qd0 = { 0.4, -0.3, 0.6 },
    sys = nz.system{ name = "hamel3 on a circle", coords = { "q1", "q2", "q3" },
      T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end,
      Q = function() return { Q[1], Q[2], Q[3] } end,
      constraints = { function(t, q, qd, qdd, qddd) return qddd[3] - qddd[1] * qddd[2] end,
        function(t, q) return q[1] ^ 2 + q[2] ^ 2 - 1 end } },
  }
end

-- A bead on a hoop of radius R turned at the rate W about the vertical:
-- th from the bottom, ph = W t (a moving holonomic constraint, which works
-- on the bead).  th'' = (W^2 cos th - g / R) sin th.  fields: added to the
-- system's definition (compile = false, ...).
function M.driven_hoop(fields)
  local m, R, W, g = 0.3, 0.5, 4.0, 9.81
  local def = { name = "driven hoop", coords = { "th", "ph" },
    T = function(t, q, qd) return 0.5 * m * R * R * (qd[1] ^ 2 + nz.sin(q[1]) ^ 2 * qd[2] ^ 2) end,
    V = function(t, q) return -m * g * R * nz.cos(q[1]) end,
    constraints = { function(t, q) return q[2] - W * t end } }
  for key, v in pairs(fields or {}) do def[key] = v end
  return {
    name = "driven hoop", n = 1, W = W, sys = nz.system(def),
    accel = function(t, q) return { (W * W * cos(q[1]) - g / R) * sin(q[1]), 0 } end,
    draw = function() return uniform(0, 2), { uniform(-2, 2), 0 }, { uniform(-1, 1), W } end,
  }
end

function M.linear_at_acceleration_level()
  return { M.sleigh(), M.rolling_disk(), M.constant_speed(), M.appell(), M.program(), M.cartesian_pendulum() }
end

return M
