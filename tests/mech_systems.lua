-- mech_systems.lua - classical systems with their equations of motion
-- derived by hand (written here, independently of the engine), shared by the
-- mechanics specs.  Each entry: a system built with nz.system, and
-- accel(t, q, qd) returning the hand-derived accelerations, and a function
-- that draws a random admissible state.
local nz = require("tests.helpers").nz
local sin, cos = math.sin, math.cos

local M = {}

local function uniform(a, b) return a + (b - a) * math.random() end

-- Solve the 2x2 system [a b; c d] x = [e; f].
local function solve2(a, b, c, d, e, f)
  local det = a * d - b * c
  return (e * d - b * f) / det, (a * f - c * e) / det
end

function M.pendulum()
  local g, l, m = 9.81, 1.3, 2.0
  return {
    name = "simple pendulum",
    sys = nz.system{ name = "pendulum", coords = { "th" },
      T = function(t, q, qd) return 0.5 * m * l * l * qd[1] ^ 2 end,
      V = function(t, q) return -m * g * l * nz.cos(q[1]) end },
    -- th'' = -(g/l) sin th
    accel = function(t, q, qd) return { -g / l * sin(q[1]) } end,
    draw = function() return uniform(0, 5), { uniform(-3, 3) }, { uniform(-2, 2) } end,
  }
end

function M.double_pendulum(with_bodies)
  local g, l1, l2, m1, m2 = 9.81, 1.1, 0.7, 2.0, 1.3
  local sys
  if with_bodies then
    sys = nz.system{ name = "double pendulum (bodies)", coords = { "a", "b" }, bodies = {
      gravity = { 0, -g, 0 },
      { mass = m1, pos = function(t, q) return { l1 * nz.sin(q[1]), -l1 * nz.cos(q[1]), 0 } end },
      { mass = m2, pos = function(t, q)
          return { l1 * nz.sin(q[1]) + l2 * nz.sin(q[2]), -l1 * nz.cos(q[1]) - l2 * nz.cos(q[2]), 0 } end },
    } }
  else
    sys = nz.system{ name = "double pendulum", coords = { "a", "b" },
      T = function(t, q, qd)
        return 0.5 * (m1 + m2) * l1 * l1 * qd[1] ^ 2 + 0.5 * m2 * l2 * l2 * qd[2] ^ 2
          + m2 * l1 * l2 * qd[1] * qd[2] * nz.cos(q[1] - q[2])
      end,
      V = function(t, q) return -(m1 + m2) * g * l1 * nz.cos(q[1]) - m2 * g * l2 * nz.cos(q[2]) end }
  end
  local function mass(q)
    return (m1 + m2) * l1 * l1, m2 * l1 * l2 * cos(q[1] - q[2]), m2 * l2 * l2
  end
  return {
    name = with_bodies and "double pendulum from bodies" or "double pendulum",
    sys = sys,
    mass = function(q) local a, b, c = mass(q); return { { a, b }, { b, c } } end,
    -- (m1+m2) l1^2 a'' + m2 l1 l2 cos(a-b) b'' + m2 l1 l2 sin(a-b) b'^2 + (m1+m2) g l1 sin a = 0
    -- m2 l1 l2 cos(a-b) a'' + m2 l2^2 b'' - m2 l1 l2 sin(a-b) a'^2 + m2 g l2 sin b = 0
    accel = function(t, q, qd)
      local d = q[1] - q[2]
      local M11, M12, M22 = mass(q)
      local r1 = -m2 * l1 * l2 * sin(d) * qd[2] ^ 2 - (m1 + m2) * g * l1 * sin(q[1])
      local r2 = m2 * l1 * l2 * sin(d) * qd[1] ^ 2 - m2 * g * l2 * sin(q[2])
      return { solve2(M11, M12, M12, M22, r1, r2) }
    end,
    draw = function() return 0, { uniform(-3, 3), uniform(-3, 3) }, { uniform(-2, 2), uniform(-2, 2) } end,
  }
end

function M.spherical_pendulum()
  local g, l, m = 9.81, 0.9, 1.7
  return {
    name = "spherical pendulum",
    sys = nz.system{ name = "spherical pendulum", coords = { "theta", "phi" },
      T = function(t, q, qd) return 0.5 * m * l * l * (qd[1] ^ 2 + nz.sin(q[1]) ^ 2 * qd[2] ^ 2) end,
      V = function(t, q) return -m * g * l * nz.cos(q[1]) end },
    -- theta'' = sin cos phi'^2 - (g/l) sin theta;  phi'' = -2 cot(theta) theta' phi'
    accel = function(t, q, qd)
      local th = q[1]
      return { sin(th) * cos(th) * qd[2] ^ 2 - g / l * sin(th), -2 * cos(th) / sin(th) * qd[1] * qd[2] }
    end,
    draw = function() return 0, { uniform(0.3, 2.8), uniform(-3, 3) }, { uniform(-2, 2), uniform(-2, 2) } end,
  }
end

function M.cart_pendulum()
  local p = { M = 3.0, m = 0.8, l = 0.6, k = 40.0, g = 9.81 }
  return {
    name = "pendulum on a spring-loaded cart",
    params = p,
    sys = nz.system{ name = "cart pendulum", coords = { "x", "th" }, params = p,
      T = function(t, q, qd, P)
        return 0.5 * (P.M + P.m) * qd[1] ^ 2 + P.m * P.l * qd[1] * qd[2] * nz.cos(q[2]) + 0.5 * P.m * P.l ^ 2 * qd[2] ^ 2
      end,
      V = function(t, q, P) return 0.5 * P.k * q[1] ^ 2 - P.m * P.g * P.l * nz.cos(q[2]) end },
    -- (M+m) x'' + m l cos th th'' - m l sin th th'^2 + k x = 0
    -- m l cos th x'' + m l^2 th'' + m g l sin th = 0
    accel = function(t, q, qd)
      local c, s = cos(q[2]), sin(q[2])
      return { solve2(p.M + p.m, p.m * p.l * c, p.m * p.l * c, p.m * p.l ^ 2,
        p.m * p.l * s * qd[2] ^ 2 - p.k * q[1], -p.m * p.g * p.l * s) }
    end,
    draw = function() return 0, { uniform(-1, 1), uniform(-3, 3) }, { uniform(-2, 2), uniform(-2, 2) } end,
  }
end

-- A bead on a hoop of radius R turning about the vertical at the rate
-- Omega(t) = w0 + alpha t (its angle phi(t) = w0 t + alpha t^2 / 2).
function M.hoop(with_bodies)
  local g, R, m, w0, alpha = 9.81, 0.5, 0.3, 2.0, 0.7
  local function Omega(t) return w0 + alpha * t end
  local sys
  if with_bodies then
    sys = nz.system{ name = "bead on a hoop (bodies)", coords = { "th" }, bodies = { gravity = { 0, 0, -g },
      { mass = m, pos = function(t, q)
          local phi = w0 * t + 0.5 * alpha * t * t
          return { R * nz.sin(q[1]) * nz.cos(phi), R * nz.sin(q[1]) * nz.sin(phi), -R * nz.cos(q[1]) }
        end } } }
  else
    sys = nz.system{ name = "bead on a hoop", coords = { "th" },
      T = function(t, q, qd) return 0.5 * m * R * R * (qd[1] ^ 2 + (w0 + alpha * t) ^ 2 * nz.sin(q[1]) ^ 2) end,
      V = function(t, q) return -m * g * R * nz.cos(q[1]) end }
  end
  return {
    name = with_bodies and "bead on a hoop from bodies" or "bead on a hoop",
    sys = sys,
    -- th'' = Omega(t)^2 sin th cos th - (g/R) sin th
    accel = function(t, q, qd) return { Omega(t) ^ 2 * sin(q[1]) * cos(q[1]) - g / R * sin(q[1]) } end,
    -- T2 = m R^2 th'^2 / 2, T0 = m R^2 Omega^2 sin^2 th / 2 (T1 = 0)
    parts = function(t, q, qd)
      return 0.5 * m * R * R * qd[1] ^ 2, 0.5 * m * R * R * Omega(t) ^ 2 * sin(q[1]) ^ 2, -m * g * R * cos(q[1])
    end,
    draw = function() return uniform(0, 3), { uniform(-3, 3) }, { uniform(-2, 2) } end,
  }
end

function M.kepler()
  local mu, m = 1.3, 0.9
  return {
    name = "Kepler problem in polar coordinates",
    sys = nz.system{ name = "kepler", coords = { "r", "phi" },
      T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + q[1] ^ 2 * qd[2] ^ 2) end,
      V = function(t, q) return -mu * m / q[1] end },
    -- r'' = r phi'^2 - mu / r^2;  phi'' = -2 r' phi' / r
    accel = function(t, q, qd) return { q[1] * qd[2] ^ 2 - mu / q[1] ^ 2, -2 * qd[1] * qd[2] / q[1] } end,
    draw = function() return 0, { uniform(0.5, 2), uniform(-3, 3) }, { uniform(-1, 1), uniform(-2, 2) } end,
  }
end

-- Heavy symmetric top, Euler angles (psi, theta, phi) of the z-x-z kind;
-- A: transverse moment about the fixed point, C: axial, lc: distance of the
-- centre of mass from the fixed point.
function M.top(with_bodies)
  local A, C, m, lc, g = 0.3, 0.2, 1.5, 0.4, 9.81
  local function rot(t, q)
    local c, s = nz.cos, nz.sin
    local Rz1 = { { c(q[1]), -s(q[1]), 0 }, { s(q[1]), c(q[1]), 0 }, { 0, 0, 1 } }
    local Rx = { { 1, 0, 0 }, { 0, c(q[2]), -s(q[2]) }, { 0, s(q[2]), c(q[2]) } }
    local Rz2 = { { c(q[3]), -s(q[3]), 0 }, { s(q[3]), c(q[3]), 0 }, { 0, 0, 1 } }
    local function mul(X, Y)
      local Z = {}
      for i = 1, 3 do
        Z[i] = {}
        for j = 1, 3 do Z[i][j] = X[i][1] * Y[1][j] + X[i][2] * Y[2][j] + X[i][3] * Y[3][j] end
      end
      return Z
    end
    return mul(mul(Rz1, Rx), Rz2)
  end
  local sys
  if with_bodies then
    -- Inertia about the centre of mass: A - m lc^2 transversally.
    sys = nz.system{ name = "top (bodies)", coords = { "psi", "theta", "phi" }, bodies = { gravity = { 0, 0, -g },
      { mass = m, inertia = { A - m * lc * lc, A - m * lc * lc, C }, rot = rot,
        pos = function(t, q) local R = rot(t, q); return { lc * R[1][3], lc * R[2][3], lc * R[3][3] } end } } }
  else
    sys = nz.system{ name = "top", coords = { "psi", "theta", "phi" },
      T = function(t, q, qd)
        local w3 = qd[3] + qd[1] * nz.cos(q[2])
        return 0.5 * A * (qd[2] ^ 2 + qd[1] ^ 2 * nz.sin(q[2]) ^ 2) + 0.5 * C * w3 * w3
      end,
      V = function(t, q) return m * g * lc * nz.cos(q[2]) end }
  end
  return {
    name = with_bodies and "heavy symmetric top from a rigid body" or "heavy symmetric top",
    sys = sys,
    -- L = A/2 (th'^2 + ps'^2 sin^2 th) + C/2 w3^2 - m g lc cos th, w3 = ph' + ps' cos th:
    -- w3' = 0;  A th'' = A ps'^2 sin th cos th - C w3 ps' sin th + m g lc sin th;
    -- A sin^2 th ps'' = C w3 th' sin th - 2 A ps' th' sin th cos th;
    -- ph'' = -ps'' cos th + ps' th' sin th.
    accel = function(t, q, qd)
      local th, psd, thd, phd = q[2], qd[1], qd[2], qd[3]
      local s, c = sin(th), cos(th)
      local w3 = phd + psd * c
      local thdd = (A * psd ^ 2 * s * c - C * w3 * psd * s + m * g * lc * s) / A
      local psdd = (C * w3 * thd * s - 2 * A * psd * thd * s * c) / (A * s * s)
      return { psdd, thdd, -psdd * c + psd * thd * s }
    end,
    draw = function()
      return 0, { uniform(-3, 3), uniform(0.3, 2.8), uniform(-3, 3) }, { uniform(-2, 2), uniform(-2, 2), uniform(-10, 10) }
    end,
  }
end

-- A charged particle in a plane, in polar coordinates (r, phi), on a
-- spring k, in a uniform magnetic field (b = charge times B along z), with
-- quadratic air drag -c |v| v and a driving force F0 cos(w t) along r: the
-- generalized forces depend on the velocities and on t, so every term Q of
-- (3.1) is exercised.  With v = r' e_r + r phi' e_phi, s = |v|, and
-- v x z = r phi' e_r - r' e_phi, projected on dr/dr = e_r and dr/dphi = r e_phi:
--   Q_r   = -c s r'       + b r phi'  + F0 cos(w t)
--   Q_phi = -c s r^2 phi' - b r r'
-- Lagrange: m r'' - m r phi'^2 + k r = Q_r;  m r^2 phi'' + 2 m r r' phi' = Q_phi.
function M.charged_drag()
  local m, k, b, c, F0, w = 1.3, 2.2, 0.9, 0.35, 0.6, 1.7
  local function forces(t, q, qd, sqrt, cos)
    local r, rd, phd = q[1], qd[1], qd[2]
    local s = sqrt(rd * rd + r * r * phd * phd)
    return { -c * s * rd + b * r * phd + F0 * cos(w * t), -c * s * r * r * phd - b * r * rd }, s
  end
  return {
    name = "charged particle with drag in a magnetic field",
    velocity_forces = true,
    sys = nz.system{ name = "charged drag", coords = { "r", "phi" },
      T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + q[1] ^ 2 * qd[2] ^ 2) end,
      V = function(t, q) return 0.5 * k * q[1] ^ 2 end,
      Q = function(t, q, qd) return (forces(t, q, qd, nz.sqrt, nz.cos)) end },
    accel = function(t, q, qd)
      local Q = forces(t, q, qd, math.sqrt, cos)
      local r, rd, phd = q[1], qd[1], qd[2]
      return { r * phd ^ 2 - k * r / m + Q[1] / m, (Q[2] - 2 * m * r * rd * phd) / (m * r * r) }
    end,
    -- dQ_j/dqd_i by hand (s_r' = r'/s, s_phi' = r^2 phi'/s), for the
    -- extremal form at n = 1 (docs/theory.md (4.3) needs dQ/dq^(n) = 0).
    dQ_dqd = function(t, q, qd)
      local _, s = forces(t, q, qd, math.sqrt, cos)
      local r, rd, phd = q[1], qd[1], qd[2]
      return { { -c * (s + rd * rd / s), -c * rd * r * r * phd / s + b * r },
               { -c * r * r * phd * rd / s - b * r, -c * r * r * (s + r * r * phd * phd / s) } }
    end,
    draw = function() return uniform(0, 3), { uniform(0.5, 2), uniform(-3, 3) }, { uniform(-1, 1), uniform(-2, 2) } end,
  }
end

-- A relativistic charged particle in a plane: a Lagrangian that is not
-- quadratic in the velocities, with a magnetic term linear in them and a
-- spring whose stiffness varies with t:
--   L = -m c^2 sqrt(1 - v^2/c^2) + (e/2)(x y' - y x') - k(t) (x^2 + y^2) / 2,
--   k(t) = k0 (1 + 0.3 sin t).
-- d/dt(m gamma v) = F with F = (e y' - k x, -e x' - k y) (the magnetic terms
-- of d/dt dL/dv and dL/dq add up), and m gamma (a + gamma^2 (v.a) v / c^2) = F
-- inverts to a = (F - (v.F) v / c^2) / (m gamma), gamma = 1/sqrt(1 - v^2/c^2).
function M.relativistic()
  local m, c, e, k0 = 0.8, 2.0, 1.1, 1.9
  local function k(t, sinf) return k0 * (1 + 0.3 * sinf(t)) end
  return {
    name = "relativistic charged oscillator (L not quadratic)",
    sys = nz.system{ name = "relativistic", coords = { "x", "y" },
      L = function(t, q, qd)
        return -m * c * c * nz.sqrt(1 - (qd[1] ^ 2 + qd[2] ^ 2) / (c * c))
          + 0.5 * e * (q[1] * qd[2] - q[2] * qd[1]) - 0.5 * k(t, nz.sin) * (q[1] ^ 2 + q[2] ^ 2)
      end },
    accel = function(t, q, qd)
      local kt = k(t, sin)
      local F = { e * qd[2] - kt * q[1], -e * qd[1] - kt * q[2] }
      local v2 = qd[1] ^ 2 + qd[2] ^ 2
      local gamma = 1 / math.sqrt(1 - v2 / (c * c))
      local vF = qd[1] * F[1] + qd[2] * F[2]
      return { (F[1] - vF * qd[1] / (c * c)) / (m * gamma), (F[2] - vF * qd[2] / (c * c)) / (m * gamma) }
    end,
    -- |v| <= sqrt(2) < c: gamma up to 1.41, far from quadratic.
    draw = function() return uniform(0, 3), { uniform(-1, 1), uniform(-1, 1) }, { uniform(-1, 1), uniform(-1, 1) } end,
  }
end

function M.all()
  return { M.pendulum(), M.double_pendulum(false), M.double_pendulum(true), M.spherical_pendulum(),
    M.cart_pendulum(), M.hoop(false), M.hoop(true), M.kepler(), M.top(false), M.top(true),
    M.charged_drag(), M.relativistic() }
end

return M
