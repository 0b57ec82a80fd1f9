-- nz/model/constraints.lua - what the constraints of a system are and what they
-- demand (docs/theory.md §6-§9): classification by jets at sample states,
-- Dolapchiev's rule, the reduced form of Tsenov, projection onto the
-- constraints, and the energy balance with moving constraints.
--
-- Nothing here reads source text: the order m of a constraint is the
-- highest derivative slot whose partial derivative is not zero at the sample
-- states, and it is linear in q^(m) when its second derivative along
-- q^(m) + s v (the curvature) vanishes for random v.
local core = require "nz.core"
local mech = core.mech

local M = {}

-- Defaults, documented in help(nz.system).
M.SAMPLES = 5              -- sample states for the classification, per anchor state
M.MAX_ANCHORS = 8          -- the user's states that add samples near them
-- A slot counts when |dPhi/dq^(j)| s_j > TOL x S, s_j the typical size of
-- q^(j) and S the largest such contribution (Phi's own value is no part of
-- S: a big constant hides no dependence).  Jets give the partials exactly up
-- to rounding: an absent dependence gives 0, one that cancels (sin^2 + cos^2)
-- a few eps times its terms; 32 eps (7e-15) sits above that rounding and
-- still sees 1e6 (q1 - q2) + 1e-6 q1' (ratio 5e-13) as first order.
M.TOL = 32 * 2 ^ -52
M.ZERO = 1e-11             -- a force Jacobian or dL/dt below this counts as zero
M.PROJECT_TOL = 1e-12      -- projection stops when the violation is below this
M.CHECK_TOL = 1e-8         -- a start state may violate a constraint by this much of its terms

local order_words = { [0] = "holonomic (of order 0)", "of first order", "of second order", "of third order" }
local top_words = { [0] = "the coordinates", "the velocities", "the accelerations", "the third derivatives q'''" }
local equation_names = {
  [1] = "Nielsen's equations", [2] = "Tsenov's equations", [3] = "the equations with the jerk q'''",
}
M.equation_names = equation_names

-- ------------------------------------------------------------------ --
-- Derivative slots                                                     --

M.MIN_SLOTS = 4            -- every constraint receives q, qd, qdd, qddd at least
M.MAX_SLOTS = 50           -- q .. q^(49): far beyond any use, keeps jets small

-- A parameter name that reads as a derivative level: q4d, qdddd, q5 ...
local function names_a_level(name) return name ~= nil and name:match("^q[%dd]+$") ~= nil end

-- The derivative slots each constraint receives.  Rule: every declared
-- parameter after t is a level q, q', q'', ... except the last when there
-- are six or more, which is params; at least q .. q''' are given, so
-- function(t, q, qd, qdd, qddd, params) keeps its meaning, and a constraint
-- on q^(4) is function(t, q, qd, qdd, qddd, q4d, params).  params always
-- comes right after the last level.
function M.levels(list, name)
  local out = {}
  for r, f in ipairs(list) do
    local info = debug.getinfo(f, "u")
    local np = info.nparams or 0
    local n = math.max(M.MIN_SLOTS, np - 2)
    if np >= 6 and names_a_level(debug.getlocal(f, np)) then
      error(("nz.system '%s': constraint %d declares %d parameters and its last, '%s', receives params "
        .. "(parameters after t are q, qd, qdd, ..., and the last from the 6th on is params): a constraint on "
        .. "q^(%d) declares params after it, e.g. function(t, q, qd, qdd, qddd, q4d, params)"):format(
        name, r, np, debug.getlocal(f, np), np - 2), 3)
    end
    if n > M.MAX_SLOTS then
      error(("nz.system '%s': constraint %d asks for %d derivative slots (at most %d)"):format(name, r, n, M.MAX_SLOTS), 3)
    end
    out[r] = n
  end
  return out
end

local function slots_of(sys)
  local n = M.MIN_SLOTS
  for _, v in ipairs(sys.constraint_levels or {}) do n = math.max(n, v) end
  return n
end

-- A state's levels beyond q''' as the `higher` argument of the C functions.
local function higher_of(levels)
  if #levels <= 4 then return nil end
  return { table.unpack(levels, 5) }
end
M.higher_of = higher_of

-- A small deterministic generator: the classification must not depend on
-- the user's math.random state, and must repeat from run to run.
local function generator(seed)
  local x = seed
  return function(a, b)
    x = (x * 1103515245 + 12345) % 2147483648
    return a + (b - a) * (x / 2147483648)
  end
end
M.generator = generator

local function max_abs(v) local m = 0; for i = 1, #v do m = math.max(m, math.abs(v[i])) end; return m end

-- The name of level j (1-based: q, qd, qdd, qddd, q4d, q5d, ...), as in a
-- sample state or simulate's options.
local function level_name(j) return ({ "q", "qd", "qdd", "qddd" })[j] or ("q" .. (j - 1) .. "d") end

-- The state the samples spread around: sys.sample, or one of the user's.
local function anchor_from(sys, st)
  local base = sys.sample or {}
  local a = { t = st.t or base.t or 0.3 }
  for j = 1, slots_of(sys) do
    local name = level_name(j)
    local given, b, v = st[name], base[name] or {}, {}
    for i = 1, sys.k do v[i] = given and given[i] or b[i] or 0.2 * j end
    a[j] = v
  end
  return a
end

local function anchors(sys)
  if not sys._anchors then sys._anchors = { anchor_from(sys, {}) } end
  return sys._anchors
end
-- The first: the sample state a new system's functions are tried at (nz/model/probe.lua).
function M.anchor(sys) return anchors(sys)[1] end

-- n states near an anchor: every slot moves by up to 1, and every other
-- sample time by up to 10, so that a dependence on t switched on away from
-- the anchor's time (a ramp) is seen.
local function samples_near(sys, a, n, rand)
  local states = {}
  for s = 1, n do
    local st = { t = a.t + rand(-0.5, 0.5) * (s % 2 == 0 and 20 or 1) }
    for j = 1, slots_of(sys) do
      local v = {}
      for i = 1, sys.k do v[i] = a[j][i] + rand(-1, 1) end
      st[j] = v
    end
    states[s] = st
  end
  return states
end

local function sample_states(sys, n)
  return samples_near(sys, anchors(sys)[1], n, generator(20261122))
end
M.sample_states = sample_states   -- {t =, [1] = q, [2] = qd, ...}: for nz/analysis/rumyantsev.lua too

-- A state close to an anchor (within the samples' spread) adds nothing.
local function near_anchor(sys, a, st)
  if math.abs((st.t or a.t) - a.t) > 10 then return false end
  for j = 1, slots_of(sys) do
    local v = st[level_name(j)]
    if v then
      for i = 1, sys.k do
        if v[i] and math.abs(v[i] - a[j][i]) > 1 then return false end
      end
    end
  end
  return true
end

local function slot_sizes(st)
  local sizes = {}
  for j = 1, #st do sizes[j] = math.max(max_abs(st[j]), 1) end
  return sizes
end

local function vector_text(v) return require("nz.base.text").list(v, "%.6g") end

local function fmt_state(st)
  local vec = vector_text
  return ("t = %.6g, q = %s, qd = %s, qdd = %s"):format(st.t, vec(st[1]), vec(st[2]), vec(st[3]))
end

-- Errors of the jet functions outside their domain (lua_jet.c): a sample
-- state the constraint cannot take, which a typical state avoids.
local domain_errors = { "of a negative value", "of a non%-positive value", "outside %[%-1, 1%]",
  "outside its domain", "is not differentiable", "whose constant term is zero" }
local function is_domain_error(msg)
  for _, pat in ipairs(domain_errors) do if tostring(msg):find(pat) then return true end end
  return false
end

-- The constraint could not be evaluated at the sample states: say what it
-- returned or raised, at the user's file:line, and suggest a typical state
-- only when it fails for want of one (a domain error at every sample).
local function evaluation_failure(sys, r, failures, tried)
  local prefix = ("system '%s': %s"):format(sys.name, sys.engine.labels.constraints[r] or ("constraint %d"):format(r))
  local f, all_domain = failures[1], true
  for _, e in ipairs(failures) do
    if not is_domain_error(e.msg) then
      if all_domain then f = e end
      all_domain = false
    end
  end
  local msg, st = tostring(f.msg), f.state
  local fn = sys.engine.constraints[r]
  local defined = type(fn) == "function" and require("nz.base.where").defined(fn)   -- the user's, not a wrapper's
  local where = defined and defined .. ": " or ""
  -- The evaluator's words (lua_system.c): "raised an error: <error> at t = ...".
  local raised = msg:match("raised an error: (.-) at t = ")
  local loc, text
  if raised then loc, text = raised:match("^([^:]+:%d+): (.*)$") end
  where = loc and loc .. ": " or where
  text = text or raised
  if all_domain then
    return ("%s%s cannot be evaluated at %d of %d sample states (%s, at %s): give a typical "
      .. "state where it is defined as sample = {t = ..., q = {...}, qd = {...}} in nz.system")
      :format(where, prefix, #failures, tried, text or msg, fmt_state(st))
  elseif raised then
    return ("%s%s raised an error at %s: %s"):format(where, prefix, fmt_state(st), text)
  end
  -- It returned something else than a number or a jet: call it once more
  -- on plain numbers to say what.
  local args, nlev = { st.t }, (sys.constraint_levels or {})[r] or M.MIN_SLOTS
  for j = 1, nlev do args[j + 1] = st[j] end
  args[nlev + 2] = sys.params
  local ok, got = pcall(fn, table.unpack(args, 1, nlev + 2))
  if ok and type(got) ~= "number" and not core.isjet(got) then
    local what = got == nil and "nil" or type(got) == "string" and ("'%s' (a string)"):format(got)
      or ("%s (a %s)"):format(tostring(got), type(got))
    return ("%s%s returned %s at %s: a constraint returns the value of Phi(t, q, qd, ...), "
      .. "a number"):format(where, prefix, what, fmt_state(st))
  end
  return ("%s%s could not be evaluated at the sample states: %s"):format(where, prefix, msg)
end

-- Constraint r's partial derivatives vanish at every sample state: it
-- constrains nothing there, which may be all it ever does (0 * qd) or a
-- factor that is zero there and not elsewhere ((t - 11) Phi): say which
-- states were tried and how to show it one where it acts.
local function vanishing(sys, r, rows)
  local lo, hi = math.huge, -math.huge
  for _, row in ipairs(rows) do lo, hi = math.min(lo, row.state.t), math.max(hi, row.state.t) end
  -- Not zero there, it can never hold: Phi = 1 is no harmless constraint
  -- but an impossible one (nothing moves its value to 0).  "Zero" leaves
  -- rounding (M.TOL) to an expression like (q1 + 0.1) - q1 - 0.1.
  local worst
  for _, row in ipairs(rows) do
    if math.abs(row.value) > M.TOL and (not worst or math.abs(row.value) > math.abs(worst.value)) then worst = row end
  end
  if worst then
    return ("%ssystem '%s': constraint %d is inconsistent: it depends on no coordinate or derivative at the %d "
      .. "sample states (t from %.3g to %.3g) and is not zero there (Phi = %.6g at %s), so Phi = 0 can never "
      .. "hold: a constraint returns the expression that must vanish (q[1] - 1 for q1 = 1, not 1); check what it "
      .. "returns"):format(M.user_where(), sys.name, r, #rows, lo, hi, worst.value, fmt_state(worst.state))
  end
  return ("%ssystem '%s': constraint %d depends on no coordinate or derivative at the %d sample states "
    .. "(t from %.3g to %.3g): its partial derivatives vanish there; if it is switched on elsewhere "
    .. "(a factor in t or q that is zero at these states), give a state where it acts as "
    .. "sample = {t = ..., q = {...}} in nz.system, else leave it out: it is zero there and constrains nothing")
    :format(M.user_where(), sys.name, r, #rows, lo, hi)
end

-- The highest slot constraint r depends on at one sample state (M.TOL), -1
-- for none, and S, the size of its largest term.
local function order_at(row)
  local contrib, S = {}, 0
  for j = 1, #row.partials do
    contrib[j] = 0
    for i = 1, #row.partials[j] do contrib[j] = contrib[j] + math.abs(row.partials[j][i]) end
    contrib[j] = contrib[j] * row.sizes[j]
    S = math.max(S, contrib[j])
  end
  for j = #row.partials, 1, -1 do
    if contrib[j] > M.TOL * S then return j - 1, S end
  end
  return -1, S
end

-- Classify constraint r: order, linearity in the top derivative, dependence
-- on t, homogeneity in the velocities (Euler's theorem, §9), with evidence.
-- The sample states spread around every anchor (sys.sample and the user's
-- states, see M.classify).
local function classify_one(sys, r)
  local e = sys.engine
  local rows, failures = {}, {}
  local rand = generator(20261122)
  for _, a in ipairs(anchors(sys)) do
    local got = 0
    for _, st in ipairs(samples_near(sys, a, 4 * M.SAMPLES, rand)) do
      if got >= M.SAMPLES then break end
      local ok, value, partials, dt = pcall(mech.constraint_partials, e, r, st.t, st[1], st[2], st[3], st[4], higher_of(st))
      if ok then
        rows[#rows + 1] = { state = st, value = value, partials = partials, dt = dt, sizes = slot_sizes(st) }
        got = got + 1
      else failures[#failures + 1] = { state = st, msg = value } end
    end
  end
  if #rows < 2 then error(evaluation_failure(sys, r, failures, #failures + #rows), 0) end
  local nslots = #rows[1].partials
  local c = { index = r, samples = #rows, norms = {}, orders_seen = {}, slots = nslots }
  for j = 1, nslots do c.norms[j] = 0 end
  for _, row in ipairs(rows) do
    local m, S = order_at(row)
    for j = 1, nslots do c.norms[j] = math.max(c.norms[j], max_abs(row.partials[j])) end
    row.order, row.S = m, S
    c.orders_seen[m] = (c.orders_seen[m] or 0) + 1
    c.depends_on_t = c.depends_on_t or math.abs(row.dt) * math.max(math.abs(row.state.t), 1) > M.TOL * S
  end
  local m, distinct = -1, 0
  for order in pairs(c.orders_seen) do m = math.max(m, order); distinct = distinct + 1 end
  c.order, c.consistent = m, distinct == 1
  if m < 0 then
    error(vanishing(sys, r, rows), 0)
  end
  -- Linearity in q^(m): the curvature c2 = v^T H v / 2 along a random v of
  -- the size of q^(m), against the size of Phi's terms at that state.
  local vrand = generator(7 + r)
  local nlinear = 0
  c.curvature = 0
  for _, row in ipairs(rows) do
    local v, st = {}, row.state
    for i = 1, sys.k do v[i] = vrand(-1, 1) * row.sizes[m + 1] end
    local _, c1, c2 = mech.constraint_curvature(e, r, m, st.t, st[1], st[2], st[3], st[4], v, higher_of(st))
    local size = math.max(row.S, math.abs(c1))
    local rel = size > 0 and math.abs(c2) / size or 0
    c.curvature = math.max(c.curvature, rel)
    if rel <= M.TOL then nlinear = nlinear + 1 end
  end
  c.linear = nlinear == #rows
  c.linear_consistent = nlinear == 0 or nlinear == #rows
  c.holonomic = m == 0
  -- Homogeneity in the velocities (§9): holonomic ones through Phi' =
  -- Phi_q q' + Phi_t, which is homogeneous of degree 1 iff Phi_t = 0;
  -- first-order ones by the ratio sum dPhi/dq' q' / Phi, constant for a
  -- homogeneous Phi (Euler's theorem).
  if m == 0 then
    c.homogeneous, c.degree = not c.depends_on_t, 1
  elseif m == 1 then
    local lo, hi = math.huge, -math.huge
    for _, row in ipairs(rows) do
      local euler = 0
      for i = 1, sys.k do euler = euler + row.partials[2][i] * row.state[2][i] end
      if math.abs(row.value) > 1e-8 * (math.abs(euler) + 1) then
        local d = euler / row.value
        lo, hi = math.min(lo, d), math.max(hi, d)
      elseif math.abs(euler) > 1e-8 then
        lo, hi = -math.huge, math.huge     -- Phi = 0 but Euler's sum is not: not homogeneous
      end
    end
    c.homogeneous = hi - lo <= 1e-8 * (1 + math.abs(hi))
    if c.homogeneous then c.degree = math.floor(0.5 * (lo + hi) * 1e6 + 0.5) / 1e6 end
  end
  c.needs = c.linear and math.max(m, 1) or m + 1
  return c
end

-- The classification, at sample states near sys.sample and, once they are
-- given, near the user's own states: state = {t =, q =, qd =} (what accel
-- and simulate start from) adds samples near it the first time it is far
-- from all anchors (up to M.MAX_ANCHORS), and the constraints are classified
-- again with them.  The check after every solve (constrained.c) covers the
-- states in between.
function M.classify(sys, state)
  if state and sys._classes then
    local list = anchors(sys)
    local near = #list >= M.MAX_ANCHORS + 1
    for _, a in ipairs(list) do near = near or near_anchor(sys, a, state) end
    if near then return sys._classes end
    list[#list + 1] = anchor_from(sys, state)
    sys._classes = nil
  elseif state then
    local list = anchors(sys)
    if not near_anchor(sys, list[1], state) then list[#list + 1] = anchor_from(sys, state) end
  end
  if sys._classes then return sys._classes end
  local classes = {}
  for r = 1, sys.nc do classes[r] = classify_one(sys, r) end
  sys._classes = classes
  return classes
end

function M.orders(sys, state)
  local orders, linear = {}, {}
  for r, c in ipairs(M.classify(sys, state)) do orders[r], linear[r] = c.order, c.linear end
  return orders, linear
end

-- What differs across the sample states, for the rule's text ("" if nothing).
local function variation(c)
  local notes = {}
  if not c.consistent then
    local seen = {}
    for order in pairs(c.orders_seen) do
      if order ~= c.order then
        seen[#seen + 1] = order < 0 and "depends on nothing" or ("is of order %d"):format(order)
      end
    end
    table.sort(seen)
    notes[#notes + 1] = ("its order differs across the %d sample states (at some it %s)"):format(c.samples,
      table.concat(seen, ", "))
  end
  if c.linear_consistent == false then
    notes[#notes + 1] = ("its linearity in %s differs across the sample states (linear at some, "
      .. "nonlinear at others)"):format(top_words[c.order] or ("q^(" .. c.order .. ")"))
  end
  if #notes == 0 then return "" end
  return " (but " .. table.concat(notes, ", and ") .. ": check the constraint; the accelerations are "
    .. "checked and the constraint classified again where they fail)"
end

-- Why constraint c needs the order it does; `alone` (the only reason the
-- rule gives) leaves out the equations, which the rule's sentence names.
local function describe_need(c, alone)
  local what = order_words[c.order] or ("of order " .. c.order)
  if c.order == 0 then
    return ("constraint %d is holonomic: after differentiation it is linear in every derivative%s%s"):format(c.index,
      alone and "" or ", so Nielsen's equations suffice (n = 1)", variation(c))
  end
  local lin = c.linear and "linear" or "nonlinear"
  local eq = equation_names[c.needs] or ("the generalized equations of order " .. c.needs)
  return ("constraint %d is %s and %s in %s%s%s"):format(c.index, what, lin,
    top_words[c.order] or ("q^(" .. c.order .. ")"), alone and "" or (": %s, n = %d"):format(eq, c.needs), variation(c))
end

-- Does any force depend on the velocities (at the sample states)?
local function forces_depend_on_velocity(sys)
  if sys.pieces.Q == 0 then return false end
  for _, st in ipairs(sample_states(sys, 3)) do
    local J = mech.force_velocity_jacobian(sys.engine, st.t, st[1], st[2])
    for i = 1, sys.k do if max_abs(J[i]) > M.ZERO then return true end end
  end
  return false
end

-- Dolapchiev's criterion (docs/theory.md §8).  opts.extremal: the extremal form
-- (4.3) is wanted, which needs forces free of q^(n).
function M.rule(sys, opts)
  local lines, n = {}, 1
  local classes = M.classify(sys)
  local alone = #classes == 1 and not (opts and opts.extremal and forces_depend_on_velocity(sys))
  for _, c in ipairs(classes) do
    lines[#lines + 1] = describe_need(c, alone)
    n = math.max(n, c.needs)
  end
  if #lines == 0 then lines[1] = "the system has no constraints (and every order gives the same equations)" end
  if opts and opts.extremal and n == 1 and forces_depend_on_velocity(sys) then
    n = 2
    lines[#lines + 1] = "the forces depend on the velocities, so the extremal form (4.3) needs one order more (n = 2)"
  end
  -- One sentence says the order and why; with several constraints a second
  -- one gives each constraint's own order (the largest decides).
  local principle = M.principle(n)
  local text
  if #lines == 1 then
    text = ("Dolapchiev's rule: n = %d, %s, since %s."):format(n, principle, lines[1])
  else
    text = ("Dolapchiev's rule: n = %d, %s: the largest order needed.  %s."):format(n, principle,
      (table.concat(lines, "; "):gsub("^%l", string.upper)))
  end
  return n, text
end

-- A table of the classification, then the evidence of each constraint,
-- every line within 80 columns (as help's).
function M.report(sys)
  local table_text = require("nz.base.text").table
  local wrap = require("nz.base.text").wrap
  local rows = { { "#", "order", "kind", "top derivative", "homogeneous in qd" } }
  local evidence = {}
  local classes = M.classify(sys)
  for _, c in ipairs(classes) do
    local norms = {}
    for j = 1, #c.norms do norms[j] = ("%.2g"):format(c.norms[j]) end
    rows[#rows + 1] = {
      tostring(c.index), tostring(c.order), c.holonomic and "holonomic" or "nonholonomic",
      c.linear and "linear" or "nonlinear",
      c.homogeneous == nil and "n/a" or (c.homogeneous and ("yes, degree %g"):format(c.degree) or "no"),
    }
    evidence[#evidence + 1] = wrap(("%d: %s; curvature %.1g; %d states%s%s%s"):format(c.index, table.concat(norms, ", "),
      c.curvature, c.samples, c.depends_on_t and "; depends on t" or "",
      c.consistent and "" or "; ORDER DIFFERS ACROSS STATES: check the constraint",
      c.linear_consistent == false and "; LINEARITY DIFFERS ACROSS STATES" or ""), "  ", "     ")
  end
  local out = { ("System '%s': %d constraint%s"):format(sys.name, sys.nc, sys.nc == 1 and "" or "s"), table_text(rows) }
  if #classes > 0 then
    out[#out + 1] = wrap(("Evidence: the largest |dPhi/dq^(j)|, j = 0..%d, over the sample states; the curvature of "
      .. "Phi along q^(m) + s v against the size of its terms (0: linear in q^(m)):"):format(#classes[1].norms - 1), "", "")
    for _, e in ipairs(evidence) do out[#out + 1] = e end
  end
  return table.concat(out, "\n")
end

-- ------------------------------------------------------------------ --
-- Multipliers in the residual                                          --

-- A_{r,i} = dPhi_r/dq_i^(m_r) at the state (levels q, qd, qdd, qddd).
function M.gradients(sys, t, levels)
  local A = {}
  for r, c in ipairs(M.classify(sys)) do
    local _, partials = mech.constraint_partials(sys.engine, r, t, levels[1], levels[2], levels[3], levels[4], higher_of(levels))
    A[r] = partials[c.order + 1]
  end
  return A
end

-- The constraint forces of (6.2), A^T lambda (k values), at the state
-- (levels q, qd, qdd, ...) with the multipliers lambda.
function M.multiplier_terms(sys, t, levels, lambda)
  local A, f = M.gradients(sys, t, levels), {}
  for i = 1, sys.k do
    local s = 0
    for c = 1, sys.nc do s = s + A[c][i] * lambda[c] end
    f[i] = s
  end
  return f
end

-- ------------------------------------------------------------------ --
-- Projection onto the constraints                                      --

local function violations(sys, t, q, qd, which)
  local vals, rows = {}, {}
  for r, c in ipairs(M.classify(sys)) do
    if which(c) then
      local v, partials, dt = mech.constraint_partials(sys.engine, r, t, q, qd)
      vals[#vals + 1], rows[#rows + 1] = v, { c = c, partials = partials, dt = dt }
    end
  end
  return vals, rows
end

-- The nearest state (least change, Euclidean) that satisfies the holonomic
-- constraints at position and velocity level and the first-order ones at
-- velocity level, by Gauss-Newton steps of minimum norm.
function M.project(sys, t, q, qd, opts)
  local tol = opts and opts.tol or M.PROJECT_TOL
  local maxit = opts and opts.maxit or 50
  q, qd = { table.unpack(q) }, { table.unpack(qd) }
  local report = { position_iterations = 0, velocity_iterations = 0 }
  local function holonomic(c) return c.order == 0 end
  for it = 1, maxit + 1 do
    local vals, rows = violations(sys, t, q, qd, holonomic)
    if #vals == 0 or max_abs(vals) <= tol then break end
    if it > maxit then error(M.user_where() .. ("system '%s': projection onto the holonomic constraints did not converge in %d steps (violation %.3g at its last "
      .. "iterate q = %s): the constraints may have no common solution near the start (check them), or start nearer to one"):format(sys.name, maxit,
      max_abs(vals), vector_text(q)), 0) end
    local A, b = {}, {}
    for i, row in ipairs(rows) do A[i], b[i] = row.partials[1], -vals[i] end
    local dq = mech.lstsq(A, b)
    for i = 1, sys.k do q[i] = q[i] + dq[i] end
    report.position_iterations = it
  end
  -- Velocity level: holonomic Phi' = Phi_q q' + Phi_t and first-order Phi.
  local function velocity_level(c) return c.order <= 1 end
  for it = 1, maxit + 1 do
    local vals, rows = violations(sys, t, q, qd, velocity_level)
    if #vals == 0 then break end
    local A, b = {}, {}
    for i, row in ipairs(rows) do
      if row.c.order == 0 then
        local v = row.dt
        for j = 1, sys.k do v = v + row.partials[1][j] * qd[j] end
        vals[i], A[i] = v, row.partials[1]
      else
        A[i] = row.partials[2]
      end
      b[i] = -vals[i]
    end
    if max_abs(vals) <= tol then break end
    if it > maxit then error(M.user_where() .. ("system '%s': projection onto the velocity constraints did not converge in %d steps (violation %.3g) at q = %s: "
      .. "check that the velocity constraints can hold together there"):format(sys.name, maxit, max_abs(vals), vector_text(q)), 0) end
    local dv = mech.lstsq(A, b)
    for i = 1, sys.k do qd[i] = qd[i] + dv[i] end
    report.velocity_iterations = it
  end
  local top = sys.nc > 0 and M.top_level(sys)
  local p = sys.nc > 0 and M.level(sys)
  if top then M.project_top(sys, t, q, qd, top, opts, report)
  elseif p then M.project_levels(sys, t, q, qd, p, opts, report) end
  return q, qd, report
end

-- The first frame outside the library (the user's call): "file:line: ".
M.user_where = require("nz.base.where").user_where

-- The rows of constraint r of order <= 1 at position and velocity level
-- (a holonomic one at both), each with the size of its terms: the sum of
-- |dPhi/dq^(j)_i q^(j)_i| and |Phi|, as the classification weighs them.
-- calls f(value, size, level) for each.
local function state_rows(sys, r, order, t, q, qd, f)
  local v, partials, dt = mech.constraint_partials(sys.engine, r, t, q, qd)
  local size = math.abs(v)
  for j = 1, sys.k do
    size = size + math.abs(partials[1][j] * q[j])
    if order == 1 then size = size + math.abs(partials[2][j] * qd[j]) end
  end
  f(v, size, order == 0 and "position" or "velocity")
  if order == 0 then
    -- Phi' = Phi_t + Phi_q q': its terms, and the position terms' size
    -- over the time and velocity scales |q'| / |q| cannot be told apart
    -- from them, so the terms of Phi' alone.
    local d, dsize = dt, math.abs(dt)
    for j = 1, sys.k do
      d = d + partials[1][j] * qd[j]
      dsize = dsize + math.abs(partials[1][j] * qd[j])
    end
    f(d, dsize, "velocity")
  end
end

-- The largest violation of constraints of order <= 1 at position and
-- velocity level: {value, constraint, level}, absolute (what projection
-- drives to zero; a start state is checked relative to the terms, below).
function M.violation(sys, t, q, qd)
  local worst, which, level = 0, nil, nil
  for r, c in ipairs(M.classify(sys)) do
    if c.order <= 1 then
      state_rows(sys, r, c.order, t, q, qd, function(v, _, lev)
        if math.abs(v) > worst then worst, which, level = math.abs(v), r, lev end
      end)
    end
  end
  return worst, which, level
end

-- The worst row of the start state relative to its terms:
-- value, size, constraint, level.
local function worst_relative(sys, t, q, qd)
  local best = { rel = -1 }
  for r, c in ipairs(M.classify(sys)) do
    if c.order <= 1 then
      state_rows(sys, r, c.order, t, q, qd, function(v, size, lev)
        local x = math.abs(v) > 0 and math.abs(v) / size or 0
        if x > best.rel then best = { rel = x, value = math.abs(v), size = size, r = r, level = lev } end
      end)
    end
  end
  return best
end

-- A start state: every constraint of order <= 1 holds at position and
-- velocity level within tol of the size of its terms (rounding in a
-- circle of radius 3e5 is 1e-5 absolute, 1e-16 of its terms R^2).
function M.check_state(sys, t, q, qd, tol)
  tol = tol or M.CHECK_TOL
  local w = worst_relative(sys, t, q, qd)
  if w.rel > tol then
    error(("%ssystem '%s': the state at t = %s violates constraint %d at %s level by %.3g (%.3g of the size of "
      .. "its terms, %.3g; tolerance %.3g of it): start from a consistent state, e.g. q, qd = sys:project(t, q, qd)")
      :format(M.user_where(), sys.name, tostring(t), w.r, w.level, w.value, w.rel, w.size, tol), 0)
  end
end

-- ------------------------------------------------------------------ --
-- Constraints of order 3 and more: the motion at level p               --
-- (src/mech/constrained_series.h)                                           --

-- The name of the start option and of the report field for level j.
function M.level_name(j)
  if j == 0 then return "q" elseif j == 1 then return "qd" elseif j == 2 then return "qdd" end
  return "q" .. j .. "d"
end

-- The level p at which the motion is integrated: the highest order of a
-- constraint linear in its top derivative when that is 3 or more (nil
-- otherwise: the accelerations are a function of q and qd), and the first
-- constraint of order >= 3 that is nonlinear in its top derivative, if any
-- (its gradient depends on q^(m), so (6.2) does not close at any level).
function M.level(sys)
  local p, nonlinear = nil, nil
  for r, c in ipairs(M.classify(sys)) do
    if c.order >= 3 then
      if c.linear then p = math.max(p or 3, c.order) else nonlinear = nonlinear or r end
    end
  end
  return p, nonlinear
end

-- Constraints of order >= 3 nonlinear in their top derivative (src/
-- constrained_series.h, "top"): the level p is the highest such order; the
-- state is q .. q^(p-1) and (q^(p), lambda) are solved at each time.  nil
-- when there is none.  Every other constraint must be of order <= p (a
-- linear one of higher order would need (6.2) differentiated): an error
-- names the pair otherwise.
function M.top_level(sys)
  local p, which
  for r, c in ipairs(M.classify(sys)) do
    if c.order >= 3 and not c.linear and c.order > (p or 0) then p, which = c.order, r end
  end
  if not p then return nil end
  for r, c in ipairs(M.classify(sys)) do
    if c.order > p then
      error(M.user_where() .. ("system '%s': constraint %d (order %d, linear in q^(%d)) and constraint %d (order %d, nonlinear in "
        .. "q^(%d)) cannot be integrated together: the nonlinear one is solved with (6.2) undifferentiated at level %d, "
        .. "the linear one needs (6.2) differentiated %d times"):format(sys.name, r, c.order, c.order, which, p, p, p,
        c.order - 2), 0)
    end
  end
  return p, which
end

-- The rows of the constraints at the levels 2..p-1 of a top state (levels
-- q .. q^(p-1)): the worst |Phi_r^(l - m_r)| for m_r <= l, and where.
function M.top_rows(sys, t, levels, p)
  local orders, worst, at = M.orders(sys), 0, nil
  for l = 2, p - 1 do
    local res = mech.series_level(sys.engine, orders, l, t, { table.unpack(levels, 1, l + 1) }, nil)
    for r = 1, sys.nc do
      if orders[r] <= l and math.abs(res[sys.k + r]) > worst then worst, at = math.abs(res[sys.k + r]), { l = l, r = r } end
    end
  end
  return worst, at
end

-- A top start state: the constraints at levels 2..p-1 hold within tol
-- (those of levels 0, 1 are check_state's).  (6.2) puts no condition on
-- q'' .. q^(p-1): it is solved with q^(p) and lambda at each time.
function M.check_top_start(sys, t, levels, p, tol)
  tol = tol or M.CHECK_TOL
  local worst, at = M.top_rows(sys, t, levels, p)
  if worst > tol then
    local orders, given = M.orders(sys), {}
    for j = 2, p - 1 do given[#given + 1] = M.level_name(j) .. "0" end
    local d = at.l - orders[at.r]
    error(("%ssystem '%s': the start state at t = %s is inconsistent: constraint %d%s is violated by %.3g (tolerance %.3g): "
      .. "give %s that satisfy it, e.g. from sys:project(t0, q0, qd0, {qdd = ...})"):format(M.user_where(), sys.name, tostring(t), at.r,
      d == 0 and "" or (" differentiated %d time%s"):format(d, d == 1 and "" or "s"), worst, tol,
      table.concat(given, ", ")), 0)
  end
end

-- Complete a top start state: for l = 2..p-1 the smallest change of q^(l)
-- that satisfies the constraint rows of that level, by Gauss-Newton steps of
-- minimum norm (columns by central differences: a row is affine in q^(l)
-- unless the constraint is of order l and nonlinear there, as Hamel's).
function M.project_top(sys, t, q, qd, p, opts, report)
  local k, orders = sys.k, M.orders(sys)
  local levels = { q, qd }
  for j = 2, p - 1 do
    local v = opts and opts[M.level_name(j)]
    local copy = {}
    for i = 1, k do copy[i] = v and v[i] or 0 end
    levels[j + 1] = copy
  end
  local tol, maxit = opts and opts.tol or M.PROJECT_TOL, opts and opts.maxit or 50
  local its = 0
  for l = 2, p - 1 do
    local rows = {}
    for r = 1, sys.nc do if orders[r] <= l then rows[#rows + 1] = r end end
    local function residual()
      local res = mech.series_level(sys.engine, orders, l, t, { table.unpack(levels, 1, l + 1) }, nil)
      local out = {}
      for n, r in ipairs(rows) do out[n] = res[k + r] end
      return out
    end
    for it = 1, maxit + 1 do
      local b = residual()
      if #rows == 0 or max_abs(b) <= tol then break end
      if it > maxit then
        error(M.user_where() .. ("system '%s': completing %s of the start state did not converge in %d steps (violation %.3g)"):format(
          sys.name, M.level_name(l), maxit, max_abs(b)), 0)
      end
      local x, J = levels[l + 1], {}
      for n = 1, #rows do J[n] = {} end
      for j = 1, k do
        -- central differences are exact for affine and quadratic rows; a
        -- wide step keeps rounding (eps / h) near 1e-13
        local keep, hj = x[j], 1e-3 * (1 + math.abs(x[j]))
        x[j] = keep + hj
        local up = residual()
        x[j] = keep - hj
        local down = residual()
        x[j] = keep
        for n = 1, #rows do J[n][j] = (up[n] - down[n]) / (2 * hj) end
      end
      for n = 1, #rows do b[n] = -b[n] end
      local d = mech.lstsq(J, b)
      for i = 1, k do x[i] = x[i] + d[i] end
      its = its + 1
    end
    report[M.level_name(l)] = levels[l + 1]
  end
  report.level_iterations = its
end

-- What row `row` (1-based, from series_initial) of level l is, in words.
local function row_words(sys, orders, l, row)
  if row <= sys.k then
    return l == 2 and ("the equation of motion (6.2) for '%s' (no multipliers satisfy it with this qdd)"):format(sys.coords[row])
      or ("(6.2) differentiated %d time%s, for '%s'"):format(l - 2, l == 3 and "" or "s", sys.coords[row])
  end
  local r = row - sys.k
  local d = l - orders[r]
  return ("constraint %d%s"):format(r, d == 0 and "" or (" differentiated %d time%s"):format(d, d == 1 and "" or "s"))
end

-- The multipliers at a start state of level p (levels = {q, qd, qdd, ...},
-- p of them), after checking the equations of every level below p: an
-- error naming the first one violated by more than tol (relative).
function M.start_lambdas(sys, t, levels, p, tol)
  local orders = M.orders(sys)
  local lambdas, v = mech.series_initial(sys.engine, orders, p, t, levels)
  if v.value > (tol or M.CHECK_TOL) then
    local given = {}
    for j = 0, p - 1 do given[#given + 1] = M.level_name(j) .. "0" end
    error(("%ssystem '%s': the start state at t = %s is inconsistent: %s is violated by %.3g (tolerance %.3g, "
      .. "relative to its terms): give %s that satisfy the constraints and (6.2) at levels 0..%d, e.g. "
      .. "from sys:project(t0, q0, qd0, {qdd = ...}) (its report holds qdd and the multipliers)"):format(
      M.user_where(), sys.name, tostring(t), row_words(sys, orders, v.level, v.row), v.value, tol or M.CHECK_TOL,
      table.concat(given, ", "), p - 1), 0)
  end
  return lambdas
end

-- Along a motion of level p: the largest residual of the equations of levels
-- 2..p-1 (6.2) and its derivatives, and the constraints of order >= 2 with
-- theirs) with the state's own multipliers: the drift that level p leaves
-- free (the rows of level p hold to the solve's accuracy).  levels: q .. q^(p-1);
-- lambdas: lambda .. lambda^(p-3).
function M.level_violation(sys, t, levels, lambdas, p)
  local orders, worst = M.orders(sys), 0
  for l = 2, p - 1 do
    local res = mech.series_level(sys.engine, orders, l, t, levels, lambdas)
    for i = 1, sys.k do worst = math.max(worst, math.abs(res[i])) end
    for r = 1, sys.nc do if orders[r] <= l then worst = math.max(worst, math.abs(res[sys.k + r])) end end
  end
  return worst
end

-- Complete the higher levels of a start state (p >= 3): given q, qd (already
-- projected) and opts.qdd, opts.q3d, ... (0 when absent), the smallest
-- change of each level l = 2..p-1 that satisfies the equations of that
-- level (a level that does is kept as it is), its multipliers lambda^(l-2)
-- whatever the equations need.  Multipliers the caller chose (opts.lambda:
-- lambda; opts.lambdas: {lambda, lambda', ...}, a list per level or nil
-- there) count in the change: the least change of both together.
function M.project_levels(sys, t, q, qd, p, opts, report)
  local levels = { q, qd }
  for j = 2, p - 1 do
    local v = opts and opts[M.level_name(j)]
    if v == nil then v = {}; for i = 1, sys.k do v[i] = 0 end end
    levels[j + 1] = v
  end
  local tol = opts and opts.tol or M.PROJECT_TOL
  local chosen = opts and (opts.lambdas or (opts.lambda and { opts.lambda }))
  local out, lambdas, its = mech.series_project(sys.engine, M.orders(sys), p, t, levels, tol, opts and opts.maxit or 50,
    chosen)
  if not out then
    error(M.user_where() .. ("system '%s': completing the start state (qdd and higher, with the multipliers) did not converge in %d steps"):format(sys.name, lambdas), 0)
  end
  for j = 2, p - 1 do report[M.level_name(j)] = out[j + 1] end
  report.lambda, report.lambdas, report.level_iterations = lambdas[1], lambdas, its
end

-- ------------------------------------------------------------------ --
-- Tsenov's elimination (docs/theory.md §7)                                  --

-- Choose r dependent coordinates by Gauss-Jordan elimination with complete
-- pivoting on A (r x k), and return them with a = -A_dep^-1 A_ind (r x l)
-- and a0 = -A_dep^-1 b: q''_dep = a q''_ind + a0.
local function partition(A, b, k)
  local nc = #A
  local W, rhs = {}, {}
  for r = 1, nc do W[r] = { table.unpack(A[r]) }; rhs[r] = b[r] end
  local dep, used = {}, {}
  for r = 1, nc do
    local best, bc, br = 0, nil, nil
    for rr = r, nc do
      for j = 1, k do
        if not used[j] and math.abs(W[rr][j]) > best then best, bc, br = math.abs(W[rr][j]), j, rr end
      end
    end
    if not bc or best < 1e-12 then return nil end
    W[r], W[br], rhs[r], rhs[br] = W[br], W[r], rhs[br], rhs[r]
    local p = W[r][bc]
    for j = 1, k do W[r][j] = W[r][j] / p end
    rhs[r] = rhs[r] / p
    for rr = 1, nc do
      if rr ~= r and W[rr][bc] ~= 0 then
        local f = W[rr][bc]
        for j = 1, k do W[rr][j] = W[rr][j] - f * W[r][j] end
        rhs[rr] = rhs[rr] - f * rhs[r]
      end
    end
    dep[r], used[bc] = bc, true
  end
  local ind = {}
  for j = 1, k do if not used[j] then ind[#ind + 1] = j end end
  local a, a0 = {}, {}
  for r = 1, nc do
    a[r] = {}
    for l, j in ipairs(ind) do a[r][l] = -W[r][j] end
    a0[r] = -rhs[r]
  end
  return dep, ind, a, a0
end

-- Tsenov's elimination (7.1) once the constraint rows B x = b at the top
-- level are known: choose dependent components, write x by the independent
-- ones (x_dep = a x_ind + a0), combine the equations along the admissible
-- directions, which removes the multipliers, and solve the reduced
-- equations, affine in x_ind, by probing their columns.  equations(x)
-- gives the k equations at a full x.  Returns x and the report `info`
-- completed with the partition and the reduced matrix.
local function eliminate(sys, B, b, equations, info)
  local dep, ind, a, a0 = partition(B, b, sys.k)
  if not dep then error(M.user_where() .. ("system '%s': the constraints are dependent at this state: no set of dependent coordinates"):format(sys.name), 0) end
  local function full(xi)              -- x from its independent components
    local x = {}
    for l, j in ipairs(ind) do x[j] = xi[l] end
    for r, j in ipairs(dep) do
      local v = a0[r]
      for l = 1, #ind do v = v + a[r][l] * xi[l] end
      x[j] = v
    end
    return x
  end
  local function reduced_residual(xi)
    local res, out = equations(full(xi)), {}
    for l, j in ipairs(ind) do
      local v = res[j]
      for r, jr in ipairs(dep) do v = v + res[jr] * a[r][l] end
      out[l] = v
    end
    return out
  end
  local l = #ind
  local base, Mred, neg = {}, {}, {}
  for i = 1, l do base[i], Mred[i] = 0, {} end
  local r0 = reduced_residual(base)
  for c = 1, l do
    base[c] = 1
    local rc = reduced_residual(base)
    base[c] = 0
    for i = 1, l do Mred[i][c] = rc[i] - r0[i] end
  end
  for i = 1, l do neg[i] = -r0[i] end
  local xi = l > 0 and mech.lstsq(Mred, neg) or {}
  info.dependent, info.independent, info.a, info.a0, info.matrix, info.rhs = dep, ind, a, a0, Mred, neg
  return full(xi), info
end

-- Tsenov's elimination at level p >= 3: the equations of level p
-- (G^(p-2) = 0 and every Phi_r^(p - m_r) = 0, src/mech/constrained_series.h),
-- with q^(p) split by the constraint rows into dependent and independent
-- components and G^(p-2) combined along the admissible directions, which
-- removes lambda^(p-2) (its coefficient in G is A^T, in the rows A, by (2.1)).
-- The state's levels and lower multipliers come in opts.  The equations of
-- every form agree (§3), so `form` plays no part here.
local function reduced_level(sys, t, q, qd, p, opts)
  opts = type(opts) == "table" and opts or {}
  local k, levels = sys.k, { q, qd }
  for j = 2, p - 1 do
    levels[j + 1] = opts[M.level_name(j)]
    if levels[j + 1] == nil then
      error(M.user_where() .. ("system '%s': constraints of order %d make %s part of the state: give it, "
        .. "sys:reduced(t, q, qd, nil, {%s = ..., lambdas = {lambda, ...}})"):format(
        sys.name, p, M.level_name(j), M.level_name(j)), 0)
    end
  end
  local lambdas = opts.lambdas or (opts.lambda and { opts.lambda })
  if type(lambdas) ~= "table" or #lambdas < p - 2 then
    error(M.user_where() .. ("system '%s': constraints of order %d make the multipliers lambda .. lambda^(%d) part of the state: "
      .. "give lambdas = {...} (%d lists of %d)"):format(sys.name, p, p - 3, p - 2, sys.nc), 0)
  end
  local orders = M.orders(sys)
  local x = {}
  for i = 1, k do x[i] = 0 end
  levels[p + 1] = x
  local r0 = mech.series_level(sys.engine, orders, p, t, levels, lambdas)
  local Gx, B, b = {}, {}, {}
  for i = 1, k do Gx[i] = {} end
  for r = 1, sys.nc do B[r], b[r] = {}, r0[k + r] end
  for j = 1, k do                      -- affine in q^(p): columns by differences
    x[j] = 1
    local rj = mech.series_level(sys.engine, orders, p, t, levels, lambdas)
    x[j] = 0
    for i = 1, k do Gx[i][j] = rj[i] - r0[i] end
    for r = 1, sys.nc do B[r][j] = rj[k + r] - r0[k + r] end
  end
  return eliminate(sys, B, b, function(v)
    local G = {}
    for i = 1, k do
      local g = r0[i]
      for j = 1, k do g = g + Gx[i][j] * v[j] end
      G[i] = g
    end
    return G
  end, { level = p })
end

-- Accelerations from the reduced equations (7.1) of order n, without
-- multipliers: dK_n*/dq_l^(n) = dK_n/dq_l^(n) + sum_rho dK_n/dq_rho^(n) a_{rho,l}.
-- With constraints of order p >= 3: q^(p), from the equations of level p.
function M.reduced(sys, t, q, qd, n, form)
  local top = M.top_level(sys)
  if top then
    error(M.user_where() .. ("system '%s': a constraint of order %d nonlinear in q^(%d) fixes q^(%d) only together with its multiplier: "
      .. "Tsenov's elimination does not apply; use the multiplier form (sys:residual, sys:simulate)"):format(
      sys.name, top, top, top), 0)
  end
  local p = M.level(sys)
  if p then return reduced_level(sys, t, q, qd, p, form) end
  local classes = M.classify(sys)
  local A, b = {}, {}
  local zero = {}
  for i = 1, sys.k do zero[i] = 0 end
  for r, c in ipairs(classes) do
    if c.order > 2 or (c.order == 2 and not c.linear) then
      error(M.user_where() .. ("system '%s': Tsenov's elimination needs constraints linear at the acceleration level; "
        .. "constraint %d is not: use the multiplier form sys:accel"):format(sys.name, r), 0)
    end
    A[r], b[r] = mech.constraint_row(sys.engine, r, c.order, t, q, qd, zero)
  end
  return eliminate(sys, A, b, function(qdd) return sys:residual(n, t, q, qd, qdd, form) end, {})
end

-- ------------------------------------------------------------------ --
-- Energy with constraints (docs/theory.md §9)                               --

-- R_0 = d/dt(T1 + 2 T0) - dL/dt + sum_r lambda_r (dPhi_r/dq^(m_r) . q'), eq. (9.1).
function M.reaction_power(sys, t, q, qd, qdd, lambda)
  local dLdt, _, _, rate = mech.energy_terms(sys.engine, t, q, qd, qdd)
  local R0 = rate - dLdt
  if sys.nc > 0 then
    local A = M.gradients(sys, t, { q, qd, qdd })
    for r = 1, sys.nc do
      local p = 0
      for i = 1, sys.k do p = p + A[r][i] * qd[i] end
      R0 = R0 + lambda[r] * p
    end
  end
  return R0
end

-- Whether H = h is a first integral: L free of t, constraints homogeneous.
function M.energy_conditions(sys, t, q, qd)
  local dLdt = mech.energy_terms(sys.engine, t, q, qd)
  local cond = { explicit_t = dLdt, homogeneous = true, reasons = {} }
  if math.abs(dLdt) > M.ZERO * 1e3 then
    cond.reasons[#cond.reasons + 1] = ("L depends on t explicitly (dL/dt = %.6g)"):format(dLdt)
  end
  for _, c in ipairs(M.classify(sys)) do
    if c.homogeneous == false or c.homogeneous == nil then
      cond.homogeneous = false
      cond.reasons[#cond.reasons + 1] = ("constraint %d is not homogeneous in the velocities"):format(c.index)
    end
  end
  cond.holds = #cond.reasons == 0
  return cond
end

-- The name of the equations of order n, as the rule and the reports say it.
local principles = {
  [1] = "Nielsen's equations (Jourdain's principle)",
  [2] = "Tsenov's equations (Gauss's principle)",
  [3] = "equations with the jerk q''' (generalized Gauss principle of order 3)",
}
function M.principle(n)
  return principles[n] or ("generalized Lagrange equations of order %d (d'Alembert principle for the %d-th derivatives)"):format(n, n)
end


return M
