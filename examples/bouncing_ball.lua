-- bouncing_ball.lua - a ball dropped from a height h on a floor with
-- Newton's restitution e bounces at t_k = t_1 (1 + 2e (1 - e^(k-1))/(1 - e)),
-- t_1 = sqrt(2h/g), each bounce keeping e^2 of the kinetic energy (heights h
-- e^(2k)).  The bounces accumulate at t_1 (1 + e)/(1 - e) (Zeno): infinitely
-- many in finite time.  nzlua sees the intervals shrinking geometrically
-- and the approach speed fall below 1e-6 of the first, makes that impact
-- plastic, and the ball rests on the floor from there (it does not step
-- forever).
local g, R, h, e = 9.81, 0.05, 1.0, 0.7
ball = nz.scene{ name = "bouncing ball", coords = { "y" },
  bodies = { { name = "ball", mass = 0.06, pos = function(t, q) return { 0, 0, q[1] } end } },
  effects = { nz.effects.gravity{ g = { 0, 0, -g } },
              nz.effects.contact{ name = "floor", at = "ball", plane = { normal = { 0, 0, 1 } }, radius = R, e = e } } }
tr = ball:simulate{ q0 = { R + h }, t1 = 5, dt = 0.01 }
print(tr)
local t1 = math.sqrt(2 * h / g)
print("  bounce   t (simulated)      t (closed form)    height after    h e^(2k)")
local impacts = {}
for _, ev in ipairs(tr.events) do if ev.kind == "impact" then impacts[#impacts + 1] = ev end end
local worst = 0
for k, ev in ipairs(impacts) do
  local tk = t1 * (1 + 2 * e * (1 - e ^ (k - 1)) / (1 - e))
  worst = math.max(worst, math.abs(ev.t - tk))
  if k <= 5 or k == #impacts then
    print(("  %6d   %.12f   %.12f   %.6e    %.6e"):format(k, ev.t, tk, ev.qd_after[1] ^ 2 / (2 * g), h * e ^ (2 * k)))
  end
end
print(("bounce times: largest difference from the closed form %.3g s over %d bounces"):format(worst, #impacts))
local last = impacts[#impacts]
print(("Zeno: at rest on the floor from t = %.9f; the impacts accumulate at %.9f (closed form %.9f)"):format(
  last.t, last.zeno, t1 * (1 + e) / (1 - e)))
print(("energy kept per bounce: %.12f (e^2 = %.12f)"):format(1 - impacts[1].energy_lost / (0.5 * 0.06 * impacts[1].qd[1] ^ 2), e * e))
tr:plot{ y = { "y" }, title = "a bouncing ball comes to rest" }
