-- problems.lua - the standard problems of the work-precision benchmark, each
-- a scene with its reference: a closed form where one exists (Kepler,
-- pendulum, rolling disk, Hamel's particle), else nil (the benchmark then
-- uses rk8pd at rtol 1e-13).
local nz = rawget(_G, "nz") or require "nz"
local M = {}

-- Kepler, e = 0.6, 10 orbits, polar coordinates (r, phi), phi unwrapped.
-- Closed form: Kepler's equation M = E - e sin E by Newton's method.
function M.kepler()
  local mu, e, a = 1.0, 0.6, 1.0
  local P = 2 * math.pi * math.sqrt(a ^ 3 / mu)
  local rp = a * (1 - e)
  local sys = nz.system{ name = "Kepler e=0.6", coords = { "r", "phi" },
    T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + q[1] ^ 2 * qd[2] ^ 2) end,
    V = function(t, q) return -mu / q[1] end }
  local function reference(t)
    local Mean = 2 * math.pi * t / P
    local E = Mean
    for _ = 1, 50 do
      local dE = (E - e * math.sin(E) - Mean) / (1 - e * math.cos(E))
      E = E - dE
      if math.abs(dE) < 1e-16 then break end
    end
    local r = a * (1 - e * math.cos(E))
    -- The true anomaly, continuous in E (no branch cut to unwrap):
    -- nu = E + 2 atan(beta sin E / (1 - beta cos E)), beta = e / (1 + sqrt(1 - e^2)).
    local beta = e / (1 + math.sqrt(1 - e * e))
    return { r, E + 2 * math.atan(beta * math.sin(E) / (1 - beta * math.cos(E))) }
  end
  return { sys = sys, start = { q0 = { rp, 0 }, qd0 = { 0, math.sqrt(mu * (1 + e) / rp) / rp }, t1 = 10 * P, dt = P / 8 },
    reference = reference }
end

-- A pendulum at large amplitude (2.5 rad), 5 periods; exact motion from
-- Jacobi's elliptic functions, the period from the complete elliptic
-- integral (GSL).
function M.pendulum()
  local g, l, th0 = 9.81, 1.0, 2.5
  local k, w = math.sin(th0 / 2), math.sqrt(g / l)
  local K = nz.special.ellint_K(k)
  local sys = nz.system{ name = "pendulum 2.5 rad", coords = { "th" },
    T = function(t, q, qd) return 0.5 * l * l * qd[1] ^ 2 end,
    V = function(t, q) return -g * l * nz.cos(q[1]) end }
  return { sys = sys, start = { q0 = { th0 }, t1 = 5 * 4 * K / w, dt = K / w / 4 },
    reference = function(t) return { 2 * math.asin(k * nz.special.elljac(K - w * t, k * k)) } end }
end

-- A double pendulum over a short horizon (chaotic: the horizon keeps the
-- reference meaningful).
function M.double_pendulum()
  local g = 9.81
  local sys = nz.system{ name = "double pendulum", coords = { "a", "b" }, bodies = { gravity = { 0, -g, 0 },
    { mass = 1, pos = function(t, q) return { nz.sin(q[1]), -nz.cos(q[1]), 0 } end },
    { mass = 1, pos = function(t, q) return { nz.sin(q[1]) + nz.sin(q[2]), -nz.cos(q[1]) - nz.cos(q[2]), 0 } end } } }
  return { sys = sys, start = { q0 = { 2.0, 1.0 }, t1 = 5, dt = 0.25 } }
end

function M.sleigh()
  local m, I, a = 2.0, 0.3, 0.4
  local sys = nz.system{ name = "Chaplygin sleigh", coords = { "x", "y", "th" },
    T = function(t, q, qd)
      local vx, vy = qd[1] - a * nz.sin(q[3]) * qd[3], qd[2] + a * nz.cos(q[3]) * qd[3]
      return 0.5 * m * (vx * vx + vy * vy) + 0.5 * I * qd[3] ^ 2
    end,
    constraints = { function(t, q, qd) return -qd[1] * nz.sin(q[3]) + qd[2] * nz.cos(q[3]) end } }
  local u, th, w = 0.5, 0.3, 2.0
  return { sys = sys, start = { q0 = { 0, 0, th }, qd0 = { u * math.cos(th), u * math.sin(th), w }, t1 = 10, dt = 0.5 } }
end

-- A vertical rolling disk: th and ph turn uniformly, and the contact point
-- runs on a circle of radius R ph' / th' (closed form).
function M.rolling_disk()
  local m, R, Id, Ia = 1.2, 0.3, 0.05, 0.08
  local sys = nz.system{ name = "rolling disk", coords = { "x", "y", "th", "ph" },
    T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2) + 0.5 * Id * qd[3] ^ 2 + 0.5 * Ia * qd[4] ^ 2 end,
    constraints = { function(t, q, qd) return qd[1] - R * qd[4] * nz.cos(q[3]) end,
      function(t, q, qd) return qd[2] - R * qd[4] * nz.sin(q[3]) end } }
  local th0, w, phd = 0.2, 0.7, 3.0
  local rho = R * phd / w
  return { sys = sys, start = { q0 = { 0, 0, th0, 0 }, qd0 = { R * phd * math.cos(th0), R * phd * math.sin(th0), w, phd }, t1 = 20, dt = 1 },
    reference = function(t)
      local th = th0 + w * t
      return { rho * (math.sin(th) - math.sin(th0)), -rho * (math.cos(th) - math.cos(th0)), th, phd * t }
    end }
end

-- Hamel's particle: constant forces give constant accelerations (the root
-- of the constraint reached at the start): q = q0 + qd0 t + a t^2 / 2.
function M.hamel()
  local m, Q = 1.5, { 0.7, -0.4, 2.0 }
  local sys = nz.system{ name = "Hamel's particle", coords = { "q1", "q2", "q3" },
    T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end,
    Q = function() return { Q[1], Q[2], Q[3] } end,
    constraints = { function(t, q, qd, qdd) return qdd[3] - qdd[1] * qdd[2] end } }
  local q0, qd0 = { 0, 0, 0 }, { 0.4, -0.5, 0.6 }
  local a = sys:accel(0, q0, qd0)
  return { sys = sys, start = { q0 = q0, qd0 = qd0, t1 = 5, dt = 0.5 },
    reference = function(t)
      local out = {}
      for j = 1, 3 do out[j] = q0[j] + qd0[j] * t + 0.5 * a[j] * t * t end
      return out
    end }
end

M.order = { "kepler", "pendulum", "double_pendulum", "sleigh", "rolling_disk", "hamel" }

return M
