-- nz/record.lua - record a system's functions once as an expression graph,
-- evaluated in C from then on (src/graph/graph.c, src/mech/mech_graph.c).
--
-- Each function (T, V, L, Q, each constraint) runs once on tracer values:
-- t, every derivative slot of every q_i and every named number in params
-- are graph inputs, and every operation on a tracer adds a node; the branch
-- functions (nz.gt, nz.ifelse, nz.max, nz.min, nz.clamp, nz.sign) add
-- comparison and selection nodes.  What the graph cannot hold -- a Lua
-- comparison (a Lua branch on the state), math.* on
-- a traced value, a jet method, text -- stops that function's recording:
-- it keeps the Lua evaluation, and the reason is kept for print(sys).
--
-- A number the function reads from an upvalue or a global is baked into
-- the graph as a constant; params.x stays an input (change sys.params.x and
-- the next call sees it).  A recording is then checked against the Lua
-- function at a sample state; a function whose value depends on anything
-- but its arguments (a counter, math.random) fails that check and stays in
-- Lua.
local core = require "nz.core"

local M = {}

-- Relative agreement a recording must show with its function at the check.
M.CHECK_TOL = 1e-9

-- ------------------------------------------------------------------ --
-- Tracers                                                              --

local TR = { __name = "nz.traced" }
local function is_tr(x) return getmetatable(x) == TR end
local function wrap(c, id) return setmetatable({ c = c, id = id }, TR) end

-- An operation the graph cannot hold: the recorder's handler turns the
-- message into the reason, with the user's file:line.
local function untraceable(msg) error(msg, 0) end

local function kind(x)
  if core.isjet(x) then return "jet" end
  return type(x)
end

local function operand(c, x)
  if is_tr(x) then return x.id end
  if type(x) == "number" then return c:const(x) end
  untraceable(("arithmetic of a traced value with a %s"):format(kind(x)))
end

-- A number type of its own on the other side (nz/hyperdual.lua) takes the
-- call, as it does for jets.
local function foreign(a, b, field)
  local other = is_tr(a) and b or a
  if type(other) == "table" and not is_tr(other) then
    local mt = getmetatable(other)
    return mt and mt[field]
  end
end

local function binop(name, field)
  return function(a, b)
    local f = foreign(a, b, field)
    if f then return f(a, b) end
    local c = (is_tr(a) and a or b).c
    return wrap(c, c:op(name, operand(c, a), operand(c, b)))
  end
end

TR.__add = binop("add", "__add")
TR.__sub = binop("sub", "__sub")
TR.__mul = binop("mul", "__mul")
TR.__div = binop("div", "__div")
TR.atan2 = binop("atan2", "atan2")
TR.hypot = binop("hypot", "hypot")
local pow = binop("pow", "__pow")
TR.__pow = function(a, b)
  if is_tr(a) and type(b) == "number" then return wrap(a.c, a.c:powc(a.id, b)) end
  return pow(a, b)
end
TR.__unm = function(a) return wrap(a.c, a.c:op("neg", a.id)) end
for _, name in ipairs{ "exp", "log", "sqrt", "sin", "cos", "tan", "asin", "acos", "atan",
                       "sinh", "cosh", "tanh", "abs", "sign" } do
  TR[name] = function(x) return wrap(x.c, x.c:fn(name, x.id)) end
end

-- Branches written without a Lua `if` (nz.lt ... nz.clamp, src/lua/lua_jet.c):
-- nz.* hands the call to the first table argument whose metatable has the
-- field, so a tracer may be any of the arguments; the others are numbers.
-- The same choices as the jets: max and min keep the first operand at a
-- tie, clamp keeps x at a tie with a bound.
local function graph_of(...)
  for i = 1, select("#", ...) do
    local x = select(i, ...)
    if is_tr(x) then return x.c end
  end
end

local function branch_operand(c, x, fname)
  if type(x) == "boolean" then
    untraceable(("nz.%s got a boolean (a Lua comparison such as x > 0 cannot be recorded): "
      .. "write the condition with nz.gt(x, 0), nz.lt, nz.ge or nz.le"):format(fname))
  end
  return operand(c, x)
end

for _, name in ipairs{ "lt", "le", "gt", "ge" } do
  TR[name] = function(a, b)
    local c = graph_of(a, b)
    return wrap(c, c:cmp(name, branch_operand(c, a, name), branch_operand(c, b, name)))
  end
end

-- ifelse(cond, a, b): a where cond ~= 0, else b (a constant cond chooses now).
local function ifelse(c, cond, a, b, fname)
  return c:select(branch_operand(c, cond, fname), branch_operand(c, a, fname), branch_operand(c, b, fname))
end

function TR.ifelse(cond, a, b)
  local c = graph_of(cond, a, b)
  return wrap(c, ifelse(c, cond, a, b, "ifelse"))
end

local function extremum(kind, fname)
  return function(a, b)
    local c = graph_of(a, b)
    local ia, ib = branch_operand(c, a, fname), branch_operand(c, b, fname)
    return wrap(c, c:select(c:cmp(kind, ia, ib), ia, ib))
  end
end
TR.max = extremum("ge", "max")   -- max(a, b) = select(a >= b, a, b)
TR.min = extremum("le", "min")   -- min(a, b) = select(a <= b, a, b)

-- clamp(x, lo, hi) = lo where x < lo, hi where x > hi, else x; lo <= hi is
-- checked now when the bounds are numbers.  Bounds that are traced (params,
-- the state) would need that check at every evaluation, which a graph does
-- not make: such a clamp stays in Lua, and min(max(x, lo), hi) records.
function TR.clamp(x, lo, hi)
  local c = graph_of(x, lo, hi)
  local ix, ilo, ihi = branch_operand(c, x, "clamp"), branch_operand(c, lo, "clamp"), branch_operand(c, hi, "clamp")
  local vlo, vhi = c:constant(ilo), c:constant(ihi)
  if not (vlo and vhi) then
    untraceable("nz.clamp with bounds that are traced (params or the state): its check lo <= hi "
      .. "cannot be recorded; write nz.min(nz.max(x, lo), hi), which records")
  end
  if vlo > vhi then
    untraceable(("nz.clamp: the lower bound %.17g is above the upper bound %.17g (clamp(x, lo, hi) "
      .. "needs lo <= hi)"):format(vlo, vhi))
  end
  local below = c:select(c:cmp("lt", ix, ilo), ilo, ix)
  return wrap(c, c:select(c:cmp("gt", ix, ihi), ihi, below))
end

local BRANCH = "compares a traced value (a Lua branch on the state cannot be recorded): "
  .. "write it with nz.ifelse and nz.gt/lt/ge/le, nz.max, nz.min, nz.clamp or nz.sign"
TR.__lt = function() untraceable(BRANCH) end
TR.__le = TR.__lt
TR.__eq = TR.__lt
TR.__index = function(_, key)
  untraceable(("reads field '%s' of a traced value (jet methods cannot be recorded)"):format(tostring(key)))
end
TR.__newindex = function() untraceable("writes into a traced value") end
TR.__len = function() untraceable("takes the length of a traced value") end
TR.__concat = function() untraceable("makes text of a traced value") end
TR.__call = function() untraceable("calls a traced value") end
TR.__tostring = TR.__concat
TR.__idiv = function() untraceable("floor-divides a traced value (not differentiable)") end
TR.__mod = function() untraceable("takes a traced value modulo (not differentiable)") end

-- ------------------------------------------------------------------ --
-- Running a function on tracers                                        --

local function library(src) return src:sub(1, 8) == "@lua/nz/" or src == "=[C]" end

-- The reason a recording stopped, with the user's file:line.
local function handler(e)
  if rawequal(e, core.interrupted) then return e end   -- Ctrl-C stays Ctrl-C
  local where
  for level = 2, 60 do
    local info = debug.getinfo(level, "Sl")
    if not info then break end
    if info.currentline > 0 and not library(info.source) then
      where = ("%s:%d"):format(info.short_src, info.currentline)
      break
    end
  end
  local msg = tostring(e)
  if where and msg:sub(1, #where + 2) == where .. ": " then msg = msg:sub(#where + 3) end
  -- math.* on a tracer: "number expected, got nz.traced" (its __name)
  if msg:find("number expected, got table", 1, true) or msg:find("number expected, got nz.traced", 1, true) then
    msg = msg .. " (math.* takes numbers only: use nz.sin, nz.sqrt, nz.abs, ... on the state)"
  end
  return where and (msg .. " at " .. where) or msg
end

local function param_proxy(c, params, index)
  return setmetatable({}, {
    __index = function(_, key)
      local p = index[key]
      if p then return wrap(c, c:param(p)) end
      local v = params[key]
      if v ~= nil then untraceable(("reads params.%s, a %s: only numbers are recorded"):format(tostring(key), type(v))) end
      return nil
    end,
    __newindex = function(_, key) untraceable(("writes params.%s"):format(tostring(key))) end,
    __pairs = function() untraceable("iterates over params") end,
  })
end

-- The node of a returned value, or nil and why.
local function result_node(c, v)
  if is_tr(v) then return v.id end
  if type(v) == "number" then
    if v ~= v or v == math.huge or v == -math.huge then return nil, "returns a value that is not finite" end
    return c:const(v)
  end
  return nil, ("returns a %s"):format(kind(v))
end

-- Record f: nodes (1, or k for Q) or nil and the reason.
local function record_function(c, f, nslots, k, pproxy, is_Q)
  local args = { wrap(c, c:time()) }
  for j = 0, nslots - 1 do
    local level = {}
    for i = 1, k do level[i] = wrap(c, c:slot(j, i)) end
    args[j + 2] = level
  end
  args[nslots + 2] = pproxy
  local ok, res = xpcall(f, handler, table.unpack(args, 1, nslots + 2))
  if not ok then
    if rawequal(res, core.interrupted) then error(res, 0) end
    return nil, res
  end
  if not is_Q then
    local id, why = result_node(c, res)
    if not id then return nil, why end
    return { id }
  end
  if type(res) ~= "table" or getmetatable(res) ~= nil or #res ~= k then
    return nil, "does not return a list of " .. k .. " forces"
  end
  local ids = {}
  for i = 1, k do
    local id, why = result_node(c, res[i])
    if not id then return nil, ("force %d %s"):format(i, why) end
    ids[i] = id
  end
  return ids
end

-- ------------------------------------------------------------------ --
-- Checking a recording against its function                           --

-- A state that is not special (no zeros, no symmetries), for slot j of q_i.
local function sample(j, i) return 0.31 + 0.17 * i - 0.043 * j + 0.011 * i * j end
local SAMPLE_T = 0.23

local function check(c, f, ids, nslots, k, names, params, is_Q)
  local inputs = { [0] = SAMPLE_T }
  for p, name in ipairs(names) do inputs[p] = params[name] end
  local np = #names
  local args = { SAMPLE_T }
  for j = 0, nslots - 1 do
    local level = {}
    for i = 1, k do
      level[i] = sample(j, i)
      inputs[1 + np + j * k + (i - 1)] = level[i]
    end
    args[j + 2] = level
  end
  args[nslots + 2] = params
  local ok, res = pcall(f, table.unpack(args, 1, nslots + 2))
  if not ok and rawequal(res, core.interrupted) then error(res, 0) end
  if not ok then return true end     -- no verdict where the function itself fails
  local got = c:eval(ids, inputs)
  if not got then return true end
  -- Q returns its list of k forces (a list of one with one coordinate)
  local want = is_Q and res or { res }
  if type(want) ~= "table" then want = {} end
  for o = 1, #ids do
    local a, b = got[o], want[o]
    if type(b) ~= "number" or math.abs(a - b) > M.CHECK_TOL * math.max(1, math.abs(a), math.abs(b)) then
      return false, ("gives %s where its recording gives %.17g at a sample state: it depends on something "
        .. "other than its arguments (a global that changes, math.random, a counter)"):format(tostring(b), a)
    end
  end
  return true
end

-- ------------------------------------------------------------------ --
-- A system                                                             --

-- Record what can be recorded of engine (the definition table the C
-- mechanics reads; lua/nz/system.lua): sets engine.compiled,
-- engine.compiled_params, engine.compiled_mass_bias, and returns the report
-- { {label =, compiled =, why =, nodes =}, ..., seconds =, nodes = }.
-- The parameters a recording reads as inputs: the named numbers of params,
-- in a fixed (sorted) order, and each name's input number.
local function recorded_params(params)
  local names, index = {}, {}
  for name, v in pairs(params) do
    if type(name) == "string" and type(v) == "number" then names[#names + 1] = name end
  end
  table.sort(names)
  for p, name in ipairs(names) do index[name] = p end
  return names, index
end

function M.compile(engine, levels, native)
  local clock = os.clock()
  local k = engine.k
  local names, index = recorded_params(engine.params)
  -- two slots more than any function reads: the rows of the constraints
  -- differentiate them twice along the motion (src/mech/mech_graph.c)
  local nslots = 2
  for _, n in ipairs(levels) do nslots = math.max(nslots, n) end
  nslots = nslots + 2
  local c = core.mech.compiled_new(k, #names, #engine.constraints, nslots)
  if native ~= nil then c:set_native(native) end
  local pproxy = param_proxy(c, engine.params, index)

  local done, report = {}, { seconds = 0 }
  -- Each function once (T's functions are also F's), with its verdict.
  local function record(f, label, slots, is_Q)
    if done[f] then return done[f] end
    local ids, why = record_function(c, f, slots, k, pproxy, is_Q)
    if ids then
      local ok, bad = check(c, f, ids, slots, k, names, engine.params, is_Q)
      if not ok then ids, why = nil, bad end
    end
    done[f] = { ids = ids, why = why, label = label }
    report[#report + 1] = { label = label, compiled = ids ~= nil, why = why }
    return done[f]
  end
  -- A piece is compiled when every one of its functions is: the sum of theirs.
  local function piece(name, list, labels, slots, index1)
    local sum
    for fi, f in ipairs(list) do
      local r = record(f, labels[fi] or name, slots, name == "Q")
      if not r.ids then return end
      if not sum then sum = { table.unpack(r.ids) }
      else for o = 1, #sum do sum[o] = c:op("add", sum[o], r.ids[o]) end end
    end
    if sum then c:set_piece(name, index1, sum) end
    return sum ~= nil
  end
  local lab = engine.labels
  local have = {}
  have.F = piece("F", engine.F, lab.F, 2, 1)
  have.T = piece("T", engine.T, lab.T, 2, 1)
  have.V = piece("V", engine.V, lab.V, 1, 1)
  have.Q = piece("Q", engine.Q, lab.Q, 2, 1)
  for r, f in ipairs(engine.constraints) do
    piece("constraints", { f }, { lab.constraints[r] }, levels[r] or 4, r)
  end
  -- M and h from the graphs when every piece they need is recorded.
  local function ok(name) return #engine[name] == 0 or have[name] end
  engine.compiled = c
  engine.compiled_params = names
  engine.compiled_mass_bias = #engine.F > 0 and ok("F") and ok("V") and ok("Q")
  report.seconds = os.clock() - clock
  report.nodes = c:info().nodes
  return report
end

-- What of T, V, Q (or L, the forces) runs in Lua, as "V: why" text, or nil
-- when M and h come whole from the graph.  Readers of the graph (sys:show,
-- sys:export) must refuse then: the graph's M and h would lack that piece
-- and print or export wrong equations without a word.
function M.mass_bias_in_lua(sys)
  local e = sys.engine
  if not e.compiled then return "every function runs in Lua (the system was made with compile = false)" end
  if e.compiled_mass_bias then return nil end
  local parts = {}
  for _, r in ipairs(sys.recording or {}) do
    if not r.compiled and not r.label:find("^constraint") then parts[#parts + 1] = ("%s runs in Lua: %s"):format(r.label, r.why) end
  end
  return #parts > 0 and table.concat(parts, "; ") or "a piece of T, V or Q runs in Lua (print(sys) says which)"
end

-- ------------------------------------------------------------------ --
-- Functions of the state (simulate's event functions)                  --

-- Record functions f(t, q, qd, params) of engine's state, each returning a
-- number, into a graph of their own (inputs numbered as the system's:
-- src/mech/mech_graph.h), each checked against its function at the sample
-- state as a system's functions are.  Returns { compiled =, nodes = {one
-- node per function}, params = {names}, values = {their values now} }, or
-- nil, the index of the first function that cannot be recorded, and why.
function M.state_functions(engine, list)
  local k = engine.k
  local names, index = recorded_params(engine.params)
  local values = {}
  for p, name in ipairs(names) do values[p] = engine.params[name] end
  local c = core.mech.compiled_new(k, #names, 0, 2)
  local pproxy = param_proxy(c, engine.params, index)
  local nodes = {}
  for i, f in ipairs(list) do
    local ids, why = record_function(c, f, 2, k, pproxy, false)
    if ids then
      local ok, bad = check(c, f, ids, 2, k, names, engine.params)
      if not ok then ids, why = nil, bad end
    end
    if not ids then return nil, i, why end
    nodes[i] = ids[1]
  end
  return { compiled = c, nodes = nodes, params = names, values = values }
end

-- ------------------------------------------------------------------ --
-- The differential check (NZ_GRAPH_CHECK=1 in the environment)         --

-- Every compiled piece against the Lua evaluator on the same jets: values,
-- jets of orders 0..8 with 0..3 tangents, and a state direction, at states
-- around the sample.  The test suite runs with it on, so that every system
-- the tests define is checked this way; an error names the piece.
M.DIFF_TOL = 1e-13

local function random_jet(v, K, D)
  local c = { v, order = K }
  for j = 1, K do c[j + 1] = (math.random() - 0.5) * 0.6 ^ j end
  if D > 0 then
    c.tangents = {}
    for d = 1, D do
      c.tangents[d] = {}
      for j = 1, K + 1 do c.tangents[d][j] = (math.random() - 0.5) * 0.6 ^ (j - 1) end
    end
  end
  return core.jet(c)
end

local function jets_worst(a, b)
  local w = 0
  for o = 1, #b do
    for d = 0, b[o]:ntangents() do
      local sa = d == 0 and a[o] or a[o]:tangent(d)
      local sb = d == 0 and b[o] or b[o]:tangent(d)
      local scale = 1
      for j = 0, sb:order() do scale = math.max(scale, math.abs(sb:coef(j))) end
      for j = 0, sb:order() do w = math.max(w, math.abs(sa:coef(j) - sb:coef(j)) / scale) end
    end
  end
  return w
end

function M.diff_check(engine, levels, name)
  if not engine.compiled then return end
  local lua_engine = {}
  for key, v in pairs(engine) do lua_engine[key] = v end
  lua_engine.compiled, lua_engine.compiled_mass_bias = nil, nil
  local mech = core.mech
  local pieces = {}
  for _, p in ipairs{ "F", "T", "V", "Q" } do
    if #engine[p] > 0 then pieces[#pieces + 1] = { p, 1, p == "V" and 1 or 2 } end
  end
  for r = 1, #engine.constraints do pieces[#pieces + 1] = { "constraints", r, levels[r] or 4 } end
  for _, pc in ipairs(pieces) do
    -- a piece that runs in Lua on both sides has nothing to compare
    for trial = 0, engine.compiled:piece_nodes(pc[1], pc[2]) > 0 and 8 or -1 do
      local K, D = trial, trial % 4
      local tj = random_jet(SAMPLE_T + math.random() - 0.5, K, D)
      local lv, dlv = {}, {}
      for j = 1, pc[3] do
        lv[j], dlv[j] = {}, {}
        for i = 1, engine.k do
          lv[j][i] = random_jet(sample(j - 1, i) + 0.4 * (math.random() - 0.5), K, D)
          dlv[j][i] = random_jet(math.random() - 0.5, K, D)
        end
      end
      local dt = random_jet(math.random() - 0.5, K, D)
      local oka, va, da = pcall(mech.piece, engine, pc[1], pc[2], tj, lv, dt, dlv)
      local okb, vb, db = pcall(mech.piece, lua_engine, pc[1], pc[2], tj, lv, dt, dlv)
      if rawequal(va, core.interrupted) or rawequal(vb, core.interrupted) then error(core.interrupted, 0) end
      if oka and okb then
        local e = math.max(jets_worst(va, vb), jets_worst(da, db))
        if e > M.DIFF_TOL then
          error(("NZ_GRAPH_CHECK: system '%s': %s %d differs from the Lua evaluation by %.3g (order %d, %d tangents)")
            :format(name, pc[1], pc[2], e, K, D), 0)
        end
      end
    end
  end
end

return M
