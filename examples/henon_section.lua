-- henon_section.lua - Poincare sections of the Henon-Heiles system at the
-- energy E = 1/8: orbits that stay on invariant curves (regular) beside an
-- orbit that fills a region (chaotic).  The section is y, y' where x = 0 and
-- x' > 0, the crossings located by simulate's events (not read off a grid).
-- The cells of a 40 x 40 grid over the section that an orbit's crossings
-- visit tell them apart: a curve visits few (here under 30), a chaotic sea
-- many (over 150 of its ~230 crossings in cells of their own).
local E = 1 / 8
henon = nz.system{ name = "Henon-Heiles", coords = { "x", "y" },
  T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end,
  V = function(t, q) return 0.5 * (q[1] ^ 2 + q[2] ^ 2) + q[1] ^ 2 * q[2] - q[2] ^ 3 / 3 end }

-- Starts on x = 0 with y' = 0: x' from the energy.
local function start(y)
  local V = 0.5 * y * y - y ^ 3 / 3
  return { 0, y }, { math.sqrt(2 * (E - V)), 0 }
end

sections = {}
local series = {}
print(("Henon-Heiles at E = %g: Poincare sections (x = 0, x' > 0), t = 0 .. 1500"):format(E))
print(("%8s %10s %12s %10s"):format("y0", "crossings", "cells of 1600", "orbit"))
for n, y0 in ipairs{ -0.15, 0.05, 0.2, 0.3, 0.45, -0.3 } do
  local q0, qd0 = start(y0)
  local tr = henon:simulate{ q0 = q0, qd0 = qd0, t1 = 1500, dt = 1500, rtol = 1e-12, atol = 1e-12, method = "taylor",
    events = { { name = "x=0", f = function(t, q, qd) return q[1] end, direction = 1 } } }
  local s = tr:section{ when = "x=0", plot = { "y", "y'" }, draw = false }
  local cells = {}
  for i = 1, #s.x do cells[math.floor((s.x[i] + 0.6) / 1.3 * 40) * 64 + math.floor((s.y[i] + 0.6) / 1.2 * 40)] = true end
  local count = 0
  for _ in pairs(cells) do count = count + 1 end
  sections[n] = s
  print(("%8.2f %10d %12d %10s"):format(y0, #s.x, count, count > 80 and "chaotic" or "regular"))
  series[#series + 1] = { name = ("y0 = %g"):format(y0), x = s.x, y = s.y, style = ("points pt %d ps 0.3"):format(n) }
end
local drawn, why = pcall(require("nz.draw.plot").lines, { series = series, title = "Henon-Heiles, E = 1/8: the section x = 0",
  xlabel = "y", ylabel = "y'", width = 100, height = 36 })
if not drawn then print(why) end
