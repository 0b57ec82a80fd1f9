-- tests/fuzz/compare.lua - one random system recorded (the default) against
-- the same system with compile = false (every function in Lua on jets):
-- values and jets with tangents and along a state direction of each piece,
-- M and h, accelerations, residuals of orders 1-3, energies and a short
-- run, at random and boundary states.  The two must answer the same (to
-- TOL relative, a run to RUN_TOL), or both fail.  Returns the findings.
local systems = require "tests.fuzz.systems"
local core = require "nz.core"

local M = {}
M.TOL = 1e-9        -- the same operations, rounded alike: the graph computes what Lua does
M.RUN_TOL = 1e-7    -- a run's steps amplify a last-bit difference of the right-hand side
M.answered = 0      -- comparisons where both answered (the others both failed)

local function flat(v, out)
  out = out or {}
  if type(v) == "number" then out[#out + 1] = v
  elseif core.isjet(v) then
    for d = 0, v:ntangents() do
      local s = d == 0 and v or v:tangent(d)
      for j = 0, s:order() do out[#out + 1] = s:coef(j) end
    end
  elseif type(v) == "table" then
    for _, x in ipairs(v) do flat(x, out) end
  end
  return out
end

-- nil when a and b agree, else what differs (a text).
local function agree(a, b, tol)
  local fa, fb = flat(a), flat(b)
  if #fa ~= #fb then return ("%d numbers against %d"):format(#fa, #fb) end
  for i = 1, #fa do
    local x, y = fa[i], fb[i]
    if not (math.abs(x - y) <= tol * math.max(1, math.abs(x), math.abs(y))) and not (x ~= x and y ~= y) then
      return ("number %d: %.17g (recorded) against %.17g (Lua)"):format(i, x, y)
    end
  end
end

local function show(st)
  local function list(v)
    local s = {}
    for i, x in ipairs(v) do s[i] = systems.num(x) end
    return "{" .. table.concat(s, ", ") .. "}"
  end
  return ("t = %s, q = %s, qd = %s"):format(systems.num(st.t), list(st.q), list(st.qd))
end

-- The jets of a state for a piece of nlev levels, order K, D tangents.
local function jets_of(r, st, nlev, K, D, k)
  local function jet(v)
    local c = { v, order = K, tangents = {} }
    for j = 1, K do c[j + 1] = r.uniform(-0.5, 0.5) end
    for d = 1, D do
      c.tangents[d] = {}
      for j = 1, K + 1 do c.tangents[d][j] = r.uniform(-1, 1) end
    end
    if D == 0 then c.tangents = nil end
    return core.jet(c)
  end
  local lv, dlv = {}, {}
  for j = 1, nlev do
    lv[j], dlv[j] = {}, {}
    for i = 1, k do
      lv[j][i] = jet(j == 1 and st.q[i] or j == 2 and st.qd[i] or r.uniform(-1, 1))
      dlv[j][i] = jet(r.uniform(-1, 1))
    end
  end
  return jet(st.t), lv, jet(r.uniform(-1, 1)), dlv
end

-- Lua's error for an overflow at a state beyond 1e100 (a run that blew up).
local function overflow_far_out(err)
  err = tostring(err)
  if not err:find("overflows", 1, true) then return false end
  for v in err:gmatch("[-+]?%d[%d.]*e%+(%d+)") do if tonumber(v) >= 100 then return true end end
  return false
end

-- Every comparison of one system (a recorded, b in Lua) at its states.
function M.system(r, sys, a, b, states)
  local findings, count = {}, 0
  local function compare(what, st, fa, fb, tol)
    count = count + 1
    local oka, ra = pcall(fa)
    local okb, rb = pcall(fb)
    if rawequal(ra, core.interrupted) or rawequal(rb, core.interrupted) then error(core.interrupted, 0) end
    local bad
    M.answered = M.answered + (oka and okb and 1 or 0)
    if oka and not okb and overflow_far_out(rb) then
      -- the one case README leaves open: a polynomial T or V beside a
      -- constant M overflows only far out, and that plan does not see it
      okb, rb = true, ra
    end
    if oka ~= okb then
      bad = oka and ("the recording answers, Lua fails: " .. tostring(rb)) or ("the recording fails, Lua answers: " .. tostring(ra))
    elseif oka then
      bad = agree(ra, rb, tol or M.TOL)
    end
    if bad then findings[#findings + 1] = { what = what, state = st and show(st) or "", why = bad } end
  end
  local k, mech = a.k, core.mech
  local pieces = { { "F", 2 }, { "V", 1 } }
  if a.pieces.Q > 0 then pieces[#pieces + 1] = { "Q", 2 } end
  if a.nc > 0 then pieces[#pieces + 1] = { "constraints", a.constraint_levels[1] or 4 } end
  for _, st in ipairs(states) do
    local t, q, qd = st.t, st.q, st.qd
    local qdd = {}
    for i = 1, k do qdd[i] = r.uniform(-1, 1) end
    for _, pc in ipairs(pieces) do
      local K, D = r.pick{ 0, 1, 3 }, r.pick{ 0, 2 }
      local tj, lv, dt, dlv = jets_of(r, st, pc[2], K, D, k)
      compare(("%s on jets of order %d, %d tangents"):format(pc[1], K, D), st,
        function() return mech.piece(a.engine, pc[1], 1, tj, lv) end,
        function() return mech.piece(b.engine, pc[1], 1, tj, lv) end)
      compare(pc[1] .. " along a state direction", st,
        function() return { mech.piece(a.engine, pc[1], 1, tj, lv, dt, dlv) } end,
        function() return { mech.piece(b.engine, pc[1], 1, tj, lv, dt, dlv) } end)
    end
    compare("M and h", st, function() return { a:mass_bias(t, q, qd) } end, function() return { b:mass_bias(t, q, qd) } end)
    compare("accel", st, function() return { a:accel(t, q, qd) } end, function() return { b:accel(t, q, qd) } end)
    for n = 1, 3 do
      compare(("residual of order %d"):format(n), st, function() return a:residual(n, t, q, qd, qdd) end,
        function() return b:residual(n, t, q, qd, qdd) end)
    end
    compare("energy", st, function() local E, H = a:energy(t, q, qd); return { E, H } end,
      function() local E, H = b:energy(t, q, qd); return { E, H } end)
  end
  -- a short run from the first state (on the constraints, when there are):
  -- 5 fixed steps of rk4, the same steps for both; a smooth system only
  local st = states[1]
  local ok, q0, qd0 = sys.smooth, st.q, st.qd
  if ok and a.nc > 0 then ok, q0, qd0 = pcall(b.project, b, st.t, st.q, st.qd) end
  if ok then
    local run = { q0 = q0, qd0 = qd0, t0 = st.t, t1 = st.t + 0.05, dt = 0.05, method = "rk4", step = 0.01,
      progress = false }
    compare("a run of 0.05", st, function() local tr = a:simulate(run); return { tr.q[#tr.q], tr.qd[#tr.qd] } end,
      function() local tr = b:simulate(run); return { tr.q[#tr.q], tr.qd[#tr.qd] } end, M.RUN_TOL)
  end
  -- every function is recorded: none may fall back (its operations all
  -- record) unless it fails at the check states itself (nz.log(-1))
  for _, rec in ipairs(a.recording) do
    if not rec.recorded and tostring(rec.why):find("^gives ") then
      findings[#findings + 1] = { what = rec.label .. " fell back to Lua", state = "", why = tostring(rec.why) }
    end
  end
  return findings, count
end

-- Run `n` random systems from `seed`: the findings (each with the system's
-- source), the comparisons made, the systems tried and those nz.system
-- refused in both forms (a constraint that constrains nothing, ...).
function M.run(seed, n, opts)
  opts = opts or {}
  local r = systems.rng(seed)
  local all, comparisons, refused = {}, 0, 0
  for i = 1, n do
    local sys = systems.system(r, opts.depth)
    local oka, a = pcall(sys.make, true)
    local okb, b = pcall(sys.make, false)
    if rawequal(a, core.interrupted) or rawequal(b, core.interrupted) then error(core.interrupted, 0) end
    if oka ~= okb then
      all[#all + 1] = { system = sys.source, index = i, what = "nz.system", state = "",
        why = oka and ("made when recorded, refused in Lua: " .. tostring(b)) or ("refused when recorded: " .. tostring(a)) }
    elseif not oka then
      refused = refused + 1
    else
      local states = systems.states(r, sys.k, opts.random or 2, opts.boundary or 2)
      local found, c = M.system(r, sys, a, b, states)
      comparisons = comparisons + c
      for _, f in ipairs(found) do
        f.system, f.index = sys.source, i
        all[#all + 1] = f
      end
    end
    if opts.progress then opts.progress(i, #all) end
  end
  return all, comparisons, n, refused
end

-- A finding as text: what differed, where, and the system's source.
function M.describe(f)
  return ("system %d: %s%s: %s\n%s"):format(f.index, f.what, f.state ~= "" and (" at " .. f.state) or "", f.why,
    f.system)
end

return M
