-- contact_spec.lua - unilateral contacts, impacts and friction (issue 26)
-- against closed forms: a particle leaving a sphere where cos th = (2/3)
-- cos th0 (its time by quadrature, its flight a parabola); a ladder leaving
-- a smooth wall at the same ratio, two contacts held at once; a ball's bounce
-- times t1 (1 + 2e (1 - e^(k-1))/(1 - e)), heights h e^(2k), energy lost
-- (1 - e^2) per bounce and rest after the accumulation time; a block on a
-- slope that stays, stops at v0^2/(2g(sin a + mu cos a)) and sticks or slides
-- back; a pendulum against a stop (energy over 100 impacts at e = 1, the
-- amplitudes 1 - cos th_k+1 = e^2 (1 - cos th_k) at e < 1, the impacts at
-- odd quarter periods K(k) sqrt(l/g)); a double pendulum's tip hitting a
-- wall against the impulse equations written out by hand; Newton's cradle
-- under the simultaneous law; a billiard ball slipping, then rolling at
-- 5/7 of its speed; a ball on a vibrating table (Newton's law relative to
-- it); a block on a moving belt sticking and slipping at the closed-form
-- times; every method; Painleve's paradox; scenes; what the trajectory
-- shows; every error.
local h = require "tests.helpers"
local nz = h.nz
local E = nz.effects

local g = 9.81

local max_abs = h.max_abs
-- (here, not in tests/helpers.lua: an error names the first frame outside
-- the library, which must be this file's)
local function errmsg(f, ...)
  local ok, err = pcall(f, ...)
  assert(not ok, "an error was expected")
  return tostring(err)
end
local events_of = h.contact_events

local quad = h.gauss_legendre

local ball_e = 0.8
local function ball(e, R)
  return nz.system{ name = "ball", coords = { "y" },
    T = function(t, q, qd) return 0.5 * 1.3 * qd[1] ^ 2 end,
    V = function(t, q) return 1.3 * g * q[1] end,
    constraints = { nz.unilateral(function(t, q) return q[1] - R end, { e = e, name = "floor" }) } }
end

describe("closed forms", function()
  for _, method in ipairs{ "rk8pd", "taylor" } do
    it(("a particle leaves a sphere where cos th = (2/3) cos th0, then flies a parabola (%s)"):format(method), function()
      local R, th0 = 1.3, 0.3
      local p = nz.system{ name = "particle on a sphere", coords = { "x", "z" },
        T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end,
        V = function(t, q) return g * q[2] end,
        constraints = { nz.unilateral(function(t, q) return nz.sqrt(q[1] ^ 2 + q[2] ^ 2) - R end, { name = "sphere" }) } }
      local tr = p:simulate{ q0 = { R * math.sin(th0), R * math.cos(th0) }, t1 = 1.5, dt = 0.01, method = method }
      local opens = events_of(tr, "opens")
      assert(#opens == 1 and #events_of(tr, "closes") == 1, "it rests on the sphere from the start, then leaves once")
      local thf = math.acos(2 / 3 * math.cos(th0))
      -- on the sphere th'^2 = (2g/R)(cos th0 - cos th): t = sqrt(R/2g) int dth / sqrt(cos th0 - cos th), th = th0 + u^2
      local tf = math.sqrt(R / (2 * g)) * quad(function(u)
        return 2 * u / math.sqrt(2 * math.sin(th0 + u * u / 2) * math.sin(u * u / 2))
      end, 0, math.sqrt(thf - th0), 40)
      local ev = opens[1]
      local th = math.atan(ev.q[1], ev.q[2])
      assert(math.abs(th - thf) <= 1e-9, ("it leaves at th = %.15g, closed form %.15g"):format(th, thf))
      assert(math.abs(ev.t - tf) <= 1e-9, ("it leaves at t = %.15g, closed form %.15g"):format(ev.t, tf))
      local v, worst = math.sqrt(g * R * math.cos(thf)), 0
      for i, t in ipairs(tr.t) do
        if t > tf then
          local s = t - tf
          worst = math.max(worst, math.abs(tr.q[i][1] - (R * math.sin(thf) + v * math.cos(thf) * s)),
            math.abs(tr.q[i][2] - (R * math.cos(thf) - v * math.sin(thf) * s - g / 2 * s * s)))
        end
      end
      assert(worst <= 1e-9, ("the free flight within %.3g of the parabola"):format(worst))
      -- the normal force on the sphere before it leaves: m (g cos th - v^2/R) = m g (3 cos th - 2 cos th0)
      local i = 11
      local thi = math.atan(tr.q[i][1], tr.q[i][2])
      local N = tr:column("N.sphere")[i]
      assert(math.abs(N - g * (3 * math.cos(thi) - 2 * math.cos(th0))) <= 1e-8, "the normal force m g (3 cos th - 2 cos th0)")
    end)

    it(("a ladder between a smooth wall and floor leaves the wall when its centre is at 2/3 of its height (%s)"):format(method), function()
      -- a rod of length 2l, centre (x, y), angle th from the vertical: top (x - l sin th, y + l cos th) on the wall x = 0,
      -- foot (x + l sin th, y - l cos th) on the floor y = 0; T = (x'^2 + y'^2)/2 + l^2 th'^2/6 (I = m (2l)^2/12)
      local l, th0 = 1.2, 0.3
      local ladder = nz.system{ name = "ladder", coords = { "x", "y", "th" },
        T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) + l ^ 2 / 6 * qd[3] ^ 2 end,
        V = function(t, q) return g * q[2] end,
        constraints = { nz.unilateral(function(t, q) return q[1] - l * nz.sin(q[3]) end, { name = "wall" }),
          nz.unilateral(function(t, q) return q[2] - l * nz.cos(q[3]) end, { name = "floor" }) } }
      local tr = ladder:simulate{ q0 = { l * math.sin(th0), l * math.cos(th0), th0 }, t1 = 1, dt = 0.01, method = method }
      local opens = events_of(tr, "opens")
      assert(#opens == 1 and opens[1].name == "wall", "it leaves the wall once and keeps its foot on the floor")
      -- against both, the centre moves on a circle of radius l: (2/3) l^2 th'^2 = g l (cos th0 - cos th), and the wall's
      -- push vanishes where cos th = (2/3) cos th0; t = int dth / sqrt((3g/2l)(cos th0 - cos th)), cos th = cos th0 - s^2
      local c0 = math.cos(th0)
      local tf = quad(function(s) return 2 / (math.sin(math.acos(c0 - s * s)) * math.sqrt(1.5 * g / l)) end,
        0, math.sqrt(c0 / 3), 40)
      local ev = opens[1]
      assert(math.abs(math.cos(ev.q[3]) - 2 / 3 * c0) <= 1e-9,
        ("it leaves at cos th = %.15g, closed form %.15g"):format(math.cos(ev.q[3]), 2 / 3 * c0))
      assert(math.abs(ev.t - tf) <= 1e-9, ("it leaves at t = %.15g, closed form %.15g"):format(ev.t, tf))
      -- then no horizontal force: the centre's x' keeps its value at separation, l th' cos th (on the circle)
      local vx, worst = ev.qd[1], 0
      assert(math.abs(vx - l * ev.qd[3] * math.cos(ev.q[3])) <= 1e-9, "x' = l th' cos th at separation")
      for i, t in ipairs(tr.t) do
        if t > tf then worst = math.max(worst, math.abs(tr.qd[i][1] - vx)) end
      end
      assert(worst <= 1e-9, ("x' constant after separation within %.3g"):format(worst))
    end)

    it(("a ball bounces at t1 (1 + 2e (1 - e^(k-1))/(1 - e)), loses 1 - e^2 per bounce, then rests (%s)"):format(method), function()
      local R, hh = 0.1, 1.0
      local tr = ball(ball_e, R):simulate{ q0 = { R + hh }, t1 = 6, dt = 0.01, method = method }
      local t1, v1 = math.sqrt(2 * hh / g), math.sqrt(2 * g * hh)
      local impacts = events_of(tr, "impact")
      assert(#impacts > 40, "dozens of bounces")
      for k = 1, 40 do
        local ev, tk = impacts[k], t1 * (1 + 2 * ball_e * (1 - ball_e ^ (k - 1)) / (1 - ball_e))
        assert(math.abs(ev.t - tk) <= 1e-9, ("bounce %d at t = %.15g, closed form %.15g"):format(k, ev.t, tk))
        -- (the velocity at the located impact carries g times its time's tolerance, 1e-12 t)
        local hk = ev.qd_after[1] ^ 2 / (2 * g)
        assert(math.abs(hk - hh * ball_e ^ (2 * k)) <= 1e-9 * hh,
          ("height after bounce %d: %.15g, closed form h e^2k = %.15g"):format(k, hk, hh * ball_e ^ (2 * k)))
        local T = 0.5 * 1.3 * ev.qd[1] ^ 2
        assert(math.abs(ev.energy_lost / T - (1 - ball_e ^ 2)) <= 1e-12, ("bounce %d loses %.15g of T"):format(k, ev.energy_lost / T))
        assert(math.abs(ev.qd[1] + v1 * ball_e ^ (k - 1)) <= 1e-9 * v1, "it lands at e^(k-1) v1")
      end
      -- Zeno: the last impact is plastic, at rest on the floor from then on
      local last = impacts[#impacts]
      local tinf = t1 * (1 + ball_e) / (1 - ball_e)
      assert(last.zeno and last.to == "closed", "the impacts accumulate: the last is plastic, the contact persists")
      assert(math.abs(last.zeno - tinf) <= 1e-6 and last.t < tinf and tinf - last.t <= 1e-4,
        ("the accumulation predicted at %.12g (closed form %.12g), the ball at rest from %.12g"):format(last.zeno, tinf, last.t))
      assert(#tr.contacts.zeno == 1)
      for i, t in ipairs(tr.t) do
        if t > tinf then
          assert(math.abs(tr.q[i][1] - R) <= 1e-12 and math.abs(tr.qd[i][1]) <= 1e-12, "at rest on the floor after t_inf")
          assert(math.abs(tr.lambda[i][1] - 1.3 * g) <= 1e-9, "held by its weight")
        end
      end
      assert(tr.status == "done" and tr.stats.steps < 500, ("a finite run (%d steps)"):format(tr.stats.steps))
    end)

    it(("a block on a slope stays, or stops after v0^2/(2g(sin a + mu cos a)) and sticks or slides back (%s)"):format(method), function()
      local m, alpha, mu, v0 = 1.7, 0.4, 0.3, 2.0   -- tan alpha = 0.4228
      for _, case in ipairs{ { mus = 0.5, sticks = true }, { mus = 0.35, sticks = false } } do
        local sys = nz.system{ name = "block", coords = { "x", "y" },   -- x up the slope, y off it
          T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2) end,
          V = function(t, q) return m * g * (q[1] * math.sin(alpha) + q[2] * math.cos(alpha)) end,
          constraints = { nz.unilateral(function(t, q) return q[2] end,
            { name = "slope", mu = mu, mu_s = case.mus, slip = function(t, q, qd) return qd[1] end }) } }
        -- at rest: it stays when mu_s > tan alpha
        local rest = sys:simulate{ q0 = { 0, 0 }, t1 = 2, dt = 0.1, method = method }
        if case.sticks then
          assert(#rest.events == 1 and rest.events[1].kind == "sticks", "it sticks from the start")
          assert(max_abs(rest.q[#rest.q]) <= 1e-12, "and stays")
          assert(math.abs(rest:column("T.slope")[5] - m * g * math.sin(alpha)) <= 1e-9, "held by m g sin a")
        else
          assert(rest.events[1].kind == "slips" and rest.events[1].to == "slip-", "it slides down from the start")
        end
        local tr = sys:simulate{ q0 = { 0, 0 }, qd0 = { v0, 0 }, t1 = 1.5, dt = 0.01, method = method }
        local dec = g * (math.sin(alpha) + mu * math.cos(alpha))
        local ts, xs = v0 / dec, v0 ^ 2 / (2 * dec)
        local stop = tr.events[2]
        assert(tr.events[1].kind == "slips" and tr.events[1].to == "slip+", "it slides up")
        assert(math.abs(stop.t - ts) <= 1e-9 and math.abs(stop.q[1] - xs) <= 1e-9,
          ("it stops at t = %.15g, x = %.15g (closed form %.15g, %.15g)"):format(stop.t, stop.q[1], ts, xs))
        local acc = g * (math.sin(alpha) - mu * math.cos(alpha))
        if case.sticks then
          assert(stop.kind == "sticks" and #tr.events == 2, "and sticks")
        else
          assert(stop.kind == "slips" and stop.to == "slip-", "and slides back")
        end
        for i, t in ipairs(tr.t) do
          local want = t <= ts and v0 * t - dec * t * t / 2 or case.sticks and xs or xs - acc * (t - ts) ^ 2 / 2
          assert(math.abs(tr.q[i][1] - want) <= 1e-9, ("x(%g) = %.15g, closed form %.15g"):format(t, tr.q[i][1], want))
        end
      end
    end)

    it(("a pendulum against a stop: energy over 100 impacts at e = 1, the amplitudes at e < 1 (%s)"):format(method), function()
      local l, th0 = 0.8, 1.1
      local function pendulum(e)
        return nz.system{ name = "pendulum and stop", coords = { "th" },
          T = function(t, q, qd) return 0.5 * l ^ 2 * qd[1] ^ 2 end,
          V = function(t, q) return -g * l * nz.cos(q[1]) end,
          constraints = { nz.unilateral(function(t, q) return l * nz.sin(q[1]) end, { e = e, name = "stop" }) } }
      end
      local quarter = nz.special.ellint_K(math.sin(th0 / 2)) * math.sqrt(l / g)
      local tr = pendulum(1):simulate{ q0 = { th0 }, t1 = 200 * quarter + 0.1, dt = 0.05, method = method,
        monitors = { energy = true } }
      local impacts = events_of(tr, "impact")
      assert(#impacts == 100, ("100 impacts (%d)"):format(#impacts))
      for k, ev in ipairs(impacts) do
        assert(math.abs(ev.t - (2 * k - 1) * quarter) <= 1e-8, ("impact %d at an odd quarter period"):format(k))
        assert(math.abs(ev.energy_lost) <= 1e-12 * l * l * ev.qd[1] ^ 2, "e = 1 loses nothing")
      end
      local E0, drift = tr.energy[1], 0
      for i = 1, #tr.energy do drift = math.max(drift, math.abs(tr.energy[i] - E0)) end
      assert(drift <= 1e-9 * math.abs(E0) * 100, ("T + V drifts by %.3g over 100 impacts (rtol 1e-10)"):format(drift))
      -- e < 1: 1 - cos th_k+1 = e^2 (1 - cos th_k), the amplitudes located by an event of the user's
      local e = 0.7
      local tr2 = pendulum(e):simulate{ q0 = { th0 }, t1 = 8, dt = 0.05, method = method,
        events = { { name = "apex", f = function(t, q, qd) return qd[1] end, direction = -1 } } }
      local c, n = 1 - math.cos(th0), 0
      for _, ev in ipairs(events_of(tr2, nil, "apex")) do
        c, n = c * e * e, n + 1
        assert(math.abs((1 - math.cos(ev.q[1])) / c - 1) <= 1e-9, ("apex %d: 1 - cos th = e^2k (1 - cos th0)"):format(n))
      end
      assert(n >= 6, "the amplitudes of several swings")
    end)
  end

  it("a double pendulum's tip hitting a wall: the impulse equations against a hand derivation", function()
    local m1, m2, l1, l2, d, e = 1.1, 0.7, 0.9, 0.6, 0.4, 0.55
    local dp = nz.system{ name = "double pendulum and wall", coords = { "th1", "th2" },
      T = function(t, q, qd)
        local x1d, y1d = l1 * nz.cos(q[1]) * qd[1], l1 * nz.sin(q[1]) * qd[1]
        local x2d, y2d = x1d + l2 * nz.cos(q[2]) * qd[2], y1d + l2 * nz.sin(q[2]) * qd[2]
        return 0.5 * m1 * (x1d ^ 2 + y1d ^ 2) + 0.5 * m2 * (x2d ^ 2 + y2d ^ 2)
      end,
      V = function(t, q) return -(m1 + m2) * g * l1 * nz.cos(q[1]) - m2 * g * l2 * nz.cos(q[2]) end,
      constraints = { nz.unilateral(function(t, q) return d - l1 * nz.sin(q[1]) - l2 * nz.sin(q[2]) end,
        { e = e, name = "wall" }) } }
    for _, method in ipairs{ "rk8pd", "taylor" } do
      local tr = dp:simulate{ q0 = { -0.4, -0.9 }, t1 = 1.2, dt = 0.01, method = method }
      local ev = events_of(tr, "impact")[1]
      assert(ev, "the tip hits the wall")
      local q, v = ev.q, ev.qd
      -- M q'' + ... = J^T lambda: M = [(m1 + m2) l1^2, m2 l1 l2 c; m2 l1 l2 c, m2 l2^2], J = -(l1 cos th1, l2 cos th2)
      local c = math.cos(q[1] - q[2])
      local a, b, dd = (m1 + m2) * l1 ^ 2, m2 * l1 * l2 * c, m2 * l2 ^ 2
      local det = a * dd - b * b
      local J = { -l1 * math.cos(q[1]), -l2 * math.cos(q[2]) }
      local MiJ = { (dd * J[1] - b * J[2]) / det, (-b * J[1] + a * J[2]) / det }
      local vn = J[1] * v[1] + J[2] * v[2]
      local P = -(1 + e) * vn / (J[1] * MiJ[1] + J[2] * MiJ[2])
      local want = { v[1] + MiJ[1] * P, v[2] + MiJ[2] * P }
      assert(vn < 0 and math.abs(ev.speed + vn) <= 1e-12, "it approaches")
      assert(max_abs{ ev.qd_after[1] - want[1], ev.qd_after[2] - want[2] } <= 1e-12 * max_abs(v),
        ("q'+ = q'- + M^-1 J^T P: (%.15g, %.15g), by hand (%.15g, %.15g)"):format(ev.qd_after[1], ev.qd_after[2],
          want[1], want[2]))
      assert(math.abs(ev.impulse - P) <= 1e-12 * math.abs(P), "the impulse P = -(1 + e) J q'- / (J M^-1 J^T)")
      local T0 = 0.5 * (a * v[1] ^ 2 + 2 * b * v[1] * v[2] + dd * v[2] ^ 2)
      local w = ev.qd_after
      local T1 = 0.5 * (a * w[1] ^ 2 + 2 * b * w[1] * w[2] + dd * w[2] ^ 2)
      assert(math.abs(ev.energy_lost - (T0 - T1)) <= 1e-12 * T0, "the kinetic energy lost")
      assert(math.abs((1 - e * e) * 0.5 * vn * vn / (J[1] * MiJ[1] + J[2] * MiJ[2]) - (T0 - T1)) <= 1e-12 * T0,
        "which is (1 - e^2) v^2 / (2 J M^-1 J^T)")
    end
  end)

  it("equalities beside a contact: a Cartesian pendulum (x^2 + z^2 = l^2) against a wall hits at odd quarter periods", function()
    local l, th0 = 0.8, 1.1
    local cart = nz.system{ name = "Cartesian pendulum and wall", coords = { "x", "z" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end,
      V = function(t, q) return g * q[2] end,
      constraints = { function(t, q) return q[1] ^ 2 + q[2] ^ 2 - l * l end,
        nz.unilateral(function(t, q) return q[1] end, { e = 1, name = "wall" }) } }
    local quarter = nz.special.ellint_K(math.sin(th0 / 2)) * math.sqrt(l / g)
    for _, method in ipairs{ "rk8pd", "taylor" } do
      local tr = cart:simulate{ q0 = { l * math.sin(th0), -l * math.cos(th0) }, t1 = 20 * quarter + 0.05, dt = 0.02,
        method = method }
      local impacts = events_of(tr, "impact")
      assert(#impacts == 10, ("10 impacts (%d)"):format(#impacts))
      for k, ev in ipairs(impacts) do
        assert(math.abs(ev.t - (2 * k - 1) * quarter) <= 1e-8, ("%s: impact %d at %.12g, odd quarter period %.12g"):format(
          method, k, ev.t, (2 * k - 1) * quarter))
        -- the impulse keeps the rod: the velocity stays tangent, reversed
        local v, w = ev.qd, ev.qd_after
        assert(math.abs(ev.q[1] * w[1] + ev.q[2] * w[2]) <= 1e-10 and math.abs(w[1] + v[1]) <= 1e-9 and math.abs(w[2] + v[2]) <= 1e-9,
          "q'+ = -q'- along the circle")
      end
      assert(max_abs(tr.violation) <= 1e-8, "on the circle throughout")
    end
  end)

  it("Newton's cradle under the simultaneous Newton law: v+ = (-1/3, 2/3, 2/3) v, an impulse at each contact (docs/theory.md §13)", function()
    local r, v = 0.1, 1.3
    local cradle = nz.system{ name = "cradle", coords = { "x1", "x2", "x3" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end,
      constraints = { nz.unilateral(function(t, q) return q[2] - q[1] - 2 * r end, { e = 1, name = "12" }),
        nz.unilateral(function(t, q) return q[3] - q[2] - 2 * r end, { e = 1, name = "23" }) } }
    for _, method in ipairs{ "rk8pd", "taylor" } do
      local tr = cradle:simulate{ q0 = { -0.5, 0, 2 * r }, qd0 = { v, 0, 0 }, t1 = 1, dt = 0.01, method = method }
      local impacts = events_of(tr, "impact")
      -- one impact, an event per contact that takes an impulse: the first pair's (it closed at v), and the
      -- second's (it touched at rest and passed the impulse on)
      assert(#impacts == 2 and impacts[1].name == "12" and impacts[2].name == "23" and impacts[1].t == impacts[2].t,
        "one impact, both contacts' impulses")
      assert(math.abs(impacts[1].impulse - 4 * v / 3) <= 1e-13 and math.abs(impacts[2].impulse - 2 * v / 3) <= 1e-13,
        ("impulses 4/3 m v and 2/3 m v (%.17g, %.17g)"):format(impacts[1].impulse, impacts[2].impulse))
      assert(impacts[1].speed == v and impacts[2].speed == 0, "the first closed at v, the second touched at rest")
      local w = impacts[1].qd_after
      assert(max_abs{ w[1] + v / 3, w[2] - 2 * v / 3, w[3] - 2 * v / 3 } <= 1e-13, "(-1/3, 2/3, 2/3) v")
      assert(math.abs(impacts[1].energy_lost) <= 1e-13 and impacts[2].energy_lost == nil, "e = 1: no energy lost, said once")
      assert(tostring(tr):find("contacts (12, 23): 1 impact (2 impulses), kinetic energy lost in impacts", 1, true), tostring(tr))
    end
  end)

  it("a billiard ball launched without spin slips, then rolls at 5/7 of its speed from t = 2 v0 / (7 mu g)", function()
    -- a solid sphere of radius R on a floor: T = (x'^2 + y'^2)/2 + (2/5) R^2 phi'^2 / 2, slip velocity x' - R phi';
    -- while it slips x'' = -mu g and R phi'' = (5/2) mu g, so the slip x' - R phi' = v0 - (7/2) mu g t vanishes at
    -- t = 2 v0 / (7 mu g), where x' = 5 v0 / 7; then it rolls (mu_s holds it: no force is needed)
    local R, mu, v0 = 0.3, 0.2, 3.0
    local ball = nz.system{ name = "billiard ball", coords = { "x", "y", "phi" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) + 0.5 * 0.4 * R ^ 2 * qd[3] ^ 2 end,
      V = function(t, q) return g * q[2] end,
      constraints = { nz.unilateral(function(t, q) return q[2] - R end,
        { name = "floor", mu = mu, mu_s = 0.25, slip = function(t, q, qd) return qd[1] - R * qd[3] end }) } }
    local t_roll = 2 * v0 / (7 * mu * g)
    for _, method in ipairs{ "rk8pd", "taylor" } do
      local tr = ball:simulate{ q0 = { 0, R, 0 }, qd0 = { v0, 0, 0 }, t1 = 1, dt = 0.01, method = method }
      local sticks = events_of(tr, "sticks")
      assert(#sticks == 1 and #events_of(tr, "slips") == 1, method .. ": it slips from the start, then rolls once")
      assert(math.abs(sticks[1].t - t_roll) <= 1e-9, ("%s: rolls from t = %.15g, closed form %.15g"):format(method,
        sticks[1].t, t_roll))
      assert(math.abs(sticks[1].qd[1] - 5 * v0 / 7) <= 1e-9, ("%s: x' = %.15g at rolling, closed form 5 v0/7"):format(method,
        sticks[1].qd[1]))
      local n = #tr.t
      assert(math.abs(tr.qd[n][1] - 5 * v0 / 7) <= 1e-9 and math.abs(tr.qd[n][1] - R * tr.qd[n][3]) <= 1e-9,
        method .. ": it keeps rolling at 5 v0/7")
    end
  end)

  it("a ball dropped on a vibrating table: Newton's law on the velocity relative to the table", function()
    -- the table at A sin(w t): the impact at 0.5 - g t^2/2 = A sin(w t) (Newton's method here), and after it
    -- v+ - u = -e (v- - u) with u = A w cos(w t), the table's velocity
    local A, w, e = 0.01, 20, 0.7
    local ball = nz.system{ name = "ball on a table", coords = { "y" },
      T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end, V = function(t, q) return g * q[1] end,
      constraints = { nz.unilateral(function(t, q) return q[1] - A * nz.sin(w * t) end, { e = e, name = "table" }) } }
    local t = math.sqrt(1 / g)
    for _ = 1, 50 do t = t - (0.5 - g * t * t / 2 - A * math.sin(w * t)) / (-g * t - A * w * math.cos(w * t)) end
    local u = A * w * math.cos(w * t)
    for _, method in ipairs{ "rk8pd", "taylor", "rkf45" } do
      local tr = ball:simulate{ q0 = { 0.5 }, t1 = 0.4, dt = 0.01, method = method }
      local ev = events_of(tr, "impact")[1]
      assert(ev and math.abs(ev.t - t) <= 1e-9, ("%s: the impact at %.15g, closed form %.15g"):format(method, ev and ev.t, t))
      assert(math.abs(ev.qd_after[1] - (u - e * (-g * t - u))) <= 1e-8,
        ("%s: v+ = %.12g, Newton's law on the relative velocity %.12g"):format(method, ev.qd_after[1], u - e * (-g * t - u)))
    end
  end)

  it("a block on a moving belt sticks and slips at the closed-form times, with either method", function()
    local m, k, V, mu, mus = 1.2, 30.0, 0.4, 0.25, 0.45
    local belt = nz.scene{ name = "belt", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2) end,
      V = function(t, q) return 0.5 * k * q[1] ^ 2 + m * g * q[2] end,
      effects = { E.contact{ name = "belt", gap = function(t, q) return q[2] end },
        E.friction{ contact = "belt", mu = mu, mu_s = mus, slip = function(t, q, qd) return qd[1] - V end } } }
    local w = math.sqrt(k / m)
    local xb, xe, A = mus * m * g / k, mu * m * g / k, (mus - mu) * m * g / k
    local delta = math.atan(w * A, V)
    local slip, stick = (2 * math.pi - 2 * delta) / w, 2 * A / V
    for _, method in ipairs{ "rk8pd", "taylor" } do
      local tr = belt:simulate{ q0 = { 0, 0 }, qd0 = { V, 0 }, t1 = xb / V + 3 * (slip + stick), dt = 0.01, method = method }
      local slips, sticks = events_of(tr, "slips"), events_of(tr, "sticks")
      assert(#slips == 3 and #sticks == 4, ("3 slips and 4 sticks (%d, %d)"):format(#slips, #sticks))
      for c = 1, 3 do
        local tb = xb / V + (c - 1) * (slip + stick)
        assert(math.abs(slips[c].t - tb) <= 1e-9 and slips[c].to == "slip-", ("slip %d at %.15g"):format(c, tb))
        assert(math.abs(sticks[c + 1].t - (tb + slip)) <= 1e-9, ("stick %d at %.15g"):format(c, tb + slip))
        assert(math.abs(sticks[c + 1].q[1] - (xe - A)) <= 1e-9, "re-sticking at x = x_e - A")
      end
    end
  end)
end)

describe("every method", function()
  it("each GSL stepper and taylor bring a bouncing ball to rest at the closed-form bounce times", function()
    local R, hh = 0.1, 1.0
    local t1 = math.sqrt(2 * hh / g)
    local methods = { "taylor" }
    for _, m in ipairs(nz.methods) do if m.name ~= "rk1imp" then methods[#methods + 1] = m.name end end
    for _, method in ipairs(methods) do
      local tr = ball(ball_e, R):simulate{ q0 = { R + hh }, t1 = 5, dt = 0.01, method = method }
      local impacts = events_of(tr, "impact")
      -- located: the gap there is zero to the event tolerance times the speed, for the bounces the run
      -- resolves (the first 40 rise above 2e-8 m; near its resolution of the gap, rtol |y| + atol = 1.1e-11 m,
      -- a step's end may cross where the step integrated again does not, and the end is the event)
      for k = 1, 40 do
        local ev = impacts[k]
        assert(math.abs(ev.gap) <= 1e-12 * math.max(1, ev.t) * ev.speed + 1e-15,
          ("%s: bounce %d located at a gap of %.3g (speed %.3g)"):format(method, k, ev.gap, ev.speed))
      end
      -- each flight from the state the last bounce left lasts 2 v+/g, to the integrator's error over it:
      -- a landing off by less than the run's resolution of the gap (rtol |y| + atol = 1.1e-11 m), msadams
      -- included: it restarts at order 1 after a bounce, and the first steps of a restart are held to a
      -- thousandth of the tolerance (src/ode/ode.c; without, it landed 4e-11 m off).  msbdf's flights
      -- stay at orders 1 and 2, ~60 steps each, and their errors add up to 1.3e-9 m (each step within the
      -- tolerance: its 1 m fall from rest ends 8.6e-10 m off at rtol 1e-10)
      local bound = method == "msbdf" and 2e-9 or 1.1e-11
      for k = 2, 40 do
        local v = impacts[k - 1].qd_after[1]
        local off = (impacts[k].t - impacts[k - 1].t - 2 * v / g) * v
        assert(math.abs(off) <= bound,
          ("%s: flight %d lands %.3g m off (2 v+/g = %.17g)"):format(method, k, off, 2 * v / g))
      end
      -- and at the closed form's times to 1e-9 (msadams was 1.4e-8 off by the 20th bounce while its
      -- restarts went unchecked); msbdf's landings, off by its own error on the flights, move the next
      -- bounces' speeds: its 20th bounce is 1.1e-7 off
      local tol = method == "msbdf" and 5e-7 or 1e-9
      for k = 1, 20 do
        local tk = t1 * (1 + 2 * ball_e * (1 - ball_e ^ (k - 1)) / (1 - ball_e))
        assert(math.abs(impacts[k].t - tk) <= tol, ("%s: bounce %d off by %.3g"):format(method, k, impacts[k].t - tk))
      end
      -- at rest after finitely many: a rebound the run cannot resolve is plastic (msadams made up bounces
      -- of 1e-15 m for ever without it: 2,994,981 impacts in 5 s)
      assert(#impacts < 70, ("%s: %d impacts"):format(method, #impacts))
      assert(impacts[#impacts].zeno and math.abs(tr.q[#tr.q][1] - R) <= 1e-12, method .. ": at rest on the floor")
    end
  end)
end)

describe("Painleve's paradox", function()
  -- a uniform rod of length 2l leaning at th on a rough floor, its lower end
  -- sliding: J M^-1 W^T = (1 + 3 cos^2 th + 3 mu s sin th cos th)/m, negative
  -- for mu > 4/3 at tan th = 2 when the end slides away from the rod (s = -1)
  local function rod(mu)
    local l, m = 0.5, 2.0
    return nz.system{ name = "rod", coords = { "x", "y", "th" },
      T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2) + 0.5 * m * l * l / 3 * qd[3] ^ 2 end,
      V = function(t, q) return m * g * q[2] end,
      constraints = { nz.unilateral(function(t, q) return q[2] - l * nz.sin(q[3]) end,
        { name = "end", mu = mu, slip = function(t, q, qd) return qd[1] + l * nz.sin(q[3]) * qd[3] end }) } }, l
  end
  it("no consistent mode: stopped with the contact, the state and the effective mass", function()
    local sys, l = rod(1.5)
    local th = math.atan(2)
    local msg = errmsg(sys.simulate, sys, { q0 = { 0, l * math.sin(th), th }, qd0 = { -1, 0, 0 }, t1 = 1 })
    assert(msg:find("contact 'end': Painleve's paradox at t = 0, q = {0, ", 1, true), msg)
    assert(msg:find("(J - mu s D)^T is -0.125", 1, true) and msg:find("times the frictionless one, not positive", 1, true), msg)
    assert(msg:find("no contact mode is consistent", 1, true) and msg:find("lower mu", 1, true), msg)
    assert(msg:find("^[^:]*contact_spec.lua:%d+: "), "at the caller's line: " .. msg)
    -- mu = 1 < 4/3: it slides
    local ok = rod(1.0):simulate{ q0 = { 0, l * math.sin(th), th }, qd0 = { -1, 0, 0 }, t1 = 0.1 }
    assert(ok.events[1].to == "slip-")
  end)
end)

describe("scenes", function()
  it("nz.effects.contact and friction give what nz.unilateral gives; at with a plane or a sphere, tangent", function()
    local alpha, mu, mus, v0, m = 0.4, 0.3, 0.5, 2.0, 1.5
    local function pos(t, q) return { q[1] * math.cos(alpha) - q[2] * math.sin(alpha), 0, q[1] * math.sin(alpha) + q[2] * math.cos(alpha) } end
    local bodies = { { name = "block", mass = m, pos = pos } }
    local a = nz.scene{ name = "block", coords = { "x", "y" }, bodies = bodies,
      effects = { E.gravity{}, E.contact{ name = "slope", gap = function(t, q) return q[2] end },
        E.friction{ contact = "slope", mu = mu, mu_s = mus, slip = function(t, q, qd) return qd[1] end } } }
    local n = { -math.sin(alpha), 0, math.cos(alpha) }
    local b = nz.scene{ name = "block", coords = { "x", "y" }, bodies = bodies,
      effects = { E.gravity{}, E.contact{ name = "slope", at = "block", plane = { point = { 0, 0, 0 }, normal = n } },
        E.friction{ contact = "slope", mu = mu, mu_s = mus, tangent = { math.cos(alpha), 0, math.sin(alpha) } } } }
    local ta = a:simulate{ q0 = { 0, 0 }, qd0 = { v0, 0 }, t1 = 1, dt = 0.05 }
    local tb = b:simulate{ q0 = { 0, 0 }, qd0 = { v0, 0 }, t1 = 1, dt = 0.05 }
    assert(#ta.events == 2 and #tb.events == 2 and math.abs(ta.events[2].t - tb.events[2].t) <= 1e-12)
    for i = 1, #ta.t do assert(max_abs{ ta.q[i][1] - tb.q[i][1], ta.q[i][2] - tb.q[i][2] } <= 1e-12) end
    assert(tostring(a):find("1 unilateral contact (slope), 1 with friction, effects gravity, contact, friction", 1, true),
      tostring(a))
    -- a point outside a sphere
    local R = 1.3
    local s = nz.scene{ name = "sphere", coords = { "x", "z" },
      bodies = { { name = "p", mass = 1, pos = function(t, q) return { q[1], 0, q[2] } end } },
      effects = { E.gravity{}, E.contact{ name = "sphere", at = "p", sphere = { center = { 0, 0, 0 }, radius = R } } } }
    local tr = s:simulate{ q0 = { R * math.sin(0.3), R * math.cos(0.3) }, t1 = 1, dt = 0.05 }
    local ev = events_of(tr, "opens")[1]
    assert(math.abs(math.cos(math.atan(ev.q[1], ev.q[2])) - 2 / 3 * math.cos(0.3)) <= 1e-9, "leaves at (2/3) cos th0")
  end)

  it("a scene or system without contacts has none: nothing computed for them", function()
    local sys = nz.system{ name = "free", coords = { "y" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end }
    assert(sys.contact == nil)
    local tr = sys:simulate{ q0 = { 1 }, qd0 = { 0.5 }, t1 = 1 }
    assert(tr.contacts == nil and tr.lambda_names == nil and not tostring(tr):find("contacts"))
  end)
end)

describe("what the trajectory shows", function()
  local R, hh = 0.1, 0.5
  local tr = ball(0.5, R):simulate{ q0 = { R + hh }, t1 = 2, dt = 0.01 }
  it("print(tr) counts the impacts, the energy lost, the Zeno rest and the final mode", function()
    local text = tostring(tr)
    -- Zeno: the first bounce slower than 1e-6 of the first, e^(k-1) <= 1e-6, is plastic
    local n = 1 + math.ceil(math.log(1e-6) / math.log(0.5))
    assert(#events_of(tr, "impact") == n, ("%d impacts"):format(n))
    assert(text:find(("contacts (floor): %d impacts (%d impulses), kinetic energy lost in impacts "):format(n, n), 1, true), text)
    assert(text:find("Zeno: 'floor' came to rest at t = ", 1, true), text)
    assert(text:find("final contact mode: floor closed", 1, true), text)
  end)
  it("tr.events: each impact with the state before and after, the impulse and the energy lost", function()
    local ev = tr.events[1]
    assert(ev.name == "floor" and ev.kind == "impact" and ev.from == "open" and ev.to == "open")
    assert(ev.qd[1] < 0 and math.abs(ev.qd_after[1] + 0.5 * ev.qd[1]) <= 1e-12)
    assert(math.abs(ev.impulse - 1.3 * 1.5 * ev.speed) <= 1e-12 and ev.energy_lost > 0)
  end)
  it("the contact force is a column (N.floor), in the CSV, and tr:plot marks the events", function()
    local N = tr:column("N.floor")
    assert(N[1] == 0 and math.abs(N[#N] - 1.3 * g) <= 1e-9)
    local csv = tr:csv()
    assert(csv:match("^t,y,y',y'',N%.floor"), csv:sub(1, 40))
    local msg = errmsg(tr.column, tr, "lambda1")
    assert(msg:find("quantities: t, y, y', y'', N.floor", 1, true), msg)
    local file = os.tmpname() .. ".svg"
    if os.execute("command -v gnuplot >/dev/null 2>&1") then
      tr:plot{ y = { "y" }, file = file }
      local svg = h.slurp(file)
      os.remove(file)
      assert(svg and svg:find("contact events", 1, true), "the events are marked and named in the key")
    end
  end)
  it("tr:residuals and tr:consistency refuse a run with contacts, and sys:report says why it shows no defect", function()
    for _, f in ipairs{ "residuals", "consistency" } do
      local msg = errmsg(tr[f], tr, 1)
      assert(msg:find(("tr:%s: the run of 'ball' has unilateral contacts: its motion is smooth only between its "):format(f),
        1, true) and msg:find("contact_spec.lua:%d+: "), msg)
    end
    local printed, real = {}, _G.print
    _G.print = function(...)
      local parts = { ... }
      for i = 1, select("#", ...) do parts[i] = tostring(parts[i]) end
      printed[#printed + 1] = table.concat(parts, " ")
    end
    local b = ball(0.5, R)
    local ok, err = pcall(b.report, b, { q = { 0.3 }, simulate = { t1 = 0.5 }, plot = false })
    _G.print = real
    assert(ok, err)
    assert(table.concat(printed, "\n"):find("defect of the motion: not measured across contact events", 1, true))
  end)
  it("tr:animate draws the contact point while the contact is held", function()
    local sys = nz.scene{ name = "ball", coords = { "y" },
      bodies = { { name = "b", mass = 1, pos = function(t, q) return { 0, q[1], 0 } end } },
      effects = { E.gravity{ g = { 0, -g, 0 } }, E.contact{ name = "floor", at = "b", plane = { normal = { 0, 1, 0 } } } } }
    local tr2 = sys:simulate{ q0 = { 0.2 }, t1 = 0.5, dt = 0.01 }
    local draw = require("nz.motion.contact_run").drawing(tr2, function() return { points = { { 0, 0 } } } end, { 1, 2 })
    assert(#draw(0.1, { 0.15 }).points == 1, "in flight: the body alone")
    assert(#draw(0.45, { 0 }).points == 2, "resting: the contact point too")
  end)
end)

describe("contacts in the formulas", function()
  local b = ball(0.8, 0.1)
  it("show{} writes the contact's force into the equations, its complementarity and Newton's law (text and LaTeX)", function()
    local text = tostring(b:show{})
    assert(text:find("y:  1.3 y'' + 12.753", 1, true) and text:find(" = N_floor", 1, true), text)
    assert(text:find("floor:  g_floor = y - 0.1 >= 0,  N_floor >= 0,  g_floor N_floor = 0", 1, true), text)
    assert(text:find("impact: Newton's law v_n+ = -e v_n- (e = 0.8), with every touching contact at once", 1, true), text)
    local tex = tostring(b:show{ tex = true })
    assert(tex:find("1.3 \\, \\ddot{y} + 12.753", 1, true) and tex:find("&= N_{\\mathrm{floor}}", 1, true), tex)
    assert(tex:find("g_{\\mathrm{floor}} = y - 0.1 &\\ge 0, \\quad N_{\\mathrm{floor}} \\ge 0", 1, true), tex)
    assert(tex:find("v_{n}^{+} &= -e \\, v_{n}^{-} \\quad (e = 0.8", 1, true), tex)
    -- the residuals, the contact force among the multipliers: zero at rest under m g
    local f = load(b:show{ lua = true })()
    assert(math.abs(f(0, { 0.1 }, { 0 }, { 0 }, { 1.3 * g })[1]) <= 1e-12, "M q'' + h - N = 0 at rest")
  end)

  it("show{} states a friction law: the planar one on its slip velocity, the isotropic cone on two", function()
    local R = 0.3
    local bb = nz.system{ name = "billiard ball", coords = { "x", "y", "phi" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) + 0.5 * 0.4 * R ^ 2 * qd[3] ^ 2 end,
      V = function(t, q) return g * q[2] end,
      constraints = { nz.unilateral(function(t, q) return q[2] - R end,
        { name = "floor", mu = 0.2, mu_s = 0.25, slip = function(t, q, qd) return qd[1] - R * qd[3] end }) } }
    local text = tostring(bb:show{})
    assert(text:find("x  :  x'' = T_floor", 1, true) and text:find("phi:  0.036 phi'' = -0.3 T_floor", 1, true), text)
    assert(text:find("friction: |T_floor| <= mu_s N_floor while it sticks (v_t = 0), T_floor = -mu N_floor v_t/|v_t| "
      .. "while it slides, v_t = x' - 0.3 phi'  (mu = 0.2, mu_s = 0.25)", 1, true), text)
    local puck = nz.system{ name = "puck", coords = { "x", "y", "z" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end, V = function(t, q) return g * q[3] end,
      constraints = { nz.unilateral(function(t, q) return q[3] end,
        { name = "ice", mu = 0.3, slip = { function(t, q, qd) return qd[1] end, function(t, q, qd) return qd[2] end } }) } }
    text = tostring(puck:show{})
    assert(text:find("x:  x'' = T1_ice", 1, true) and text:find("y:  y'' = T2_ice", 1, true), text)
    assert(text:find("(T1_ice, T2_ice) = -mu N_ice v_t/|v_t| while it slides, v_t = (x', y')  (mu = 0.3, mu_s = 0.3, an "
      .. "isotropic cone)", 1, true), text)
    assert(tostring(puck:show{ tex = true }):find("\\lvert \\mathbf{T}_{\\mathrm{ice}} \\rvert &\\le \\mu_{s} N_{\\mathrm{ice}}", 1, true))
  end)

  it("rule() counts the contacts and says how they enter", function()
    local n, text = b:rule()
    assert(n == 1 and text:find("The system also has 1 unilateral contact (floor): each enters by its force on its gap's "
      .. "gradient (N >= 0, gap >= 0, their product 0), held as a constraint of order 0 while it pushes", 1, true), text)
  end)

  it("export refuses a system with contacts, and with smooth = true writes the smooth part and says so", function()
    local msg = errmsg(b.export, b, { lang = "python" })
    assert(msg:find("sys:export 'ball': 'ball' has 1 unilateral contact (floor): the exported code integrates smooth "
      .. "equations, without the contacts' events, impacts and forces", 1, true) and msg:find("export{smooth = true}", 1, true), msg)
    assert(msg:find("contact_spec.lua:%d+:"), msg)
    local code = b:export{ lang = "python", smooth = true }
    assert(code:find("^# the smooth part of 'ball' only: its unilateral contacts %(floor%) are left out"), code:sub(1, 120))
  end)
end)

describe("errors", function()
  local gap = function(t, q) return q[1] end
  it("a restitution outside [0, 1], a negative friction coefficient, mu_s < mu, friction without a slip", function()
    local cases = {
      { { e = 1.2 }, "nz.unilateral: restitution 'e' must be a number in [0, 1] (0 plastic: the contact stays closed; 1 elastic), got 1.2" },
      { { e = -0.1 }, "restitution 'e' must be a number in [0, 1]" },
      { { mu = -0.3, slip = gap }, "friction coefficient 'mu' must be a number >= 0, got -0.3" },
      { { mu = 0.4, mu_s = 0.3, slip = gap }, "static friction coefficient 'mu_s' must be a number >= mu = 0.4" },
      { { mu = 0.4 }, "friction (mu = 0.4) needs 'slip', the slip velocity" },
      { { slip = 3 }, "'slip' must be a function(t, q, qd, params)" },
      { { name = 3 }, "'name' must be a string" },
      { { restitution = 1 }, "nz.unilateral: unknown option 'restitution'" },
    }
    for _, c in ipairs(cases) do
      local msg = errmsg(function() local u = nz.unilateral(gap, c[1]); return u end)
      assert(msg:find(c[2], 1, true), msg)
      assert(msg:find("contact_spec.lua:%d+: "), "at the caller's line: " .. msg)
    end
    assert(errmsg(function() return nz.unilateral(3) end):find("the gap must be a function(t, q, params) >= 0", 1, true))
    local msg = errmsg(function() local u = nz.unilateral(gap, 3); return u end)
    assert(msg:find("options {e =, mu =, mu_s =, slip =, name =, at =} expected", 1, true) and msg:find("contact_spec.lua:%d+: "), msg)
  end)
  it("effects: e above 1, a negative mu, a friction naming no contact, a gap missing", function()
    local function scene(effects)
      return nz.scene{ name = "s", coords = { "y" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end, effects = effects }
    end
    assert(errmsg(E.contact, { gap = gap, e = 1.5 }):find("effect 'contact': parameter 'e' must be at most 1", 1, true))
    assert(errmsg(E.friction, { contact = "a", mu = -1 }):find("effect 'friction': parameter 'mu' must not be negative", 1, true))
    local msg = errmsg(scene, { E.contact{ name = "floor", gap = gap }, E.friction{ contact = "flor", mu = 0.3, slip = gap } })
    assert(msg:find("effect 'friction': parameter 'contact' names no contact 'flor' (contacts: floor)", 1, true), msg)
    msg = errmsg(scene, { E.contact{ name = "floor" } })
    assert(msg:find("effect 'contact': parameter 'gap' is missing", 1, true), msg)
    msg = errmsg(scene, { E.contact{ name = "floor", gap = gap }, E.friction{ contact = "floor", mu = 0.3 } })
    assert(msg:find("parameter 'slip' is missing", 1, true), msg)
    msg = errmsg(scene, { E.contact{ name = "floor", gap = gap }, E.friction{ contact = "floor", mu = 0.3, mu_s = 0.1, slip = gap } })
    assert(msg:find("parameter 'mu_s' must be >= mu = 0.3", 1, true), msg)
  end)
  it("a unilateral constraint violated at the start, a gap without a gradient where it touches", function()
    local sys = ball(0.5, 0.1)
    local msg = errmsg(sys.simulate, sys, { q0 = { 0.05 }, t1 = 1 })
    assert(msg:find("contact 'floor' (a unilateral constraint, gap >= 0) is violated at the start: its gap is -0.05 "
      .. "at t = 0, q = {0.05}: start with every gap at or above 0", 1, true), msg)
    assert(msg:find("contact_spec.lua:%d+: "), msg)
    local flat = nz.system{ name = "flat", coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      V = function(t, q) return q[1] end,
      constraints = { nz.unilateral(function(t, q) return q[1] ^ 2 end, { name = "square" }) } }
    msg = errmsg(flat.simulate, flat, { q0 = { 0 }, t1 = 1 })
    assert(msg:find("contact 'square': its gap's gradient dPhi/dq vanishes where it touches at t = 0, q = {0}", 1, true), msg)
    assert(msg:find("write the gap as a distance whose gradient does not vanish", 1, true), msg)
  end)
  it("a gap that raises or is not finite at the sample states is said at the user's line, as the contact", function()
    local cases = {
      { function(t, q) error("no floor here") end, "raised an error at t = " },
      { function(t, q) return q[1] * (0 / 0) end, "NaN" },
      { function(t, q) return q[1] + 1 / 0 end, "inf" },
      { function(t, q) if q[1] then return nil end end, "returned nil" },
      { function(t, q) return "floor" end, "returned a string" },
    }
    for i, c in ipairs(cases) do
      local line = debug.getinfo(c[1], "S").linedefined
      local msg = errmsg(function()
        local s = nz.system{ name = "ball", coords = { "y" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
          V = function(t, q) return g * q[1] end, constraints = { nz.unilateral(c[1], { name = "floor", e = 0.5 }) } }
        return s:simulate{ q0 = { 1 }, t1 = 1 }
      end)
      assert(not msg:find("model/contact.lua", 1, true), "case " .. i .. " is said at the library's line: " .. msg)
      assert(msg:find("contact_spec.lua:" .. line .. ": ", 1, true), "case " .. i .. " not at the gap's line " .. line .. ": " .. msg)
      assert(msg:find("contact 'floor' (its gap)", 1, true), "case " .. i .. " does not name the contact: " .. msg)
      assert(msg:find(c[2], 1, true), "case " .. i .. ": " .. msg)
    end
  end)
  it("a gap whose gradient vanishes where it touches (q^3, a triple root) is refused as q^2 at 0 is", function()
    local cube = nz.system{ name = "cube", coords = { "y" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      V = function(t, q) return g * q[1] end,
      constraints = { nz.unilateral(function(t, q) return q[1] ^ 3 end, { name = "cubic", e = 0.5 }) } }
    local msg = errmsg(cube.simulate, cube, { q0 = { 1 }, t1 = 2 })
    assert(msg:find("contact 'cubic': its gap's gradient dPhi/dq vanishes where it touches at t = 0.45", 1, true), msg)
    assert(msg:find("of the largest it had in the run", 1, true), msg)
    -- and the same gap as a distance, q, is located to rounding: the impact at sqrt(2/g)
    local ok = nz.system{ name = "line", coords = { "y" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      V = function(t, q) return g * q[1] end,
      constraints = { nz.unilateral(function(t, q) return q[1] end, { name = "floor", e = 0.5 }) } }
    local tr = ok:simulate{ q0 = { 1 }, t1 = 0.5 }
    local hit = events_of(tr, "impact")[1]
    assert(hit and math.abs(hit.t - math.sqrt(2 / g)) < 1e-10, tostring(hit and hit.t))
  end)
  it("what contacts do not take: project, baumgarte, the work monitor, a constraint of order 2, two names alike", function()
    local sys = ball(0.5, 0.1)
    for _, c in ipairs{ { { project = true }, "'project' is not available with unilateral contacts" },
      { { baumgarte = 1 }, "'baumgarte' is not available with unilateral contacts" },
      { { monitors = { work = true } }, "the 'work' monitor is not available with unilateral contacts: each impact's "
        .. "loss of kinetic energy is in tr.events" } } do
      local opts = { q0 = { 1 }, t1 = 1 }
      for k, v in pairs(c[1]) do opts[k] = v end
      local msg = errmsg(sys.simulate, sys, opts)
      assert(msg:find(c[2], 1, true), msg)
    end
    local two = nz.system{ name = "two", coords = { "x", "y" }, T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end,
      constraints = { function(t, q, qd, qdd) return qdd[1] - qdd[2] end, nz.unilateral(gap, { name = "a" }) } }
    local msg = errmsg(two.simulate, two, { q0 = { 1, 0 }, t1 = 1 })
    assert(msg:find("constraint 1 is of order 2: beside unilateral contacts the constraints must be holonomic or linear "
      .. "in the velocities", 1, true), msg)
    msg = errmsg(nz.system, { name = "dup", coords = { "x" }, T = function(t, q, qd) return qd[1] ^ 2 end,
      constraints = { nz.unilateral(gap, { name = "a" }), nz.unilateral(gap, { name = "a" }) } })
    assert(msg:find("nz.system 'dup': two contacts are named 'a'", 1, true), msg)
  end)
  it("a contact dependent on a constraint: the constraint takes the force, the contact keeps what is left", function()
    -- a drive holds x = 0.3 against a push of 2.5 while the floor's friction would hold it too: the
    -- same row twice; the constraint's multiplier is -2.5 (it takes the push), the friction 0
    local block = nz.system{ name = "driven block", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end, V = function(t, q) return g * q[2] - 2.5 * q[1] end,
      constraints = { function(t, q) return q[1] - 0.3 end,
        nz.unilateral(function(t, q) return q[2] end, { name = "floor", mu = 0.5, slip = function(t, q, qd) return qd[1] end }) } }
    local tr = block:simulate{ q0 = { 0.3, 0 }, t1 = 1 }
    local L = tr.lambda[#tr.lambda]
    assert(math.abs(L[1] + 2.5) <= 1e-12 and math.abs(L[2] - g) <= 1e-12 and math.abs(L[3]) <= 1e-12,
      ("the drive -2.5, the floor g and no friction (%.17g, %.17g, %.17g)"):format(L[1], L[2], L[3]))
    assert(max_abs(tr.q[#tr.q]) - 0.3 <= 1e-12 and tr.contacts.final[1] == "stick")
  end)
  it("a singular mass matrix in a contact mode", function()
    local bad = nz.system{ name = "bad mass", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * q[1] ^ 2 * qd[1] ^ 2 + 0.5 * qd[2] ^ 2 end, V = function(t, q) return g * q[2] end,
      constraints = { nz.unilateral(function(t, q) return q[2] end, { name = "floor" }) } }
    local msg = errmsg(bad.simulate, bad, { q0 = { 0, 0 }, t1 = 1 })
    assert(msg:find("the mass matrix M is singular or not positive definite at t = 0, q = {0, 0}", 1, true), msg)
  end)
  it("a mode that keeps changing at one time stops the run", function()
    local Run = require("nz.motion.contact_run").Run
    local run = setmetatable({ same = 0, sys = { name = "s" }, names = { "a" } }, Run)
    local msg = errmsg(function() for _ = 1, 60 do run:guard(1.5, 1) end end)
    assert(msg:find("simulate 's': the contacts' mode changed 50 times at t = 1.5 without the motion going on "
      .. "(the last event: contact 'a')", 1, true), msg)
  end)
end)

describe("contacts beside the user's events", function()
  -- A ball dropped from 1 onto a floor at 0.1 (e = 0.5) passes y = 0.5 at
  -- sqrt(2 (1 - 0.5) / g) and hits the floor at sqrt(2 (1 - 0.1) / g); its
  -- bounce (apex 0.1 + 0.25 * 0.9) stays below 0.5.  The event function
  -- branches in Lua, so it is called in Lua by the loop in C.
  for _, method in ipairs{ "rk8pd", "msadams" } do
    it(("an event function that cannot be recorded is located, in time order with the impacts (%s)"):format(method), function()
      local sys = ball(0.5, 0.1)
      local tr = sys:simulate{ q0 = { 1 }, t1 = 0.6, method = method, events = { { name = "branchy",
        f = function(t, q) if q[1] > 0.5 then return 1 end return -1 end } } }
      assert(tr.stats.events_why:find("event 'branchy' cannot be recorded", 1, true), tr.stats.events_why)
      assert.are.equal("done", tr.status)
      assert.are.equal(2, #tr.events)
      assert.are.equal("branchy", tr.events[1].name)
      assert(math.abs(tr.events[1].t - math.sqrt(1 / g)) < 1e-9, tr.events[1].t - math.sqrt(1 / g))
      assert.are.equal("impact", tr.events[2].kind)
      assert(math.abs(tr.events[2].t - math.sqrt(1.8 / g)) < 1e-9, tr.events[2].t - math.sqrt(1.8 / g))
    end)
  end
end)
