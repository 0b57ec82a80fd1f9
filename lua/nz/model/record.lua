-- nz/model/record.lua - record a system's functions once as an expression graph,
-- evaluated in C from then on (src/graph/graph.c, src/mech/mech_graph.c).
--
-- Each function (T, V, L, Q, each constraint) runs once on tracer values:
-- t, every derivative slot of every q_i and every named number in params
-- are graph inputs, and every operation on a tracer adds a node; the branch
-- functions (nz.gt, nz.ifelse, nz.max, nz.min, nz.clamp, nz.sign) add
-- comparison and selection nodes.  A tracer stands for the jet the Lua
-- evaluator passes: it is a userdata (type(x) is "userdata"), nz.isjet(x) is
-- true, and what a jet can do that a graph cannot hold -- a Lua comparison
-- (a Lua branch on the state), a jet method (x:coef(0)), math.* on it,
-- text -- stops that function's recording, even when the function catches
-- the error with pcall: it keeps the Lua evaluation, and the reason, with
-- the user's file:line, is kept for print(sys).
--
-- params are read through tracers however the function reaches them: while
-- a function is recorded, the user's params table itself answers with
-- tracers (sys.params is the table given to nz.system, which a function may
-- also read through an upvalue); a name read while absent is noted, and the
-- system records again when it appears (lua_system.c's binding).  A number
-- the function reads from any other upvalue or global is baked into the
-- graph as a constant.  Each recording is then checked against the Lua
-- function on jets with tangents at two states (nz/model/record_check.lua); where
-- they differ the function stays in Lua, with what was found (a type test,
-- a table keyed by the state, a counter, math.random).
local core = require "nz.core"
local is_library = require("nz.base.where").is_library

local M = {}

-- The check of each recording against its function (nz/model/record_check.lua).
local checks = require "nz.model.record_check"
local sample, SAMPLE_T = checks.sample, checks.SAMPLE_T

-- ------------------------------------------------------------------ --
-- Tracers                                                              --

-- The recording under way: its graph c, the node of each tracer, the
-- first operation it could not record (failed), the params read while
-- absent.  One at a time; record_function saves and restores it.
local rec

local TR = { __name = "nz.traced" }
local new_tracer = core.mech.tracer
local function is_tr(x) return getmetatable(x) == TR end
-- A tracer of node id; `num`: it stands for a number in Lua (a parameter,
-- or made of parameters and numbers only), which the jets treat as such.
local function wrap(id, num)
  local u = new_tracer(TR)
  rec.node[u] = id
  if num then rec.num[u] = true end
  return u
end
local function is_num(x) return type(x) == "number" or (rec ~= nil and rec.num[x] == true) end
-- The graph under way; a tracer kept (in a global, an upvalue) and used
-- after its recording ended has none.
local function graph()
  if not rec then
    error("a traced value kept from a recording is used after it ended (a global or an upvalue set while "
      .. "the function was recorded)", 3)
  end
  return rec.c
end

-- file:line of the first frame (from `level` up) that is the user's code.
local function user_location(level)
  for l = level, 60 do
    local info = debug.getinfo(l, "Sl")
    if not info then break end
    if info.currentline > 0 and not is_library(info.source) and info.source ~= "=[C]" then
      return ("%s:%d"):format(info.short_src, info.currentline)
    end
  end
end

-- An operation the graph cannot hold.  The recording fails even if the
-- function catches the error (pcall), since Lua, on jets, would have gone
-- on with an answer: the first such operation is the reason.
local function untraceable(msg)
  if rec and not rec.failed then
    local where = user_location(3)
    rec.failed = where and (msg .. " at " .. where) or msg
  end
  error(msg, 0)
end

local function kind(x)
  if core.isjet(x) and not is_tr(x) then return "jet" end
  return type(x)
end

local function node_of(x)
  graph()
  local id = rec.node[x]
  if not id then untraceable("uses a traced value kept from another recording (a global or upvalue set while recording)") end
  return id
end

local function operand(x)
  if is_tr(x) then return node_of(x) end
  if type(x) == "number" then
    -- a jet refuses them (lua_jet.c: "got NaN"), and so the function fails
    -- in Lua wherever it meets one: it runs there, raising its error
    if x ~= x or x == math.huge or x == -math.huge then
      untraceable(("meets the number %s, which a jet refuses"):format(tostring(x)))
    end
    return graph():const(x)
  end
  untraceable(("arithmetic of a traced value with a %s"):format(kind(x)))
end

-- A number type of its own on the other side (nz/model/hyperdual.lua) takes the
-- call, as it does for jets.
local function foreign(a, b, field)
  local other = is_tr(a) and b or a
  if type(other) == "table" then
    local mt = getmetatable(other)
    return mt and mt[field]
  end
end

local function binop(name, field)
  return function(a, b)
    local f = foreign(a, b, field)
    if f then return f(a, b) end
    return wrap(graph():op(name, operand(a), operand(b)), is_num(a) and is_num(b))
  end
end

TR.__add = binop("add", "__add")
TR.__sub = binop("sub", "__sub")
TR.__mul = binop("mul", "__mul")
TR.atan2 = binop("atan2", "atan2")
TR.hypot = binop("hypot", "hypot")
-- A jet divided by a number is the jet times 1/number (lua_jet.c), which
-- rounds otherwise than x / s: so is the recording, for a number and for a
-- parameter (a number in Lua).
local div = binop("div", "__div")
TR.__div = function(a, b)
  if is_tr(a) and not is_num(a) and is_num(b) and not foreign(a, b, "__div") then
    if b == 0 then untraceable("divides a traced value by zero") end
    local c = graph()
    local inv = type(b) == "number" and c:const(1 / b) or c:op("div", c:const(1), node_of(b))
    return wrap(c:op("mul", node_of(a), inv))
  end
  return div(a, b)
end
local pow = binop("pow", "__pow")
TR.__pow = function(a, b)
  if is_tr(a) and type(b) == "number" then return wrap(graph():powc(node_of(a), b), is_num(a)) end
  return pow(a, b)
end
TR.__unm = function(a) return wrap(graph():op("neg", node_of(a)), is_num(a)) end
for _, name in ipairs{ "exp", "log", "sqrt", "sin", "cos", "tan", "asin", "acos", "atan",
                       "sinh", "cosh", "tanh", "abs", "sign" } do
  TR[name] = function(x) return wrap(graph():fn(name, node_of(x)), is_num(x)) end
end
-- nz.isjet(x) is true: the Lua evaluator passes jets (lua_jet.c dispatches)
TR.isjet = function() return true end

-- Branches written without a Lua `if` (nz.lt ... nz.clamp, src/lua/lua_jet.c):
-- nz.* hands the call to the first argument whose metatable has the field,
-- so a tracer may be any of the arguments; the others are numbers.  The
-- same choices as the jets: max and min keep the first operand at a tie,
-- clamp keeps x at a tie with a bound.
local function branch_operand(x, fname)
  if type(x) == "boolean" then
    untraceable(("nz.%s got a boolean (a Lua comparison such as x > 0 cannot be recorded): "
      .. "write the condition with nz.gt(x, 0), nz.lt, nz.ge or nz.le"):format(fname))
  end
  return operand(x)
end

for _, name in ipairs{ "lt", "le", "gt", "ge" } do
  TR[name] = function(a, b)
    return wrap(graph():cmp(name, branch_operand(a, name), branch_operand(b, name)), is_num(a) and is_num(b))
  end
end

-- ifelse(cond, a, b): a where cond ~= 0, else b (a constant cond chooses now).
function TR.ifelse(cond, a, b)
  return wrap(graph():select(branch_operand(cond, "ifelse"), branch_operand(a, "ifelse"), branch_operand(b, "ifelse")),
    is_num(cond) and is_num(a) and is_num(b))
end

local function extremum(cmp, fname)
  return function(a, b)
    local ia, ib = branch_operand(a, fname), branch_operand(b, fname)
    return wrap(graph():select(graph():cmp(cmp, ia, ib), ia, ib), is_num(a) and is_num(b))
  end
end
TR.max = extremum("ge", "max")   -- max(a, b) = select(a >= b, a, b)
TR.min = extremum("le", "min")   -- min(a, b) = select(a <= b, a, b)

-- clamp(x, lo, hi) = lo where x < lo, hi where x > hi, else x; lo <= hi is
-- checked now when the bounds are numbers.  Bounds that are traced (params,
-- the state) would need that check at every evaluation, which a graph does
-- not make: such a clamp stays in Lua, and min(max(x, lo), hi) records.
function TR.clamp(x, lo, hi)
  local c = graph()
  local ix, ilo, ihi = branch_operand(x, "clamp"), branch_operand(lo, "clamp"), branch_operand(hi, "clamp")
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
  return wrap(c:select(c:cmp("gt", ix, ihi), ihi, below), is_num(x))
end

local BRANCH = "compares a traced value (a Lua branch on the state cannot be recorded): "
  .. "write it with nz.ifelse and nz.gt/lt/ge/le, nz.max, nz.min, nz.clamp or nz.sign"
TR.__lt = function() untraceable(BRANCH) end
TR.__le = TR.__lt
TR.__eq = TR.__lt
-- The methods of a jet (lua_jet.c): they read the series itself.
local JET_METHODS = { coef = true, deriv = true, order = true, value = true, ntangents = true,
                      tangent = true, coefs = true, derivative = true }
TR.__index = function(_, key)
  if JET_METHODS[key] then
    untraceable(("calls the jet method '%s' (x:%s(...) reads the series of a jet, which a recording "
      .. "cannot hold; write the function with the nz.* operations on x itself)"):format(key, key))
  end
  untraceable(("reads field '%s' of a traced value"):format(tostring(key)))
end
TR.__newindex = function() untraceable("writes into a traced value") end
TR.__len = function() untraceable("takes the length of a traced value") end
TR.__concat = function() untraceable("makes text of a traced value") end
TR.__call = function() untraceable("calls a traced value") end
TR.__tostring = TR.__concat
TR.__idiv = function() untraceable("floor-divides a traced value (not differentiable)") end
TR.__mod = function() untraceable("takes a traced value modulo (not differentiable)") end

-- ------------------------------------------------------------------ --
-- The params table while a function is recorded                       --

-- While f runs on tracers, the user's params table (sys.params, which f
-- may read as its argument, an upvalue or a global) holds no value of its
-- own: its metatable answers a recorded parameter with its tracer, refuses
-- what is not a number, a write and an iteration, and notes a name read
-- while absent (p.c or 1).  Returns the function that puts the table back
-- as it was (entries and metatable).
local function trace_params(params, index)
  local saved, tracers = {}, {}
  for key, v in next, params do saved[key] = v end
  for key in pairs(saved) do rawset(params, key, nil) end
  local own = debug.getmetatable(params)
  local own_index = own and own.__index
  debug.setmetatable(params, {
    __index = function(_, key)
      local p = index[key]
      if p then
        tracers[key] = tracers[key] or wrap(rec.c:param(p), true)
        return tracers[key]
      end
      local v = saved[key]
      if v ~= nil then untraceable(("reads params.%s, a %s: only numbers are recorded"):format(tostring(key), type(v))) end
      if own_index ~= nil then
        local d
        if type(own_index) == "function" then d = own_index(params, key) else d = own_index[key] end
        if d ~= nil then
          untraceable(("reads params.%s, which is not in params but comes from the __index of its metatable "
            .. "(a default): put it in params (sys.params.%s = ...) to make it a parameter"):format(tostring(key), tostring(key)))
        end
      end
      if type(key) == "string" then rec.absent[key] = true end
      return nil
    end,
    __newindex = function(_, key) untraceable(("writes params.%s"):format(tostring(key))) end,
    __pairs = function() untraceable("iterates over params") end,
  })
  return function()
    debug.setmetatable(params, own)
    for key, v in pairs(saved) do rawset(params, key, v) end
  end
end

-- ------------------------------------------------------------------ --
-- Running a function on tracers                                        --

-- The reason a recording stopped, with the user's file:line.
local function handler(e)
  if rawequal(e, core.interrupted) then return e end   -- Ctrl-C stays Ctrl-C
  if rec.failed then return rec.failed end
  local where = user_location(2)
  local msg = tostring(e)
  if where and msg:sub(1, #where + 2) == where .. ": " then msg = msg:sub(#where + 3) end
  -- math.* on a tracer: "number expected, got nz.traced" (its __name)
  if msg:find("number expected, got nz.traced", 1, true) then
    msg = msg .. " (math.* takes numbers only: use nz.sin, nz.sqrt, nz.abs, ... on the state)"
  end
  return where and (msg .. " at " .. where) or msg
end

-- The node of a returned value, or nil and why.
local function result_node(v)
  if is_tr(v) then return node_of(v) end
  if type(v) == "number" then
    if v ~= v or v == math.huge or v == -math.huge then return nil, "returns a value that is not finite" end
    return rec.c:const(v)
  end
  return nil, ("returns a %s"):format(kind(v))
end

-- Run f on tracers into graph c (params: the user's table, index: the
-- input of each recorded parameter).  Returns its nodes (1, or k for Q) or
-- nil and the reason, and the names of params read while absent.  `hook`
-- (the diagnosis) runs as a call hook meanwhile.
-- f's result as nodes: (1, or k for Q), or nil and why.
local function result_nodes(res, k, is_Q)
  if not is_Q then
    local id, why = result_node(res)
    if not id then return nil, why end
    return { id }
  end
  if type(res) ~= "table" or getmetatable(res) ~= nil or #res ~= k then
    return nil, "does not return a list of " .. k .. " forces"
  end
  local ids = {}
  for i = 1, k do
    local id, why = result_node(res[i])
    if not id then return nil, ("force %d %s"):format(i, why) end
    ids[i] = id
  end
  return ids
end

local function record_function(c, f, nslots, k, params, index, is_Q, hook)
  local outer = rec
  rec = { c = c, node = setmetatable({}, { __mode = "k" }), num = setmetatable({}, { __mode = "k" }), absent = {} }
  local this = rec
  local restore = trace_params(params, index)
  -- whatever happens below (out of memory, Ctrl-C), the params table and
  -- the recording under way are put back
  local okr, ok, res = pcall(function()
    local args = { wrap(c:time()) }
    for j = 0, nslots - 1 do
      local level = {}
      for i = 1, k do level[i] = wrap(c:slot(j, i)) end
      args[j + 2] = level
    end
    args[nslots + 2] = params
    -- the nodes as Lua computes them on jets, bit for bit (graph.h)
    c:set_exact(true)
    if hook then debug.sethook(hook, "c") end
    local ok1, res1 = xpcall(f, handler, table.unpack(args, 1, nslots + 2))
    if hook then debug.sethook() end
    c:set_exact(false)
    return ok1, res1
  end)
  if hook then debug.sethook() end
  c:set_exact(false)
  restore()
  if not okr then rec = outer; error(ok, 0) end
  if not ok then
    rec = outer
    if rawequal(res, core.interrupted) then error(res, 0) end
    return nil, res, this.absent
  end
  -- caught by the function's own pcall: the first untraceable operation
  if this.failed then rec = outer; return nil, this.failed, this.absent end
  local okn, ids, why = pcall(result_nodes, res, k, is_Q)
  rec = outer
  if not okn then return nil, tostring(ids), this.absent end
  return ids, why, this.absent
end

checks.bind{ is_tr = is_tr, record_function = record_function }

-- ------------------------------------------------------------------ --
-- A system                                                             --

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
M.recorded_params = recorded_params

-- Record what can be recorded of engine (the definition table the C
-- mechanics reads; lua/nz/system.lua): sets engine.recording,
-- engine.recording_params, engine.recorded_mass_bias, engine.params_absent
-- (the names of params read while absent, which lua_system.c watches) and
-- returns the report { {label =, recorded =, why =, nodes =}, ...,
-- seconds =, nodes = }.
function M.record_system(engine, levels, native)
  local clock = os.clock()
  local k = engine.k
  local names, index = recorded_params(engine.params)
  engine.record_levels, engine.record_native = levels, native
  -- two slots more than any function reads: the rows of the constraints
  -- differentiate them twice along the motion (src/mech/mech_graph.c)
  local nslots = 2
  for _, n in ipairs(levels) do nslots = math.max(nslots, n) end
  nslots = nslots + 2
  local c = core.mech.recording_new(k, #names, #engine.constraints, nslots)
  if native ~= nil then c:set_native(native) end

  local done, report, absent = {}, { seconds = 0 }, {}
  -- Each function once (T's functions are also F's), with its verdict.
  local function record(f, label, slots, piece_name)
    if done[f] then return done[f] end
    local is_Q = piece_name == "Q"
    local ids, why, read_absent = record_function(c, f, slots, k, engine.params, index, is_Q)
    for name in pairs(read_absent) do absent[name] = true end
    if ids then
      local ok, bad = checks.jets(c, f, ids, slots, k, names, engine.params, index, piece_name)
      if not ok then ids, why = nil, bad end
    end
    done[f] = { ids = ids, why = why, label = label }
    report[#report + 1] = { label = label, recorded = ids ~= nil, why = why }
    return done[f]
  end
  -- A piece is compiled when every one of its functions is: the sum of theirs.
  local function piece(name, list, labels, slots, index1)
    local sum
    for fi, f in ipairs(list) do
      local r = record(f, labels[fi] or name, slots, name)
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
  engine.recording = c
  engine.recording_params = names
  engine.recorded_mass_bias = #engine.F > 0 and ok("F") and ok("V") and ok("Q")
  local list = {}
  for name in pairs(absent) do list[#list + 1] = name end
  table.sort(list)
  engine.params_absent = list
  engine.record_again = M.record_again
  report.seconds = os.clock() - clock
  report.nodes = c:info().nodes
  engine.record_report = report
  return report
end

-- Called by the binding (lua_system.c) when a name the functions read
-- while it was absent from params is there now: record again, so that the
-- new parameter is an input, and say so in the report (print(sys)).  The
-- report is updated in place (the system holds it); the graphs recorded
-- before stay alive with the engine (a call further up may still be using
-- them).
function M.record_again(engine)
  local added = {}
  for _, name in ipairs(engine.params_absent or {}) do
    if engine.params[name] ~= nil then added[#added + 1] = "params." .. name end
  end
  engine.retired = engine.retired or {}
  engine.retired[#engine.retired + 1] = engine.recording
  local old = engine.record_report
  local report = M.record_system(engine, engine.record_levels, engine.record_native)
  if old then
    for key in pairs(old) do old[key] = nil end
    for key, v in pairs(report) do old[key] = v end
    engine.record_report = old
  end
  engine.record_report.again = ("recorded again: %s %s added after the system was made (read while absent "
    .. "when it was recorded)"):format(table.concat(added, ", "), #added == 1 and "was" or "were")
  -- the parameters each call checks: now with the new ones
  local names = recorded_params(engine.params)
  engine.param_names = names
end

-- What of T, V, Q (or L, the forces) runs in Lua, as "V: why" text, or nil
-- when M and h come whole from the graph.  Readers of the graph (sys:show,
-- sys:export) must refuse then: the graph's M and h would lack that piece
-- and print or export wrong equations without a word.
function M.mass_bias_in_lua(sys)
  local e = sys.engine
  if not e.recording then return "every function runs in Lua (the system was made with compile = false)" end
  if e.recorded_mass_bias then return nil end
  local parts = {}
  for _, r in ipairs(sys.recording or {}) do
    if not r.recorded and not r.label:find("^constraint") then parts[#parts + 1] = ("%s runs in Lua: %s"):format(r.label, r.why) end
  end
  return #parts > 0 and table.concat(parts, "; ") or "a piece of T, V or Q runs in Lua (print(sys) says which)"
end

-- ------------------------------------------------------------------ --
-- Functions of the state (simulate's event functions)                  --

-- Record functions f(t, q, qd, params) of engine's state, each returning a
-- number, into a graph of their own (inputs numbered as the system's:
-- src/mech/mech_graph.h), each checked against its function at the sample
-- state on numbers, as the loop calls them where a graph fails.  Returns { recording =,
-- nodes = {one node per function}, params = {names}, values = {their
-- values now} }, or nil, the index of the first function that cannot be
-- recorded, and why.
function M.state_functions(engine, list)
  local k = engine.k
  local names, index = recorded_params(engine.params)
  local values = {}
  for p, name in ipairs(names) do values[p] = engine.params[name] end
  local c = core.mech.recording_new(k, #names, 0, 2)
  local nodes = {}
  for i, f in ipairs(list) do
    local ids, why = record_function(c, f, 2, k, engine.params, index, false)
    if ids then
      local ok, bad = checks.numbers(c, f, ids, 2, k, names, engine.params, index)
      if not ok then ids, why = nil, bad end
    end
    if not ids then return nil, i, why end
    nodes[i] = ids[1]
  end
  return { recording = c, nodes = nodes, params = names, values = values }
end

-- ------------------------------------------------------------------ --
-- The differential check (NZ_GRAPH_CHECK=1 in the environment)         --

-- Every compiled piece against the Lua evaluator on the same jets: values,
-- jets of orders 0..8 with 0..3 tangents, and a state direction, at states
-- around the sample.  The test suite runs with it on, so that every system
-- the tests define is checked this way; an error names the piece.
M.DIFF_TOL = 1e-13

-- A random jet around the value v (order K, D tangents) and the worst
-- difference of two lists of jets relative to each series' size: the
-- differential check below and tests/graph_diff_spec.lua compare the
-- recording with the Lua evaluator with them.
function M.random_jet(v, K, D)
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

function M.jets_worst(a, b)
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
  if not engine.recording then return end
  local lua_engine = {}
  for key, v in pairs(engine) do lua_engine[key] = v end
  lua_engine.recording, lua_engine.recorded_mass_bias = nil, nil
  local mech = core.mech
  local pieces = {}
  for _, p in ipairs{ "F", "T", "V", "Q" } do
    if #engine[p] > 0 then pieces[#pieces + 1] = { p, 1, p == "V" and 1 or 2 } end
  end
  for r = 1, #engine.constraints do pieces[#pieces + 1] = { "constraints", r, levels[r] or 4 } end
  for _, pc in ipairs(pieces) do
    -- a piece that runs in Lua on both sides has nothing to compare
    for trial = 0, engine.recording:piece_nodes(pc[1], pc[2]) > 0 and 8 or -1 do
      local K, D = trial, trial % 4
      local tj = M.random_jet(SAMPLE_T + math.random() - 0.5, K, D)
      local lv, dlv = {}, {}
      for j = 1, pc[3] do
        lv[j], dlv[j] = {}, {}
        for i = 1, engine.k do
          lv[j][i] = M.random_jet(sample(j - 1, i) + 0.4 * (math.random() - 0.5), K, D)
          dlv[j][i] = M.random_jet(math.random() - 0.5, K, D)
        end
      end
      local dt = M.random_jet(math.random() - 0.5, K, D)
      local oka, va, da = pcall(mech.piece, engine, pc[1], pc[2], tj, lv, dt, dlv)
      local okb, vb, db = pcall(mech.piece, lua_engine, pc[1], pc[2], tj, lv, dt, dlv)
      if rawequal(va, core.interrupted) or rawequal(vb, core.interrupted) then error(core.interrupted, 0) end
      if oka and okb then
        local e = math.max(M.jets_worst(va, vb), M.jets_worst(da, db))
        if e > M.DIFF_TOL then
          error(("NZ_GRAPH_CHECK: system '%s': %s %d differs from the Lua evaluation by %.3g (order %d, %d tangents)")
            :format(name, pc[1], pc[2], e, K, D), 0)
        end
      end
    end
  end
end

return M
