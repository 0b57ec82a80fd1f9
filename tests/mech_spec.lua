-- mech_spec.lua - mechanical systems and their generalized equations of any
-- order (docs/theory.md §2-§5, §9, §11), against hand-derived equations, finite
-- differences, and the identities of the theory.
local h = require "tests.helpers"
local nz = h.nz
local systems = require "tests.mech_systems"

local function uniform(a, b) return a + (b - a) * math.random() end
local function max_abs(v) local m = 0; for i = 1, #v do m = math.max(m, math.abs(v[i])) end; return m end
local function max_diff(a, b) local m = 0; for i = 1, #a do m = math.max(m, math.abs(a[i] - b[i])) end; return m end
local function vec(v) local p = {}; for i = 1, #v do p[i] = ("%.17g"):format(v[i]) end; return "{" .. table.concat(p, ", ") .. "}" end

local STATES = 6   -- random states per system and check

describe("accelerations against equations derived by hand", function()
  for _, case in ipairs(systems.all()) do
    it(case.name, function()
      for _ = 1, STATES do
        local t, q, qd = case.draw()
        local got, want = case.sys:accel(t, q, qd), case.accel(t, q, qd)
        -- Rounding only: a residual of O(1) terms solved by Cholesky of a
        -- well-conditioned M; 1e-11 relative leaves room for cond(M) ~ 100.
        assert(max_diff(got, want) <= 1e-11 * (1 + max_abs(want)),
          ("%s at q = %s, qd = %s: engine %s, hand %s"):format(case.name, vec(q), vec(qd), vec(got), vec(want)))
      end
    end)
  end
  it("the mass matrix of the double pendulum is the hand-derived one", function()
    for _, with_bodies in ipairs{ false, true } do
      local case = systems.double_pendulum(with_bodies)
      local t, q, qd = case.draw()
      local Mm = case.sys:mass(t, q, qd)
      local want = case.mass(q)
      for i = 1, 2 do for j = 1, 2 do
        assert(math.abs(Mm[i][j] - want[i][j]) <= 1e-12 * 4, ("M[%d][%d] = %.17g, hand %.17g"):format(i, j, Mm[i][j], want[i][j]))
      end end
    end
  end)
end)

describe("sys:accel into a table of the caller's (opts.out)", function()
  it("writes qdd into opts.out and returns it: the hand-derived accelerations, no table made per call", function()
    local case = systems.double_pendulum(true)
    local o = { out = { 7, 7, 7 } }
    for _ = 1, STATES do
      local t, q, qd = case.draw()
      local got, lambda = case.sys:accel(t, q, qd, o)
      local want = case.accel(t, q, qd)
      assert(got == o.out, "opts.out is not what accel returned")
      assert(max_diff(want, got) <= 1e-11 * (1 + max_abs(want)), ("engine %s, hand %s"):format(vec(got), vec(want)))
      assert(got[3] == 7, "entries past k are the caller's")
      assert(#lambda == 0 and next(lambda) == nil, "multipliers of a system without constraints")
      h.checkerror("cannot be written", function() lambda[1] = 1 end)
    end
    -- The same calls allocate: new tables for qdd and lambda each time,
    -- and none with opts.out (the collector stopped, Lua's own count).
    local t, q, qd = case.draw()
    local function grown(f)
      collectgarbage("collect")
      collectgarbage("stop")
      local before = collectgarbage("count")
      for _ = 1, 1000 do f() end
      local kb = collectgarbage("count") - before
      collectgarbage("restart")
      return kb
    end
    local plain = grown(function() case.sys:accel(t, q, qd) end)
    local into = grown(function() case.sys:accel(t, q, qd, o) end)
    assert(plain > 50 and into < 2, ("1000 calls made %.1f KB of tables, %.1f KB with opts.out"):format(plain, into))
  end)
  it("with constraints: qdd into opts.out, the multipliers as without it", function()
    local cs = require "tests.constraint_systems"
    local case = cs.sleigh()
    local t, q, qd = case.draw()
    local qdd, lambda = case.sys:accel(t, q, qd)
    local o = { out = {} }
    local got, lambda2 = case.sys:accel(t, q, qd, o)
    assert(got == o.out and #got == #qdd and #lambda2 == #lambda and #lambda == 1)
    for i = 1, #qdd do assert(got[i] == qdd[i]) end
    assert(lambda2[1] == lambda[1])
  end)
  it("refuses an out that is not a plain table, naming the option", function()
    local case = systems.double_pendulum(true)
    local t, q, qd = case.draw()
    h.checkerror("option 'out': a plain table (it receives qdd)", function() case.sys:accel(t, q, qd, { out = 3 }) end)
    h.checkerror("option 'out': a plain table (it receives qdd)", function()
      case.sys:accel(t, q, qd, { out = setmetatable({}, {}) })
    end)
  end)
end)

describe("all forms and all orders agree", function()
  -- The residual is affine in qdd, so agreement at an arbitrary qdd (not the
  -- motion's) is the stronger test.  Orders 1..12; Wassmuth's form needs
  -- particles and n >= 2.
  for _, case in ipairs(systems.all()) do
    it(case.name, function()
      local t, q, qd = case.draw()
      local qdd = {}
      for i = 1, #q do qdd[i] = uniform(-2, 2) end
      local ref = case.sys:residual(1, t, q, qd, qdd, "lagrange")
      local scale = 1 + max_abs(ref)
      for _, form in ipairs(nz.forms) do
        local has_S = form ~= "wassmuth" or case.sys.pieces.S > 0
        for n = (form == "wassmuth" and 2 or 1), 12 do
          if has_S then
            local r = case.sys:residual(n, t, q, qd, qdd, form)
            local want = ref
            if form == "extremal" and n == 1 and case.velocity_forces then
              -- K_1 = R_1 - sum_j Q_j q_j' (4.3): with forces that depend on
              -- q', dK_1/dq_i' = (Lagrange) - sum_j q_j' dQ_j/dq_i', by hand.
              local D = case.dQ_dqd(t, q, qd)
              want = {}
              for i = 1, #q do
                local s_ = 0
                for j = 1, #q do s_ = s_ + qd[j] * D[j][i] end
                want[i] = ref[i] - s_
              end
            end
            -- Each form is a different sum of O(n) terms of size ~scale,
            -- each rounded: 1e-11 n relative is a few hundred ulps.
            assert(max_diff(r, want) <= 1e-11 * n * scale,
              ("%s, form %s, n = %d: %s, Lagrange's form gives %s"):format(case.name, form, n, vec(r), vec(want)))
          end
        end
      end
    end)
  end
  for _, case in ipairs{ systems.top(false), systems.charged_drag(), systems.relativistic() } do
    it(case.name .. ": the residual of every form vanishes at the hand-derived accelerations for every n", function()
      for _ = 1, 3 do
        local t, q, qd = case.draw()
        local a = case.accel(t, q, qd)
        for _, form in ipairs(nz.forms) do
          -- Wassmuth's form needs particles; the extremal form at n = 1
          -- differs by design when Q depends on q' (checked above).
          if form ~= "wassmuth" then
            for n = (form == "extremal" and case.velocity_forces) and 2 or 1, 12 do
              local r = case.sys:residual(n, t, q, qd, a, form)
              assert(max_abs(r) <= 1e-11 * n * 10, ("%s, form %s, n = %d: residual %s at the hand accelerations"):format(case.name, form, n, vec(r)))
            end
          end
        end
      end
    end)
  end
  it("derivatives beyond qdd do not change the result", function()
    local case = systems.double_pendulum(false)
    local t, q, qd = case.draw()
    local qdd = { 0.385, -1.2 }
    for n = 3, 12 do
      local higher = {}
      for j = 1, n - 1 do higher[j] = { uniform(-50, 50), uniform(-50, 50) } end
      for _, form in ipairs{ "generalized", "difference", "appell", "extremal" } do
        local r0 = case.sys:residual(n, t, q, qd, qdd, form)
        local r1 = case.sys:residual(n, t, q, qd, qdd, { form = form, higher = higher })
        assert(max_diff(r0, r1) <= 1e-11 * n * (1 + max_abs(r0)),
          ("n = %d, form %s: %s with random q''' .. q^(%d), %s with zeros"):format(n, form, vec(r1), n + 1, vec(r0)))
      end
    end
  end)
  it("orders up to 100 stay finite and agree with n = 1", function()
    local case = systems.kepler()
    local t, q, qd = case.draw()
    local qdd = { 0.3, -0.2 }
    local ref = case.sys:residual(1, t, q, qd, qdd)
    for _, n in ipairs{ 30, 60, 100 } do
      local r = case.sys:residual(n, t, q, qd, qdd)
      assert(max_diff(r, ref) <= 1e-9 * (1 + max_abs(ref)), ("n = %d: %s vs %s"):format(n, vec(r), vec(ref)))
    end
  end)
end)

-- Random smooth functions f(t, q, qd), k = 2, with explicit t dependence and
-- terms that are not quadratic in the velocities.
local function random_function()
  local a = {}
  for i = 1, 7 do a[i] = uniform(0.5, 1.5) * (math.random() < 0.5 and -1 or 1) end
  local w, b = uniform(0.5, 2), uniform(-0.5, 0.5)
  return function(t, q, qd)
    return a[1] * qd[1] ^ 2 * nz.cos(q[2]) + a[2] * qd[1] * qd[2] * nz.exp(b * q[1])
      + a[3] * nz.sin(w * t) * qd[2] ^ 3 + a[4] * q[1] * q[2] * t
      + a[5] * nz.sqrt(1 + qd[1] ^ 2 + q[2] ^ 2) + a[6] * nz.log(2 + nz.sin(q[1])) * qd[2]
      + a[7] * nz.atan(qd[1] * t + q[2])
  end
end

-- Independent reference: df/dq and E' = d/dt(df/dqd) by central finite
-- differences of f on plain numbers.
local function fd_terms(f, t, q, qd, qdd)
  local k, hstep = #q, 1e-4
  local function at(dt, dq, dqd)
    local qq, vv = {}, {}
    for i = 1, k do qq[i] = q[i] + (dq[i] or 0); vv[i] = qd[i] + (dqd[i] or 0) end
    return f(t + dt, qq, vv)
  end
  local fq, Ep = {}, {}
  for i = 1, k do
    local e = {}; e[i] = hstep
    local me = {}; me[i] = -hstep
    fq[i] = (at(0, e, {}) - at(0, me, {})) / (2 * hstep)
    -- d/dt of g = df/dqd_i along (qd, qdd): g(t + s, q + s qd, qd + s qdd)
    local function g(s)
      local dq, dqd = {}, {}
      for j = 1, k do dq[j] = s * qd[j]; dqd[j] = s * qdd[j] end
      local ep, em = {}, {}
      for j = 1, k do ep[j] = dqd[j]; em[j] = dqd[j] end
      ep[i] = ep[i] + hstep; em[i] = em[i] - hstep
      return (at(s, dq, ep) - at(s, dq, em)) / (2 * hstep)
    end
    Ep[i] = (g(hstep) - g(-hstep)) / (2 * hstep)
  end
  return fq, Ep
end

describe("the kinematic identity (2.1) and the operators of §5", function()
  -- Second differences with step 1e-4: truncation ~1e-8, rounding
  -- ~eps/h^2 ~ 2e-8 of f's scale; 2e-6 relative is a safe bound.
  local FD_TOL = 2e-6
  for trial = 1, 4 do
    it(("(2.1) d f^(n)/dq^(n) = n d/dt(df/dqd) + df/dq for random f #%d, n = 0..12"):format(trial), function()
      local f = random_function()
      local t, q, qd, qdd = uniform(-1, 1), { uniform(-1, 1), uniform(-1, 1) }, { uniform(-1, 1), uniform(-1, 1) }, { uniform(-1, 1), uniform(-1, 1) }
      local fq, Ep = fd_terms(f, t, q, qd, qdd)
      for n = 0, 12 do
        local got = nz.partial(n, f, t, q, qd, qdd)
        for i = 1, 2 do
          local want = n * Ep[i] + fq[i]
          assert(math.abs(got[i] - want) <= FD_TOL * (1 + math.abs(n * Ep[i]) + math.abs(fq[i])),
            ("n = %d, i = %d: jets give %.12g, finite differences %.12g"):format(n, i, got[i], want))
        end
      end
    end)
    it(("Theorem 1: N^m(f) = E^m(f) = (2-m) E' - df/dq for random f #%d, m = 1..10"):format(trial), function()
      local f = random_function()
      local t, q, qd, qdd = uniform(-1, 1), { uniform(-1, 1), uniform(-1, 1) }, { uniform(-1, 1), uniform(-1, 1) }, { uniform(-1, 1), uniform(-1, 1) }
      local fq, Ep = fd_terms(f, t, q, qd, qdd)
      for m = 1, 10 do
        local N, E = nz.nielsen_op(m, f, t, q, qd, qdd), nz.euler_op(m, f, t, q, qd, qdd)
        for i = 1, 2 do
          local want = (2 - m) * Ep[i] - fq[i]
          assert(math.abs(N[i] - E[i]) <= 1e-11 * m * (1 + math.abs(want)),
            ("m = %d: N = %.17g, E = %.17g"):format(m, N[i], E[i]))
          assert(math.abs(N[i] - want) <= FD_TOL * (1 + math.abs(m * Ep[i]) + math.abs(fq[i])),
            ("m = %d: N = %.12g, closed form with finite differences %.12g"):format(m, N[i], want))
        end
      end
    end)
  end
  it("the coefficient of q^(m) in f^(m-1) is df/dqd, for m = 1..8", function()
    local f = random_function()
    local t, q, qd = 0.3, { 0.2, -0.7 }, { 0.5, 0.1 }
    local want = nz.partial(0, function(tt, qq, vv) return f(tt, vv, qq) end, t, qd, q)  -- swap slots: df/dqd
    for m = 1, 8 do
      local got = nz.top_coefficient(m, f, t, q, qd, { 0.1, 0.2 })
      assert(max_diff(got, want) <= 1e-12 * (1 + max_abs(want)), ("m = %d: %s vs %s"):format(m, vec(got), vec(want)))
    end
  end)
end)

describe("the extremal form and velocity-dependent forces (§4)", function()
  it("with damping, dK_1/dq' differs from the equations; from n = 2 on it agrees", function()
    local c = 0.7
    local sys = nz.system{ coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      V = function(t, q) return 0.5 * q[1] ^ 2 end, Q = function(t, q, qd) return { -c * qd[1] } end }
    local q, qd, qdd = { 0.4 }, { 0.9 }, { -0.1 }
    local ref = sys:residual(1, 0, q, qd, qdd)
    -- By hand: K_1 = R_1 - Q q', so dK_1/dq' = (residual) - q' dQ/dq' = ref + c q'.
    local k1 = sys:residual(1, 0, q, qd, qdd, "extremal")
    assert(math.abs(k1[1] - (ref[1] + c * qd[1])) <= 1e-14, ("n = 1: %.17g, expected %.17g"):format(k1[1], ref[1] + c * qd[1]))
    for n = 2, 5 do
      assert(math.abs(sys:residual(n, 0, q, qd, qdd, "extremal")[1] - ref[1]) <= 1e-13)
    end
  end)
end)

describe("energy", function()
  it("T + V and H of a pendulum agree with the closed form", function()
    local case = systems.pendulum()
    local E, H = case.sys:energy(0, { 0.7 }, { 0.3 })
    local want = 0.5 * 2 * 1.3 ^ 2 * 0.3 ^ 2 - 2 * 9.81 * 1.3 * math.cos(0.7)
    assert(math.abs(E - want) <= 1e-14 * 20 and math.abs(H - want) <= 1e-14 * 20, ("E = %.17g, H = %.17g, want %.17g"):format(E, H, want))
  end)
  it("on a turning hoop H is Jacobi's T2 - T0 + V, not T + V (§9)", function()
    for _, with_bodies in ipairs{ false, true } do
      local case = systems.hoop(with_bodies)
      local t, q, qd = case.draw()
      local T2, T0, V = case.parts(t, q, qd)
      local E, H = case.sys:energy(t, q, qd)
      assert(math.abs(E - (T2 + T0 + V)) <= 1e-13, ("T + V = %.17g, want %.17g"):format(E, T2 + T0 + V))
      assert(math.abs(H - (T2 - T0 + V)) <= 1e-13, ("H = %.17g, want %.17g"):format(H, T2 - T0 + V))
    end
  end)
  it("a system given by L alone has no T + V but has H", function()
    local sys = nz.system{ coords = { "x" }, L = function(t, q, qd) return nz.sqrt(1 + qd[1] ^ 2) - q[1] ^ 2 end }
    local E, H = sys:energy(0, { 0.5 }, { 0.8 })
    assert.is_nil(E)
    -- H = qd dL/dqd - L = qd^2/sqrt(1+qd^2) - sqrt(1+qd^2) + x^2
    local s = math.sqrt(1 + 0.64)
    assert(math.abs(H - (0.64 / s - s + 0.25)) <= 1e-15 * 4)
  end)
end)

describe("systems in a session", function()
  it("params are passed to the functions and can be changed between calls", function()
    local case = systems.cart_pendulum()
    local q, qd = { 0.2, 0.5 }, { 0.1, -0.3 }
    local a1 = case.sys:accel(0, q, qd)
    case.sys.params.m = 1.6
    local a2 = case.sys:accel(0, q, qd)
    local want = case.accel(0, q, qd)   -- the hand formula reads the same table
    assert(max_diff(a2, want) <= 1e-12 * (1 + max_abs(want)))
    assert(max_diff(a1, a2) > 1e-3, "changing the mass changed nothing")
  end)
  it("T, V and Q given as lists add up", function()
    local sys = nz.system{ coords = { "x" },
      T = { function(t, q, qd) return 0.5 * qd[1] ^ 2 end, function(t, q, qd) return qd[1] ^ 2 end },
      V = { function(t, q) return q[1] ^ 2 end, function(t, q) return 0.5 * q[1] ^ 2 end },
      Q = { function(t, q, qd) return { -qd[1] } end, function(t, q, qd) return { 2 } end } }
    -- 3 x'' + 3 x = -x' + 2
    local a = sys:accel(0, { 0.4 }, { 0.3 })
    assert(math.abs(a[1] - (-0.3 + 2 - 3 * 0.4) / 3) <= 1e-15 * 4)
  end)
  it("prints a summary and the table of terms", function()
    local case = systems.double_pendulum(false)
    assert.are.equal("nz.system 'double pendulum': 2 coordinates (a, b); T, V\n"
      .. "  T: recorded, runs in C\n  V: recorded, runs in C", tostring(case.sys))
    local text = case.sys:equations(2, 0, { 0.7, -0.4 }, { 0.3, 1.1 }, nil, { quiet = true })
    assert.truthy(text:find("order n = 2: Tsenov's equations (Gauss's principle)", 1, true), text)
    assert.truthy(text:find("dT^(2)/dq^(2)", 1, true), text)
    assert.truthy(text:find("3 dT/dq", 1, true), text)
    assert.truthy(text:find("\n  a ", 1, true) and text:find("\n  b ", 1, true), text)
    text = case.sys:equations(1, 0, { 0.7, -0.4 }, { 0.3, 1.1 }, { 0, 0 }, { quiet = true })
    assert.truthy(text:find("Nielsen's equations (Jourdain's principle)", 1, true), text)
  end)
end)

describe("misuse gets a clear error naming the system and the function", function()
  local q, qd = { 0.1, 0.2 }, { 0.3, 0.4 }
  local function sys_with(fields)
    local def = { name = "bad", coords = { "x", "y" }, T = function(t, q_, v) return 0.5 * (v[1] ^ 2 + v[2] ^ 2) end }
    for k, v in pairs(fields) do def[k] = v end
    return nz.system(def)
  end
  it("a function that raises an error", function()
    local sys = sys_with{ V = function() error("no potential here") end }
    h.checkerror("system 'bad': V raised an error: ", sys.accel, sys, 0, q, qd)
    h.checkerror("no potential here at t = 0, q = {0.1, 0.2}", sys.accel, sys, 0, q, qd)
  end)
  it("Q with the wrong count of forces, or not a table", function()
    -- said when the system is made (tests/errors_spec.lua), with the sample state
    h.checkerror("nz.system 'bad': Q fails at every state (tried once as the system is made, at t = 0.3, q = {0.2, 0.2}, "
      .. "qd = {0.4, 0.4}): ", sys_with, { Q = function() return { 1 } end })
    h.checkerror("Q returned 1 forces for 2 coordinates", sys_with, { Q = function() return { 1 } end })
    h.checkerror("Q returned a number: Q returns a list {Q1, Q2} of forces, one per coordinate", sys_with,
      { Q = function() return 3 end })
  end)
  it("NaN or infinity returned by a function", function()
    local s = sys_with{ V = function(t, q_) return 0 / 0 end }
    h.checkerror("system 'bad': V returned a value that is not finite", s.accel, s, 0, q, qd)
    local s2 = sys_with{ V = function(t, q_) return math.huge end }
    h.checkerror("V returned a value that is not finite", s2.accel, s2, 0, q, qd)
    -- Overflow inside the function is caught by the jets themselves, and an
    -- infinity that came in is named as the argument that carried it.
    local s3 = sys_with{ V = function(t, q_) return q_[1] * 1e300 * 1e300 end }
    h.checkerror("tests/mech_spec.lua:", s3.accel, s3, 0, q, qd)      -- the user's line first
    h.checkerror("system 'bad': V raised an error: ", s3.accel, s3, 0, q, qd)
    h.checkerror("'mul' overflows", s3.accel, s3, 0, q, qd)
    local s4 = sys_with{ V = function(t, q_) return q_[1] * math.huge end }
    h.checkerror("bad argument #2 to 'mul' (got inf", s4.accel, s4, 0, q, qd)
  end)
  it("a value that is not a number or a jet, or a jet of too low order", function()
    -- (said when the system is made: it fails at every state, tests/errors_spec.lua)
    h.checkerror("V fails at every state", sys_with, { V = function() return "x" end })
    -- T is evaluated on jets of order n: a constant made a jet of order 0
    -- would truncate it.
    local s2 = sys_with{ T = function(t, q_, v) return 0.5 * (v[1] ^ 2 + v[2] ^ 2) + nz.jet(1, 0) end }
    h.checkerror("T returned a jet of lower order than its arguments", s2.residual, s2, 3, 0, q, qd, { 0, 0 })
  end)
  it("a singular velocity Hessian reports the state and the condition number", function()
    local s = nz.system{ name = "degenerate", coords = { "x", "y" }, T = function(t, q_, v) return 0.5 * (v[1] + v[2]) ^ 2 end }
    h.checkerror("system 'degenerate': the mass matrix M = d2T/dqd2 is not positive definite at t = 0, q = {0.1, 0.2}, qd = {0.3, 0.4} (eigenvalues from",
      s.accel, s, 0, q, qd)
    h.checkerror("condition number infinite", s.accel, s, 0, q, qd)
    local s2 = nz.system{ name = "stiff", coords = { "x", "y" }, T = function(t, q_, v) return 0.5 * (v[1] ^ 2 + 1e-15 * v[2] ^ 2) end }
    h.checkerror("system 'stiff': the mass matrix M = d2T/dqd2 is singular or badly conditioned", s2.accel, s2, 0, q, qd)
    h.checkerror("condition number 1e+15", s2.accel, s2, 0, q, qd)
  end)
  it("a state of the wrong size or with a non-number", function()
    local s = sys_with{}
    h.checkerror("bad argument #2 to 'accel' (q: a table of 2 numbers expected (one per coordinate: x, y), got a table of 3 entries)",
      s.accel, s, 0, { 1, 2, 3 }, qd)
    h.checkerror("bad argument #2 to 'accel' (q[2]: a finite number expected, got NaN)", s.accel, s, 0, { 1, 0 / 0 }, qd)
    h.checkerror("bad argument #4 to 'residual' (qd: a table of 2 numbers expected (one per coordinate: x, y), got the string \"x\")",
      s.residual, s, 1, 0, q, "x", { 0, 0 })
  end)
  it("an order, a form, or Wassmuth's form without particles", function()
    local s = sys_with{}
    h.checkerror("bad argument #1 to 'residual' (n: an integer order from 1 to 100 expected, got 0)", s.residual, s, 0, 0, q, qd, { 0, 0 })
    h.checkerror("unknown form 'nielsen'; forms: generalized, lagrange", s.residual, s, 1, 0, q, qd, { 0, 0 }, "nielsen")
    h.checkerror("system 'bad': Wassmuth's form needs the acceleration energy S", s.residual, s, 2, 0, q, qd, { 0, 0 }, "wassmuth")
    local p = systems.double_pendulum(true).sys
    h.checkerror("Wassmuth's form needs n >= 2 (got 1)", p.residual, p, 1, 0, q, qd, { 0, 0 }, "wassmuth")
  end)
  it("a definition with a missing or unknown field", function()
    h.checkerror("nz.system: a table {coords = ..., T = ...} expected", nz.system, 3)
    h.checkerror("nz.system 'x': unknown field 'Tt' (expected one of L, Q, S, T, V, bodies, compile, constraints, coords, name, native, params, sample)",
      nz.system, { name = "x", coords = { "a" }, Tt = 1 })
    h.checkerror("'coords' must be a non-empty list of coordinate names", nz.system, { T = function() return 0 end })
    h.checkerror("nz.system 'unnamed': coordinate 'a' appears twice (coords[1] and coords[3]): each coordinate needs a "
      .. "name of its own", nz.system, { coords = { "a", "b", "a" }, T = function() return 0 end })
    h.checkerror("coords[2] must be the coordinate's name, a string, got the number 2 (write coords = { \"x\", \"th\" }",
      nz.system, { coords = { "a", 2 }, T = function() return 0 end })
    h.checkerror("it has no kinetic energy: give the kinetic energy T = function(t, q, qd, params) (or a Lagrangian L)",
      nz.system, { coords = { "a" } })
    -- said at the caller's line
    local ok, msg = pcall(function()
      local s = nz.system{ coords = { "a", "a" }, T = function() return 0 end }
      return s
    end)
    assert(not ok and msg:find("mech_spec.lua:%d+: nz.system"), msg)
    h.checkerror("T[2] must be a function, got number", nz.system, { coords = { "a" }, T = { function() return 0 end, 5 } })
    h.checkerror("'params' must be a table of named numbers", nz.system, { coords = { "a" }, T = function() return 0 end, params = 3 })
  end)
  it("bodies with wrong or missing parameters", function()
    local pos = function() return { 0, 0, 0 } end
    h.checkerror("nz.bodies: body 1: 'mass' must be a positive number", nz.bodies, { { mass = -1, pos = pos } })
    h.checkerror("body 2: 'pos' must be a function(t, q, params) returning {x, y, z}", nz.bodies, { { mass = 1, pos = pos }, { mass = 1 } })
    h.checkerror("body 1: a rigid body needs both 'rot' and 'inertia'", nz.bodies, { { mass = 1, pos = pos, inertia = { 1, 1, 1 } } })
    h.checkerror("body 1: unknown field 'masss'", nz.bodies, { { masss = 1, pos = pos } })
    h.checkerror("'inertia' must be symmetric", nz.bodies, { { mass = 1, pos = pos, rot = pos, inertia = { { 1, 2, 0 }, { 0, 1, 0 }, { 0, 0, 1 } } } })
    local s = nz.system{ name = "b", coords = { "x" }, bodies = { { mass = 1, pos = function(t, q) return { q[1], 0 } end } } }
    h.checkerror("'pos' must return {x, y, z}, got 2 values", s.accel, s, 0, { 1 }, { 0 })
  end)
end)
