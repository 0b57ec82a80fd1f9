-- squeezer.lua - Andrews' squeezing mechanism: seven rigid bodies in a plane,
-- joined in three closed loops, driven by a torque and held by a spring.
--
-- Sources: E. Hairer and G. Wanner, "Solving Ordinary Differential Equations
-- II: Stiff and Differential-Algebraic Problems", 2nd ed., Springer 1996,
-- section VII.7 ("the seven body mechanism", after Schiehlen's benchmark of
-- Manning and Giles); and the Test Set for IVP Solvers (F. Mazzia and
-- C. Magherini, University of Bari, release 2.4, 2008), problem "andrews"
-- (andrews.f and its documentation): the parameters below, the start and
-- the reference solution at t = 0.03 (computed there with PSIDE at rtol =
-- atol = 1e-14).
--
-- Coordinates (the Test Set's order): beta, the crank's angle (driven);
-- theta, the coupler's angle against the crank; gamma, the triangle about
-- the fixed point B (the spring pulls its corner D towards C); phi, delta
-- and Omega, epsilon, the two dyads of bars hinged at the fixed point A.
-- The Test Set writes the equations as M q'' = f(q, q') - G(q)^T lambda
-- with M and f given: here only what they come from is written, T (the
-- bodies' kinetic energies, from the positions of their centres of mass),
-- V (the spring), Q (the torque) and the six loop-closure constraints g(q)
-- = 0, and nzlua derives the equations.  SI units: masses 3.65e-3 to
-- 7.05e-2 kg, moments of inertia 4.4e-7 to 1.9e-5 kg m^2, lengths 9e-4 to
-- 7.8e-2 m, the spring 4530 N/m and the torque 0.033 N m.  Over the 0.03 s
-- of the benchmark the crank turns 2.5 times, at up to 1.4e3 rad/s.
--
-- Run: build/nzlua examples/squeezer.lua.  Loaded with an argument
-- (loadfile(path)("module")) it returns the model without printing anything
-- (tests/squeezer_spec.lua does that).

-- The Test Set's parameters (andrews.f, andpar).
local testset = {
  m1 = .04325, m2 = .00365, m3 = .02373, m4 = .00706, m5 = .07050, m6 = .00706, m7 = .05498,
  i1 = 2.194e-6, i2 = 4.410e-7, i3 = 5.255e-6, i4 = 5.667e-7, i5 = 1.169e-5, i6 = 5.667e-7, i7 = 1.912e-5,
  xa = -.06934, ya = -.00227, xb = -.03635, yb = .03273, xc = .014, yc = .072,
  d = 28e-3, da = 115e-4, e = 2e-2, ea = 1421e-5, rr = 7e-3, ra = 92e-5,
  ss = 35e-3, sa = 1874e-5, sb = 1043e-5, sc = 18e-3, sd = 2e-2,
  ta = 2308e-5, tb = 916e-5, u = 4e-2, ua = 1228e-5, ub = 449e-5,
  zf = 2e-2, zt = 4e-2, fa = 1421e-5,
  c0 = 4530, l0 = 7785e-5, mom = 0.033,
}
local LENGTHS = { "xa", "ya", "xb", "yb", "xc", "yc", "d", "da", "e", "ea", "rr", "ra", "ss", "sa", "sb", "sc", "sd",
  "ta", "tb", "u", "ua", "ub", "zf", "zt", "fa", "l0" }

-- The same mechanism in other units: lengths times L, masses times M, time
-- times T.  The angles are the same functions of t / T (the equations are
-- invariant when inertias scale by M L^2, the spring's stiffness by M / T^2
-- and the torque by M L^2 / T^2), so the reference holds at t = 0.03 T.
local function scaled(L, M, T)
  local p = {}
  for key, v in pairs(testset) do p[key] = v end
  for _, key in ipairs(LENGTHS) do p[key] = testset[key] * L end
  for b = 1, 7 do
    p["m" .. b] = testset["m" .. b] * M
    p["i" .. b] = testset["i" .. b] * M * L ^ 2
  end
  p.c0 = testset.c0 * M / T ^ 2
  p.mom = testset.mom * M * L ^ 2 / T ^ 2
  return p
end

local BETA, THETA, GAMMA, PHI, DELTA, OMEGA, EPSILON = 1, 2, 3, 4, 5, 6, 7
local sin, cos, sqrt = nz.sin, nz.cos, nz.sqrt

-- A point fixed on a body turned by the angle a: R(a) (x, y), and its
-- velocity a' R(a) (-y, x).
local function turned(a, x, y) return x * cos(a) - y * sin(a), x * sin(a) + y * cos(a) end
local function turning(a, ad, x, y) return turned(a, -ad * y, ad * x) end

-- The system for the parameters p.
local function build(p, name)
  -- The velocities of the centres of mass.  Bodies 1, 3, 5 and 7 turn
  -- about the origin O, B, A and A; 2 hangs from the crank's end, 4 from
  -- the end of 5, 6 from the end of 7.  Where a centre sits off a bar's
  -- line (3, 5, 7: the Test Set gives two offsets, sa and sb, ...) only its
  -- distance from the pivot enters T (there is no gravity), so the side it
  -- sits on is a choice.
  local function velocities(q, qd)
    local v = {}
    v[1] = { turning(q[BETA], qd[BETA], p.ra, 0) }                             -- crank, about O
    local ex, ey = turning(q[BETA], qd[BETA], p.rr, 0)                          -- crank's end
    local bx, by = turning(q[BETA] + q[THETA], qd[BETA] + qd[THETA], -p.da, 0)
    v[2] = { ex + bx, ey + by }                                                   -- coupler
    v[3] = { turning(q[GAMMA], qd[GAMMA], p.sa, -p.sb) }                        -- triangle, about B
    v[5] = { turning(q[DELTA], qd[DELTA], p.ta, p.tb) }                         -- bar about A
    ex, ey = turning(q[DELTA], qd[DELTA], p.zt, 0)                              -- its end
    bx, by = turning(q[PHI] + q[DELTA], qd[PHI] + qd[DELTA], 0, -(p.e - p.ea))
    v[4] = { ex + bx, ey + by }
    v[7] = { turning(q[EPSILON], qd[EPSILON], p.ua, p.ub) }                     -- bar about A
    ex, ey = turning(q[EPSILON], qd[EPSILON], 0, -p.u)                          -- its end
    bx, by = turning(q[OMEGA] + q[EPSILON], qd[OMEGA] + qd[EPSILON], p.zf - p.fa, 0)
    v[6] = { ex + bx, ey + by }
    local w = { qd[BETA], qd[BETA] + qd[THETA], qd[GAMMA], qd[PHI] + qd[DELTA], qd[DELTA],
      qd[OMEGA] + qd[EPSILON], qd[EPSILON] }
    return v, w
  end

  local function T(t, q, qd)
    local v, w = velocities(q, qd)
    local sum = 0
    for b = 1, 7 do
      sum = sum + 0.5 * p["m" .. b] * (v[b][1] ^ 2 + v[b][2] ^ 2) + 0.5 * p["i" .. b] * w[b] ^ 2
    end
    return sum
  end

  -- The spring from the triangle's corner D = B + R(gamma) (sd, -sc) to
  -- the fixed point C, of rest length l0.
  local function V(t, q)
    local x, y = turned(q[GAMMA], p.sd, -p.sc)
    return 0.5 * p.c0 * (sqrt((p.xb + x - p.xc) ^ 2 + (p.yb + y - p.yc) ^ 2) - p.l0) ^ 2
  end

  -- The driving torque on the crank.
  local function Q() return { p.mom, 0, 0, 0, 0, 0, 0 } end

  -- The point E where the coupler meets the three other chains: from O
  -- through the crank and the coupler, and again from B through the
  -- triangle and from A through each dyad.  The three loops close where
  -- both ends of each chain agree: g_1 .. g_6 of the Test Set.
  local function coupler_end(q)
    return p.rr * cos(q[BETA]) - p.d * cos(q[BETA] + q[THETA]), p.rr * sin(q[BETA]) - p.d * sin(q[BETA] + q[THETA])
  end
  local constraints = {
    function(t, q) local x = coupler_end(q); return x - p.ss * sin(q[GAMMA]) - p.xb end,
    function(t, q) local _, y = coupler_end(q); return y + p.ss * cos(q[GAMMA]) - p.yb end,
    function(t, q) local x = coupler_end(q); return x - p.e * sin(q[PHI] + q[DELTA]) - p.zt * cos(q[DELTA]) - p.xa end,
    function(t, q) local _, y = coupler_end(q); return y + p.e * cos(q[PHI] + q[DELTA]) - p.zt * sin(q[DELTA]) - p.ya end,
    function(t, q) local x = coupler_end(q); return x - p.zf * cos(q[OMEGA] + q[EPSILON]) - p.u * sin(q[EPSILON]) - p.xa end,
    function(t, q) local _, y = coupler_end(q); return y - p.zf * sin(q[OMEGA] + q[EPSILON]) + p.u * cos(q[EPSILON]) - p.ya end,
  }

  return nz.system{
    name = name or "Andrews' squeezer",
    coords = { "beta", "theta", "gamma", "phi", "delta", "Omega", "epsilon" },
    T = T, V = V, Q = Q, constraints = constraints,
  }
end

squeezer = build(testset)

-- The Test Set's start (at rest, on the constraints to 30 digits) and its
-- reference solution at t = 0.03: q, q', q'' and the multipliers of the
-- form M q'' = f - G^T lambda, which are minus those of (6.2) here.  Its
-- own accuracy falls with the derivative, as an index-3 solver's does:
-- nzlua's steppers agree with one another to 1e-13 and with it to 3e-10 in
-- q, 3e-8 in q' and 2e-6 in q'' and lambda (relative).
local start = {
  q = { -0.0617138900142764496358948458001, 0, 0.455279819163070380255912382449,
    0.222668390165885884674473185609, 0.487364979543842550225598953530,
    -0.222668390165885884674473185609, 1.23054744454982119249735015568 },
  qd = { 0, 0, 0, 0, 0, 0, 0 },
  -- consistent accelerations and multipliers (the Test Set's y(15..27) at t = 0)
  qdd = { 14222.4439199541138705911625887, -10666.8329399655854029433719415, 0, 0, 0, 0, 0 },
  lambda = { 98.5668703962410896057654982170, -6.12268834425566265503114393122, 0, 0, 0, 0 },
}
local reference = {
  t = 0.03,
  q = { 0.1581077119629904e+2, -0.1575637105984298e+2, 0.4082224013073101e-1, -0.5347301163226948e+0,
    0.5244099658805304e+0, 0.5347301163226948e+0, 0.1048080741042263e+1 },
  qd = { 0.1139920302151208e+4, -0.1424379294994111e+4, 0.1103291221937134e+2, 0.1929337464421385e+2,
    0.5735699284790808e+0, -0.1929337464421385e+2, 0.3231791658026955e+0 },
  qdd = { -0.2463176316945196e+5, 0.5185037701610329e+5, 0.3241025686413781e+6, 0.5667493645176213e+6,
    0.1674362929479361e+5, -0.5667493645176222e+6, 0.9826520791458422e+4 },
  lambda = { 0.1991753333731910e+3, -0.2975531228015052e+2, 0.2306654119098399e+2, 0.3145271365475927e+2,
    0.2264249232082739e+2, 0.1161740700019673e+2 },
}

local model = { system = squeezer, params = testset, scaled = scaled, build = build, start = start,
  reference = reference }
if ... == "module" then return model end

-- ------------------------------------------------------------------ --
print(squeezer)
print(select(2, squeezer:rule()))

-- Every stepper from the Test Set's start to t = 0.03, each at a tolerance
-- it reaches in well under a second (rk2imp takes 2 s; rk1imp, first
-- order, needs 12 s for two digits and is left out here), against the
-- reference: the largest error of the angles and of the angular velocities.
local function errors(run)
  local n, eq, ev = #run.t, 0, 0
  for i = 1, 7 do
    eq = math.max(eq, math.abs(run.q[n][i] - reference.q[i]))
    ev = math.max(ev, math.abs(run.qd[n][i] - reference.qd[i]))
  end
  return eq, ev
end
print("\nmethod    tolerance   steps   |q - ref|  |q' - ref|   (rad, rad/s; the crank turns at 1.1e3 rad/s)")
for _, case in ipairs{ { "rk8pd", 1e-10 }, { "taylor", 1e-12 }, { "rkf45", 1e-8 }, { "rkck", 1e-8 }, { "bsimp", 1e-10 },
  { "rk4imp", 1e-6 }, { "msadams", 1e-10 }, { "msbdf", 1e-8 }, { "rk2imp", 1e-5 }, { "rk4", 2e-5, true } } do
  local method, tol, fixed = case[1], case[2], case[3]
  local opts = { q0 = start.q, qd0 = start.qd, t1 = reference.t, dt = reference.t, method = method }
  if fixed then opts.step = tol else opts.rtol, opts.atol = tol, tol end
  local run = squeezer:simulate(opts)
  local eq, ev = errors(run)
  print(("%-9s %-11s %6d   %9.1e  %9.1e"):format(method, fixed and ("step " .. tol) or tol, run.stats.steps, eq, ev))
end

tr = squeezer:simulate{ q0 = start.q, qd0 = start.qd, t1 = reference.t, dt = 2e-4, rtol = 1e-10, atol = 1e-10 }
print(tr)
print(("at t = 0.03 the angles differ from the Test Set's reference by at most %.1e rad"):format((errors(tr))))
tr:plot{ y = { "gamma", "phi", "delta" }, width = 72, height = 18 }
