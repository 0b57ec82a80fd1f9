-- nz/model/record_check.lua - a recording against its function (nz/model/record.lua):
-- the function run by the Lua evaluator, the path of compile = false, on
-- jets with tangents and along a state direction, at two states (or, for
-- simulate's event functions, on numbers, as the loop calls them); and,
-- where they differ, what the function reads besides its arguments, found
-- by running it on tracers once more under a call hook (a type test, a
-- table of its own keyed by the state, a counter, math.random).
local core = require "nz.core"
local is_library = require("nz.base.where").is_library

local M = {}

-- Relative agreement a recording must show with its function.
M.TOL = 1e-9

-- The recorder's own: is_tr(x) (a tracer?) and record_function(c, f,
-- nslots, k, params, index, is_Q, hook) (nz/model/record.lua), set by it.
local is_tr, record_function
function M.bind(recorder)
  is_tr, record_function = recorder.is_tr, recorder.record_function
end

-- ------------------------------------------------------------------ --
-- What a function reads besides its arguments (a failed check)        --

-- Functions whose call on a tracer, or at all, explains why a function
-- answers differently from its recording.
local WATCH = {
  [type] = "tests type() of a traced value", [math.type] = "tests math.type() of a traced value",
  [getmetatable] = "reads the metatable of a traced value (getmetatable)",
  [debug.getmetatable] = "reads the metatable of a traced value (debug.getmetatable)",
  [rawequal] = "compares a traced value with rawequal", [rawlen] = "takes rawlen of a traced value",
  [rawget] = "indexes a table with rawget", [next] = "iterates a table with next",
  [core.isjet] = "tests nz.isjet on a traced value",
}
local ALWAYS = { [math.random] = "calls math.random", [os.clock] = "reads the clock (os.clock)",
                 [os.time] = "reads the time (os.time)", [os.getenv] = "reads the environment (os.getenv)" }

-- The upvalues of f: {name = value}, and a table's own name in them.
local function upvalues(f)
  local out = {}
  for i = 1, 255 do
    local name, v = debug.getupvalue(f, i)
    if not name then break end
    out[#out + 1] = { name = name, v = v }
  end
  return out
end

-- Runs f once more on tracers, watching: the calls above, tables among its
-- upvalues that gain traced values as keys, numbers among them that
-- change.  Returns what it found, as text: type tests, and state of the
-- function's own (each nil when nothing).
local function diagnose(f, nslots, k, params, index, is_Q)
  local found = { tests = {}, state = {} }
  local seen = {}
  local function note(list, text)
    if not seen[text] and #list < 3 then seen[text] = true; list[#list + 1] = text end
  end
  -- a call made by the user's code itself (the library calls some of
  -- these on tracers too)
  local function hook()
    local info = debug.getinfo(2, "f")
    local fn = info and info.func
    if not (ALWAYS[fn] or WATCH[fn]) then return end
    local caller = debug.getinfo(3, "Sl")
    if not caller or caller.currentline <= 0 or is_library(caller.source) then return end
    local at = ("%s:%d"):format(caller.short_src, caller.currentline)
    if ALWAYS[fn] then return note(found.state, ALWAYS[fn] .. " at " .. at) end
    for a = 1, 3 do
      local _, v = debug.getlocal(2, a)
      if is_tr(v) then return note(found.tests, WATCH[fn] .. " at " .. at) end
    end
  end
  local before = upvalues(f)
  local np = 0
  for _ in pairs(index) do np = np + 1 end
  local c = core.mech.recording_new(k, np, 0, nslots)
  pcall(record_function, c, f, nslots, k, params, index, is_Q, hook)
  for i, u in ipairs(upvalues(f)) do
    local old = before[i] and before[i].v
    if type(u.v) == "table" then
      for key in pairs(u.v) do
        if is_tr(key) then note(found.state, ("keeps traced values as keys of its table '%s' (an upvalue): a "
          .. "lookup keyed by the state, whose entries pile up call after call"):format(u.name)) break end
      end
    elseif type(u.v) == "number" and type(old) == "number" and old ~= u.v then
      note(found.state, ("changes its upvalue '%s' at every call (a counter)"):format(u.name))
    end
  end
  local function text(list) return #list > 0 and table.concat(list, "; ") or nil end
  return text(found.tests), text(found.state)
end

-- Why a function answers differently from its recording, from what
-- diagnose found: a type test (the function tells a tracer from a jet), or
-- state of its own (a counter, math.random, a table it fills).
local function explain(tests, state)
  local parts = {}
  if tests then parts[#parts + 1] = "it tells the traced values of its recording from jets: it " .. tests end
  if state then parts[#parts + 1] = "it depends on something other than its arguments: it " .. state end
  if #parts == 0 then
    parts[1] = "it depends on something other than its arguments (a global or an upvalue that changes, "
      .. "math.random, a counter)"
  end
  return table.concat(parts, "; ")
end

-- ------------------------------------------------------------------ --
-- Checking a recording against its function                           --

-- A state that is not special (no zeros, no symmetries), for slot j of q_i;
-- s moves it for the second check.
local function sample(j, i, s) return 0.31 + 0.17 * i - 0.043 * j + 0.011 * i * j + (s or 0) end
local SAMPLE_T = 0.23
M.sample, M.SAMPLE_T = sample, SAMPLE_T

-- A fixed sequence in (-0.5, 0.5) (a recording is the same every time).
local function wobble(n) return (n * 0.6180339887498949) % 1 - 0.5 end

-- The jets of a check state: t and every slot of every q_i of order K with
-- D tangents, a state direction of the same shape, and the graph's inputs
-- (params by their values) and their directions.
local CHECK_K, CHECK_D = 2, 2
local function check_jets(nslots, k, names, params, s)
  local n = 0
  local function jet(v)
    local c = { v, order = CHECK_K, tangents = {} }
    for j = 1, CHECK_K do n = n + 1; c[j + 1] = wobble(n) * 0.5 ^ j end
    for d = 1, CHECK_D do
      c.tangents[d] = {}
      for j = 1, CHECK_K + 1 do n = n + 1; c.tangents[d][j] = wobble(n) end
    end
    return core.jet(c)
  end
  local np = #names
  local tj, dt = jet(SAMPLE_T + s), jet(wobble(99))
  local inputs, dinputs = { [0] = tj }, { [0] = dt }
  for p, name in ipairs(names) do inputs[p] = params[name] end
  local lv, dlv = {}, {}
  for j = 0, nslots - 1 do
    lv[j + 1], dlv[j + 1] = {}, {}
    for i = 1, k do
      local at = 1 + np + j * k + (i - 1)
      lv[j + 1][i], dlv[j + 1][i] = jet(sample(j, i, s)), jet(wobble(at))
      inputs[at], dinputs[at] = lv[j + 1][i], dlv[j + 1][i]
    end
  end
  return tj, lv, dt, dlv, inputs, dinputs
end

-- Where jets a and b (or numbers) differ beyond the tolerance: nil, or what
-- differs and the two numbers (a's, b's).
local function differ(a, b, along)
  local function series(x, d)
    if type(x) == "number" then return function(j) return (d == 0 and j == 0) and x or 0 end end
    local s = d == 0 and x or x:tangent(d)
    return function(j) return j <= s:order() and s:coef(j) or 0 end
  end
  local D = math.max(core.isjet(a) and a:ntangents() or 0, core.isjet(b) and b:ntangents() or 0)
  local K = math.max(core.isjet(a) and a:order() or 0, core.isjet(b) and b:order() or 0)
  for d = 0, D do
    local sa, sb = series(a, d), series(b, d)
    local scale = 1
    for j = 0, K do scale = math.max(scale, math.abs(sa(j)), math.abs(sb(j))) end
    for j = 0, K do
      local x, y = sa(j), sb(j)
      if not (math.abs(x - y) <= M.TOL * scale) then
        local what = d > 0 and "a derivative (tangent)" or j == 0 and "its value" or ("Taylor coefficient " .. j)
        return (along and "the derivative along a state direction of " or "") .. what, x, y
      end
    end
  end
end

-- The pieces of the mechanics (lua_system.c) a function can be checked as.
local PIECE_OF = { F = "F", T = "F", V = "V", Q = "Q", constraints = "constraints" }

-- The recording of f (node ids) against the Lua evaluator running f (the
-- path of compile = false) on jets with tangents and along a state
-- direction, at two states: true, or false and the reason.  A state where
-- either fails gives no verdict (an evaluation that fails goes to the Lua
-- function anyway, which says why).
function M.jets(c, f, ids, nslots, k, names, params, index, piece)
  local name = PIECE_OF[piece]
  local engine = { k = k, name = "check", params = params, F = {}, T = {}, V = {}, Q = {}, S = {}, constraints = {},
    labels = { F = { "f" }, T = {}, V = { "f" }, Q = { "f" }, S = {}, constraints = { "f" } } }
  engine[name] = { f }
  if name == "constraints" then engine.constraint_levels = core.mech.constraint_levels({ nslots }) end
  -- jets at one state, dualjets along a direction at another (what the
  -- evaluator passes then, and a function may tell them from jets)
  for s = 0, 1 do
    local tj, lv, dt, dlv, inputs, dinputs = check_jets(nslots, k, names, params, 0.137 * s)
    if s == 0 then dt, dlv, dinputs = nil, nil, nil end
    local ok, want, dwant = pcall(core.mech.piece, engine, name, 1, tj, lv, dt, dlv)
    if not ok and rawequal(want, core.interrupted) then error(want, 0) end
    local got, dgot = nil, nil
    if ok then got, dgot = c:eval_jets(ids, inputs, dinputs) end
    if got then
      for o = 1, #ids do
        local what, gv, lv1 = differ(got[o], want[o])
        if not what and dt then what, gv, lv1 = differ(dgot[o], dwant[o], true) end
        if what then
          return false, ("gives %.17g where its recording gives %.17g in %s at a check state: %s")
            :format(lv1, gv, what, explain(diagnose(f, nslots, k, params, index, piece == "Q")))
        end
      end
    end
  end
  return true
end

-- The same on plain numbers, for the functions the stepping loop calls with
-- numbers (simulate's event functions).
function M.numbers(c, f, ids, nslots, k, names, params, index)
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
  local a, b = got[1], res
  if type(b) ~= "number" or math.abs(a - b) > M.TOL * math.max(1, math.abs(a), math.abs(b)) then
    local why = explain(diagnose(f, nslots, k, params, index, false))
    return false, ("gives %s on numbers where its recording gives %.17g at a sample state: %s"):format(tostring(b), a, why)
  end
  return true
end

return M
